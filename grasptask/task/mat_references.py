"""Naming what a recording is in a MATLAB file: references as MATLAB writes them, resolved to channels.

A reference starts at a variable and descends as MATLAB indexes: ``.field`` into a struct, ``{k}`` into a cell,
``(k)`` into a struct array (``{k}`` and ``(k)`` are read alike, as the intent is never in doubt), ``k`` counted
from 1 in MATLAB's linear order, or ``{i,j}`` by row and column. A final ``[k]`` takes channel ``k`` (from 1) of
a matrix whose samples run along its rows (``n x k``) or its columns (``k x n``). One ``*`` in place of an index
(``rawdata_FT{*}.Tool_FT``) stands for every element: :func:`elements` lists them, one recording each.

Where the layout does not say which way the samples run, the channels it names decide: the axis long enough to
hold the highest channel named holds the channels (a 7 x 1 matrix with channels up to 7 is one sample); where
both are, the longer axis holds the samples, and a square matrix must be said.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grasptask.errors import BadInputError
from grasptask.task.matlab import Cell, Struct, class_name, describe, describe_value, size

WILDCARD = "*"
_NAME = re.compile(r"\s*([A-Za-z]\w*)\s*")
_STEP = re.compile(r"\s*(?:\.\s*(?P<field>[A-Za-z]\w*)|\{(?P<brace>[^{}]*)\}|\((?P<paren>[^()]*)\))\s*")
_CHANNEL = re.compile(r"\s*\[\s*(?P<k>\d+)\s*\]\s*$")
_INDEX = re.compile(r"^\s*(\*|\d+(?:\s*,\s*\d+)*)\s*$")

#: a step: a field's name, or an element's index (a tuple of ints from 1; None for the wildcard)
Step = tuple[str, Any]


@dataclass(frozen=True)
class Reference:
    """A parsed reference: the variable, the steps into it, and the channel taken at the end (None: the whole)."""

    text: str
    name: str
    steps: tuple[Step, ...]
    channel: int | None

    @property
    def where(self) -> str:
        """The reference without its channel."""
        return self.prefix(len(self.steps))

    @property
    def wildcards(self) -> int:
        return sum(1 for kind, index in self.steps if kind == "index" and index is None)

    def prefix(self, count: int) -> str:
        """The reference's first ``count`` steps, written as MATLAB would."""
        text = self.name
        for kind, index in self.steps[:count]:
            if kind == "field":
                text += f".{index}"
            else:
                text += "{" + (WILDCARD if index is None else ",".join(map(str, index))) + "}"
        return text


def parse(path: str | Path, text: str, key: str = "") -> Reference:
    """``text`` as a reference; a line naming the form where it is not one."""
    form = "a variable: name, name.field, name{k}, name(k).field, name{*} for every element, [k] for channel k"
    match = _NAME.match(text)
    rest = text[match.end() :] if match else text
    channel = _CHANNEL.search(rest)
    if channel:
        rest = rest[: channel.start()]
    steps: list[Step] = []
    while match and rest.strip():
        step = _STEP.match(rest)
        if step is None:
            break
        if step["field"]:
            steps.append(("field", step["field"]))
        else:
            index = step["brace"] if step["brace"] is not None else step["paren"]
            if not _INDEX.match(index):
                break
            index = index.strip()
            steps.append(("index", None if index == WILDCARD else tuple(int(i) for i in index.split(","))))
        rest = rest[step.end() :]
    if match is None or rest.strip():
        raise BadInputError(path, f"'{text}' is not {form}", column=key or None)
    reference = Reference(text.strip(), match.group(1), tuple(steps), int(channel["k"]) if channel else None)
    if reference.wildcards > 1:
        raise BadInputError(path, f"'{text}' has {reference.wildcards} wildcards; one '*' at most", column=key or None)
    if any(kind == "index" and index is not None and min(index) < 1 for kind, index in steps):
        raise BadInputError(path, f"'{text}': MATLAB counts elements from 1", column=key or None)
    return reference


def resolve(path: str | Path, variables: Mapping[str, Any], reference: Reference, steps: int | None = None) -> Any:
    """The value the reference's first ``steps`` steps (all, by default) name; one line where the file cannot
    answer it, naming the step at fault and what is there."""
    value = variables.get(reference.name)
    if value is None:
        raise BadInputError(
            path, f"no variable '{reference.name}' for '{reference.text}' (the file holds: {describe(variables)})"
        )
    for count, (kind, index) in enumerate(reference.steps[:steps], start=1):
        here = reference.prefix(count - 1)
        if _empty(value):
            raise BadInputError(path, f"'{reference.text}': {here} is empty ({describe_value(value)})")
        if kind == "field":
            value = _field(path, reference, here, value, str(index))
        elif index is None:
            raise BadInputError(path, f"'{reference.text}': name one element of {here} in place of '*'")
        else:
            value = _element(path, reference, here, value, index)
    return value


def _empty(value: Any) -> bool:
    if isinstance(value, np.ndarray):
        return value.size == 0
    return isinstance(value, (Cell, Struct)) and not value.items


def _field(path: str | Path, reference: Reference, here: str, value: Any, name: str) -> Any:
    if not isinstance(value, Struct):
        raise BadInputError(
            path, f"'{reference.text}': {here} is {describe_value(value)}, not a struct with field '{name}'"
        )
    if name not in value.fields:
        raise BadInputError(
            path, f"'{reference.text}': {here} has no field '{name}' (it has: {', '.join(value.fields)})"
        )
    if len(value.items) != 1:
        raise BadInputError(
            path, f"'{reference.text}': {here} is a {size(value.shape)} struct array: name an element, {here}(k).{name}"
        )
    return value.items[0][name]


def _element(path: str | Path, reference: Reference, here: str, value: Any, index: tuple[int, ...]) -> Any:
    if not isinstance(value, (Cell, Struct)):
        what = describe_value(value)
        raise BadInputError(path, f"'{reference.text}': {here} is {what}, not a cell or struct array to index")
    shape = value.shape
    if len(index) == 1:
        linear = index[0]
        if linear > len(value.items):
            raise BadInputError(
                path,
                f"'{reference.text}': {here} is {size(shape)}, so it has no element {linear} (1 to {len(value.items)})",
            )
    else:
        padded = tuple(shape) + (1,) * max(0, len(index) - len(shape))
        if len(index) != len(padded) and any(d != 1 for d in padded[len(index) :]):
            raise BadInputError(path, f"'{reference.text}': {here} is {size(shape)}: give one index or {len(shape)}")
        if any(i > d for i, d in zip(index, padded, strict=False)):
            at = ",".join(map(str, index))
            raise BadInputError(path, f"'{reference.text}': {here} is {size(shape)}, so it has no element {{{at}}}")
        linear = int(np.ravel_multi_index(tuple(i - 1 for i in index), padded[: len(index)], order="F")) + 1
    item = value.items[linear - 1]
    if isinstance(value, Struct):
        return Struct((1, 1), value.fields, (item,))
    return item


def elements(
    path: str | Path, variables: Mapping[str, Any], references: Mapping[str, str], samples: str | None
) -> int | None:
    """How many elements the references' wildcards range over (None: they hold none), each element checked to
    read alike: a numeric matrix of as many channels as the first element's, and not empty."""
    parsed = {key: parse(path, text, key) for key, text in references.items()}
    wild = {key: reference for key, reference in parsed.items() if reference.wildcards}
    if not wild:
        return None
    counts = {key: _count(path, variables, reference) for key, reference in wild.items()}
    if len(set(counts.values())) > 1:
        said = ", ".join(f"'{wild[key].text}' {n}" for key, n in counts.items())
        raise BadInputError(path, f"wildcards over different numbers of elements ({said})")
    highest: dict[str, int] = {}
    for reference in wild.values():
        highest[reference.where] = max(highest.get(reference.where, 1), reference.channel or 1)
    first: dict[str, tuple[str, str, int]] = {}
    for k in range(1, next(iter(counts.values())) + 1):
        concrete = {key: substitute(reference.text, k) for key, reference in wild.items()}
        for key, text in concrete.items():
            reference = parse(path, text, key)
            value = matrix(path, variables, reference)
            data = samples_first(path, reference.where, value, samples, highest[wild[key].where])
            if key not in first:
                first[key] = (reference.where, describe_value(value), data.shape[1])
            elif data.shape[1] != first[key][2]:
                where, said, _ = first[key]
                raise BadInputError(
                    path,
                    f"'{reference.where}' is {describe_value(value)}, unlike '{where}' ({said}): the elements a "
                    f"wildcard reads must hold the same channels ({first[key][2]}, not {data.shape[1]})",
                )
    return next(iter(counts.values()))


def _count(path: str | Path, variables: Mapping[str, Any], reference: Reference) -> int:
    at = next(k for k, (kind, index) in enumerate(reference.steps) if kind == "index" and index is None)
    container = resolve(path, variables, reference, at)
    here = reference.prefix(at)
    if not isinstance(container, (Cell, Struct)):
        what = describe_value(container)
        raise BadInputError(path, f"'{reference.text}': {here} is {what}, not a cell or struct array for '*'")
    if not container.items:
        what = describe_value(container)
        raise BadInputError(path, f"'{reference.text}': {here} is empty ({what}): no elements for '*'")
    return len(container.items)


def substitute(text: str, k: int) -> str:
    """The reference with its wildcard replaced by element ``k``."""
    return re.sub(r"([{(])\s*\*\s*([})])", lambda m: f"{m[1]}{k}{m[2]}", text, count=1)


def matrix(path: str | Path, variables: Mapping[str, Any], reference: Reference) -> np.ndarray:
    """The real, non-empty numeric matrix a reference (without its channel) names."""
    value = resolve(path, variables, reference)
    where = reference.where
    if not isinstance(value, np.ndarray):
        hint = f": index it, e.g. {where}{{1}}" if isinstance(value, Cell) else ""
        hint = f": name a field, e.g. {where}.{value.fields[0]}" if isinstance(value, Struct) and value.fields else hint
        raise BadInputError(path, f"'{where}' is {describe_value(value)}, not a matrix of samples{hint}")
    if value.dtype.kind == "c":
        raise BadInputError(path, f"'{where}' is {describe_value(value)}: a force/torque recording is real")
    if value.ndim != 2:
        raise BadInputError(path, f"'{where}' is {describe_value(value)}; a recording is a vector or a matrix")
    return value


def channels(
    path: str | Path, variables: Mapping[str, Any], references: Mapping[str, str], samples: str | None, hint: str
) -> dict[str, np.ndarray]:
    """Each reference's samples as a float vector, all of one length; ``hint`` ends the line of a reference the
    file cannot answer (it names the setting that maps them)."""
    parsed = {key: parse(path, text, key) for key, text in references.items()}
    highest: dict[str, int] = {}  # the highest channel named of each matrix decides which way it lies
    for reference in parsed.values():
        highest[reference.where] = max(highest.get(reference.where, 1), reference.channel or 1)
    found: dict[str, np.ndarray] = {}
    for key, reference in parsed.items():
        if reference.name not in variables:
            raise BadInputError(
                path, f"no variable '{reference.name}' for {key} (the file holds: {describe(variables)}); {hint}"
            )
        where = reference.where
        data = samples_first(path, where, matrix(path, variables, reference), samples, highest[where])
        if reference.channel is None:
            if data.shape[1] != 1:
                raise BadInputError(
                    path, f"'{where}' has {data.shape[1]} channels: name one as {where}[k] for {key}; {hint}"
                )
            column = data[:, 0]
        else:
            k = reference.channel
            if not 1 <= k <= data.shape[1]:
                raise BadInputError(path, f"'{where}' has no channel {k} (it has {data.shape[1]}) for {key}")
            column = data[:, k - 1]
        found[key] = np.asarray(column, dtype=float)
    lengths = {key: len(v) for key, v in found.items()}
    if len(set(lengths.values())) > 1:
        said = ", ".join(f"{key} {n}" for key, n in lengths.items())
        raise BadInputError(path, f"channels of different lengths ({said}); {hint}")
    return found


def samples_first(path: str | Path, name: str, value: np.ndarray, samples: str | None, highest: int = 1) -> np.ndarray:
    """``value`` as ``(n, k)``, samples along the first axis; ``highest`` is the highest channel the layout names."""
    rows, cols = value.shape
    if samples is None:
        if min(rows, cols) == 1 and highest == 1:
            return value.reshape(-1, 1)
        fits = [rows >= highest, cols >= highest]  # which axis can hold the channels named
        if fits == [True, False]:
            samples = "columns"
        elif fits == [False, True]:
            samples = "rows"
        elif rows == cols:
            raise BadInputError(
                path, f"'{name}' is {rows}x{cols}: say whether its samples are rows or columns (matlab: samples)"
            )
        else:
            samples = "rows" if rows > cols else "columns"
    data = value if samples == "rows" else value.T
    if data.shape[0] == 0:
        raise BadInputError(path, f"'{name}' is {size(value.shape)} {class_name(value)}: it holds 0 samples")
    return data


def scalar(path: str | Path, variables: Mapping[str, Any], text: str, what: str) -> float:
    """A positive, finite number the file holds (a sample rate or period), named by a reference."""
    value = matrix(path, variables, parse(path, text, what))
    if value.size != 1 or not np.isfinite(value).all() or float(value.ravel()[0]) <= 0:
        shown = describe_value(value) if value.size != 1 else f"{float(value.ravel()[0]):.6g}"
        raise BadInputError(path, f"'{text}' for {what} must be one positive number, got {shown}")
    return float(value.ravel()[0])
