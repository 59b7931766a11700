"""YAML configuration and JSON summaries, read and validated once at the edge.

A config file's schema is a pydantic dataclass: its keys, their defaults and their checks declared once, in
the module that uses them, with the types below. :func:`validated` turns a file's mapping into it, and an
unknown key, a wrong type or a value out of range into the same one line naming the file and the key.
"""

from __future__ import annotations

import dataclasses
import json
import math
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, TypeVar

import numpy as np
import yaml
from pydantic import ConfigDict, Field, Strict, TypeAdapter, ValidationError

from grasptask.errors import BadInputError, existing_file

#: every schema's own settings: an unknown key is an error, and so is a NaN or an infinity
SCHEMA = ConfigDict(extra="forbid", allow_inf_nan=False)
#: a number, never text or true/false
Real = Annotated[float, Strict()]
#: a number >= 0
NonNegative = Annotated[float, Strict(), Field(ge=0)]
#: a number > 0
Positive = Annotated[float, Strict(), Field(gt=0)]
#: a number in [0, 1]
Fraction = Annotated[float, Strict(), Field(ge=0, le=1)]
#: a number in (0, 1]
Share = Annotated[float, Strict(), Field(gt=0, le=1)]
#: a whole number >= 0, never 1.0 or true
Count = Annotated[int, Strict(), Field(ge=0)]
#: true or false, never 1 or "yes"
Flag = Annotated[bool, Strict()]

T = TypeVar("T")

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
    """A YAML mapping from ``path`` (safe types only, no aliases), or a one-line error naming the file. A file
    with nothing but comments is the empty mapping: every key at its default."""
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
    if data is None and _only_comments(path):
        return {}
    if not isinstance(data, dict):
        raise BadInputError(path, "expected a mapping at the top level")
    return data


def _only_comments(path: Path) -> bool:
    lines = [line.strip() for line in path.read_text().splitlines()]
    return any(lines) and all(not line or line.startswith("#") for line in lines)


def validated(schema: type[T], data: Mapping[str, Any], source: str | Path) -> T:
    """``data`` as an instance of the pydantic dataclass ``schema``, or one line naming the file and the key."""
    try:
        return TypeAdapter(schema).validate_python(data)
    except ValidationError as exc:
        # a misspelt key explains a missing one, so an unknown key is named first
        errors = sorted(exc.errors(), key=lambda e: e["type"] not in ("unexpected_keyword_argument", "extra_forbidden"))
        raise BadInputError(source, _problem(schema, errors[0])) from None


def _problem(schema: type, error: Any) -> str:
    """One of pydantic's errors as this project's one line: ``field 'a.b': must be ..., got ...``."""
    loc = [part for part in error["loc"] if part != "__root__"]
    key = "".join(f"[{part + 1}]" if isinstance(part, int) else f".{part}" for part in loc).lstrip(".")
    message = str(error["msg"]).removeprefix("Value error, ").replace("Input should be", "must be")
    if error["type"] in ("unexpected_keyword_argument", "extra_forbidden"):
        return f"unknown field '{key}' (allowed: {', '.join(_keys(schema, loc[:-1]))})"
    if error["type"] == "missing":
        return f"missing field '{key}'"
    if not key:
        return message
    return f"field '{key}': {message}, got {error.get('input')!r}"


def _keys(schema: Any, path: list[Any]) -> list[str]:
    """The keys a schema allows at ``path`` (a nested schema's, for an unknown key inside it)."""
    for part in path:
        schema = typing.get_type_hints(schema).get(str(part))
        if not dataclasses.is_dataclass(schema):
            return []
    return sorted(f.name for f in dataclasses.fields(schema))


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
