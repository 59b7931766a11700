"""YAML configuration and JSON summaries, read and validated once at the edge."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from grasptask.errors import BadInputError, existing_file

#: the largest config file read; every bundled one is under 10 kB
MAX_CONFIG_BYTES = 1 << 20


class _NoAliasLoader(yaml.SafeLoader):
    """``yaml.safe_load`` without anchors and aliases: a few hundred bytes of nested aliases expand to
    gigabytes (a "billion laughs"), and no config needs them."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            raise yaml.MarkedYAMLError(problem="aliases (*name) are not allowed", problem_mark=event.start_mark)
        return super().compose_node(parent, index)


def load_yaml(path: str | Path) -> dict[str, Any]:
    """A YAML mapping from ``path`` (safe types only, no aliases), or a one-line error naming the file."""
    path = existing_file(path, "config file")
    if path.stat().st_size > MAX_CONFIG_BYTES:
        raise BadInputError(path, f"larger than {MAX_CONFIG_BYTES >> 20} MB: not a config file")
    try:
        data = yaml.load(path.read_text(), Loader=_NoAliasLoader)  # noqa: S506 - a SafeLoader subclass
    except UnicodeDecodeError as exc:
        raise BadInputError(path, "not a text file") from exc
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
    path = existing_file(path)
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


def number(value: Any, source: str | Path, name: str, *, positive: bool = False, minimum: float | None = None) -> float:
    """``value`` as a finite float, or a one-line error naming the field (``positive``: above 0)."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise BadInputError(source, f"field '{name}' must be a number, got {value!r}")
    if positive and not value > 0:
        raise BadInputError(source, f"field '{name}' must be positive, got {value!r}")
    if minimum is not None and value < minimum:
        raise BadInputError(source, f"field '{name}' must be at least {minimum:g}, got {value!r}")
    return float(value)


def whole(value: Any, source: str | Path, name: str, minimum: int = 0) -> int:
    """``value`` as an int of at least ``minimum``, or a one-line error naming the field."""
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise BadInputError(source, f"field '{name}' must be a whole number >= {minimum}, got {value!r}")
    return value


def numbers(value: Any, source: str | Path, name: str, length: int | None = None) -> np.ndarray:
    """A list of finite numbers (of ``length`` when given) as an array, or a one-line error naming the field."""
    if not isinstance(value, list | tuple) or (length is not None and len(value) != length):
        size = f"{length} numbers" if length is not None else "a list of numbers"
        raise BadInputError(source, f"field '{name}' must be {size}, got {value!r}")
    return np.array([number(v, source, f"{name}[{k + 1}]") for k, v in enumerate(value)], dtype=float)
