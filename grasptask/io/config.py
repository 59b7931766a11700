"""YAML configuration and JSON summaries, read and validated once at the edge."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml

from grasptask.errors import BadInputError


def load_yaml(path: str | Path) -> dict[str, Any]:
    path = Path(path)
    if not path.is_file():
        raise BadInputError(path, "config file not found")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        line = getattr(getattr(exc, "problem_mark", None), "line", None)
        raise BadInputError(
            path, f"invalid YAML: {getattr(exc, 'problem', exc)}", row=None if line is None else line + 1
        ) from exc
    if not isinstance(data, dict):
        raise BadInputError(path, "expected a mapping at the top level")
    return data


def read_json(path: str | Path) -> dict[str, Any]:
    """A JSON object from ``path``, or a one-line error naming the file."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BadInputError(path, f"not a readable JSON file ({type(exc).__name__})") from exc
    if not isinstance(data, dict):
        raise BadInputError(path, "expected a JSON object at the top level")
    return data


def require(mapping: dict[str, Any], key: str, source: str | Path, kind: type | tuple[type, ...] = object) -> Any:
    """``mapping[key]``, or a one-line error naming the file and field."""
    if key not in mapping:
        raise BadInputError(source, f"missing field '{key}'")
    value = mapping[key]
    if not isinstance(value, kind):
        expected = kind.__name__ if isinstance(kind, type) else " or ".join(k.__name__ for k in kind)
        raise BadInputError(source, f"field '{key}' must be {expected}, got {value!r}")
    return value


def reject_unknown(mapping: dict[str, Any], allowed: set[str], source: str | Path, where: str = "") -> None:
    unknown = sorted(set(mapping) - allowed)
    if unknown:
        raise BadInputError(source, f"unknown field '{where}{unknown[0]}' (allowed: {', '.join(sorted(allowed))})")
