"""YAML configuration and JSON summaries, read and validated once at the edge.

A config file's schema is a pydantic dataclass: its keys, their defaults and their checks declared once, in
the module that uses them, with the types below. :func:`validated` turns a file's mapping into it, and an
unknown key, a wrong type or a value out of range into the same one line naming the file and the key.
"""

from __future__ import annotations

import dataclasses
import json
import re
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, TypeVar

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
#: a name or a path: text, never empty
Text = Annotated[str, Strict(), Field(min_length=1)]
#: three numbers: a point or a direction
Vector = tuple[Real, Real, Real]

T = TypeVar("T")

#: the most processes one command starts (--workers); more would only wait on each other's cores
MAX_WORKERS = 64

#: the largest config file read; every bundled one is under 10 kB
MAX_CONFIG_BYTES = 1 << 20


#: the deepest nesting of lists and mappings a config may have; the deepest bundled one has 4 levels
MAX_DEPTH = 32


class _ConfigLoader(yaml.SafeLoader):
    """``yaml.safe_load`` that cannot hang or lie: no anchors and aliases (a few hundred bytes of nested aliases
    expand to gigabytes, a "billion laughs", and no config needs them), no nesting deeper than
    :data:`MAX_DEPTH` (PyYAML composes recursively: thousands of levels end in a RecursionError), no key given
    twice (PyYAML keeps the last without a word), and ``1e6`` or ``1.0e6`` read as numbers, as YAML 1.2 and
    JSON read them (YAML 1.1 asks for a dot and a signed exponent, and reads them as text)."""

    def __init__(self, stream: str):
        super().__init__(stream)
        self.depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        event = self.peek_event()
        mark: Any = event.start_mark
        if isinstance(event, yaml.AliasEvent):
            raise yaml.MarkedYAMLError(problem="aliases (*name) are not allowed", problem_mark=mark)
        if self.depth >= MAX_DEPTH:
            raise yaml.MarkedYAMLError(problem=f"nested deeper than {MAX_DEPTH} levels", problem_mark=mark)
        self.depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        first: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            if isinstance(key, typing.Hashable) and key in first:
                raise yaml.MarkedYAMLError(
                    problem=f"key {key!r} given twice (first on line {first[key] + 1})",
                    problem_mark=key_node.start_mark,
                )
            if isinstance(key, typing.Hashable):
                first[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep)


_ConfigLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


def load_yaml(path: str | Path) -> dict[str, Any]:
    """A YAML mapping from ``path`` (safe types only, see :class:`_ConfigLoader`), or a one-line error naming
    the file and the line. A file with nothing but comments is the empty mapping: every key at its default."""
    path = existing_file(path, "config file")
    if path.stat().st_size > MAX_CONFIG_BYTES:
        raise BadInputError(path, f"larger than {MAX_CONFIG_BYTES >> 20} MB: not a config file")
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark, as some Windows editors write it
        data = yaml.load(text, Loader=_ConfigLoader)  # noqa: S506 - a SafeLoader subclass
    except UnicodeDecodeError as exc:
        raise BadInputError(path, "not a text file") from exc
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = "" if mark is None else f"line {mark.line + 1}: "
        raise BadInputError(path, f"{where}invalid YAML: {getattr(exc, 'problem', exc)}") from exc
    if data is None and _only_comments(text):
        return {}
    if not isinstance(data, dict):
        raise BadInputError(path, "expected a mapping at the top level")
    return data


def _only_comments(text: str) -> bool:
    lines = [line.strip() for line in text.splitlines()]
    return any(lines) and all(not line or line.startswith("#") for line in lines)


def validated(schema: type[T], data: Mapping[str, Any], source: str | Path) -> T:
    """``data`` as an instance of the pydantic dataclass ``schema``, or one line naming the file and the key."""
    try:
        return TypeAdapter(schema).validate_python(data)
    except ValidationError as exc:
        # a misspelt key explains a missing one, so an unknown key is named first
        # and of a union's members, the one the value was meant for (a mapping is not a literal's word)
        errors = sorted(exc.errors(), key=_first)
        raise BadInputError(source, _problem(schema, errors[0])) from None


def _first(error: Any) -> int:
    kind = error["type"]
    if kind in ("unexpected_keyword_argument", "extra_forbidden"):
        return 0
    return 2 if kind in ("literal_error", "dataclass_type", "model_type") else 1


def _problem(schema: type, error: Any) -> str:
    """One of pydantic's errors as this project's one line: ``field 'a.b': must be ..., got ...``."""
    raw = [part for part in error["loc"] if part != "__root__"]
    loc, _ = _walk(schema, raw)
    key = "".join(f"[{part + 1}]" if isinstance(part, int) else f".{part}" for part in loc).lstrip(".")
    message = str(error["msg"]).removeprefix("Value error, ").replace("Input should be", "must be")
    if error["type"] in ("unexpected_keyword_argument", "extra_forbidden"):
        _, holder = _walk(schema, raw[:-1])
        keys = sorted(f.name for f in dataclasses.fields(holder)) if dataclasses.is_dataclass(holder) else []
        return f"unknown field '{key}' (allowed: {', '.join(keys)})"
    if error["type"] == "missing" and loc and isinstance(loc[-1], int):  # a fixed-length list cut short
        parent = key.rsplit("[", 1)[0]
        return f"field '{parent}': too few numbers (number {loc[-1] + 1} is missing)"
    if error["type"] == "missing":
        return f"missing field '{key}'"
    if not key:
        return message
    given = error.get("input")
    got = "" if isinstance(given, dict) else f", got {given!r}"  # a whole section is too long to quote
    return f"field '{key}': {message[:1].lower()}{message[1:]}{got}"


def _walk(schema: Any, loc: list[Any]) -> tuple[list[Any], Any]:
    """An error's location as the file's keys, and the schema found there. Where the schema is a union of
    several kinds, pydantic names the kind it tried (``TaskFrame``, ``literal[...]``); that is no key of the
    file, so it is left out, and the walk goes on in that kind."""
    keys: list[Any] = []
    current = schema
    parts = list(loc)
    while parts:
        current = _inner(current)
        members = _members(current)
        if len(members) > 1:
            tag = parts.pop(0)
            current = next((m for m in members if getattr(m, "__name__", None) == tag), None)
            continue
        part = parts.pop(0)
        keys.append(part)
        origin, args = typing.get_origin(current), typing.get_args(current)
        if origin is dict:
            current = args[1]
        elif origin is list or (origin is tuple and args[-1:] == (Ellipsis,)):
            current = args[0]
        elif origin is tuple and isinstance(part, int) and part < len(args):
            current = args[part]
        elif dataclasses.is_dataclass(current):
            current = typing.get_type_hints(current).get(str(part))
        else:
            current = None
    return keys, _inner(current)


def _members(hint: Any) -> list[Any]:
    """The kinds a union allows, but None."""
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        return [a for a in typing.get_args(hint) if a is not type(None)]
    return [hint]


def _inner(hint: Any) -> Any:
    """A hint's schema: ``X | None`` is X, and ``Annotated[X, ...]`` is X."""
    while typing.get_origin(hint) is typing.Annotated:
        hint = typing.get_args(hint)[0]
    members = _members(hint)
    return members[0] if len(members) == 1 else hint


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
