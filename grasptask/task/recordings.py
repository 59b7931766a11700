"""Reading one recording (CSV, Parquet or a MATLAB file) into a validated ``(n, 7)`` array of t, fx, fy, fz, tx, ty, tz.

Row numbers in error messages count data rows from 1, not counting a CSV header.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from grasptask.errors import BadInputError, existing_file
from grasptask.io.csv_format import ENCODING, sniff
from grasptask.task import mat_references, matlab
from grasptask.task.matlab import MAT_SUFFIX

CANONICAL_COLUMNS = ("t", "fx", "fy", "fz", "tx", "ty", "tz")

MIN_SAMPLES = 10
RECORDING_SUFFIXES = (".csv", ".parquet", ".pq", MAT_SUFFIX)
#: ``ignore_columns: rest``: every column the layout does not map is left out
REST = "rest"
_WRENCH = CANONICAL_COLUMNS[1:]


@dataclass(frozen=True)
class Layout:
    """Where a file keeps a recording's time and wrench (a tool config says it; see :mod:`grasptask.task.tool`).

    ``columns`` maps a canonical name (``t``, ``fx``, ...) to the file's own column, or for a ``.mat`` file to a
    variable reference (``time``, ``ft[3]``); ``ignore`` names file columns to leave out, or is ``"rest"`` for
    all that ``columns`` does not map. ``rate_hz`` stands in for a time column. A ``.mat`` file's wrench may be
    channels ``wrench`` (from 1) of the matrix ``variable``, with samples along its ``samples`` (rows or
    columns) and its time in channel ``time`` (or a variable of that name).
    """

    columns: Mapping[str, str] = field(default_factory=dict)
    ignore: tuple[str, ...] | str = ()
    rate_hz: float | None = None
    variable: str | None = None
    samples: str | None = None
    wrench: tuple[int, ...] = (1, 2, 3, 4, 5, 6)
    time: int | str | None = None
    #: a ``.mat`` file's variables holding its sample rate (Hz) or period (s), in place of a number
    rate_from: str | None = None
    period_from: str | None = None
    #: the element its references' wildcard (``{*}``) stands for, from 1 (None: they hold none)
    element: int | None = None

    @property
    def rated(self) -> bool:
        """Whether a sample rate (a number, or a variable of the file's) gives the time."""
        return bool(self.rate_hz or self.rate_from or self.period_from)

    @property
    def needed(self) -> tuple[str, ...]:
        """The canonical columns the file must give: the wrench, and time unless a rate stands in for it."""
        return _WRENCH if self.rated else CANONICAL_COLUMNS


def read_recording(path: str | Path, layout: Layout = Layout()) -> np.ndarray:
    """The recording's samples as float64 ``(n, 7)`` in canonical column order, units as stored (time, where
    ``layout.rate_hz`` stands in for it, in seconds from 0).

    Anything missing, extra (unless ignored), non-numeric, NaN or infinite, too short or not strictly
    increasing in time raises :class:`BadInputError` naming the file, row and column.
    """
    path = Path(path)
    existing_file(path)
    if path.stat().st_size == 0:
        raise BadInputError(path, "empty file")
    suffix = path.suffix.lower()
    if suffix not in RECORDING_SUFFIXES:
        raise BadInputError(path, f"unknown recording format '{suffix}' (expected .csv, .parquet or .mat)")
    if suffix == MAT_SUFFIX:
        data = _read_mat(path, layout)
    else:
        rename = {file_name: canonical for canonical, file_name in layout.columns.items()}
        file_columns = _read_header(path, suffix)
        wanted = _check_columns(path, file_columns, rename, layout)
        names = [rename.get(c, c) for c in wanted]
        table = _read_table(path, suffix, wanted, file_columns)
        data = _to_float(path, table, wanted, names)
    if layout.rate_hz:  # the readers left the time column for the rate to fill
        data[:, 0] = np.arange(len(data)) / layout.rate_hz
    check_values(path, data)
    return data


_MAT_HINT = (
    "say where the samples are in the tool config (matlab: {variable: NAME, samples: rows, wrench: [1, 2, 3, 4, 5, "
    "6], time: 7}, or rate_hz) or in the manifest's variable column"
)


def references_of(layout: Layout) -> dict[str, str]:
    """What a ``.mat`` file's layout reads: a reference per canonical channel (``t``, ``fx``, ...) and for the
    variables that give the rate (``rate``, ``period``), as written, wildcards and all."""
    if layout.variable:
        references = {name: f"{layout.variable}[{k}]" for name, k in zip(_WRENCH, layout.wrench, strict=True)}
        if isinstance(layout.time, int):
            references = {"t": f"{layout.variable}[{layout.time}]", **references}
        elif layout.time:
            references = {"t": layout.time, **references}
    else:
        references = {name: layout.columns.get(name, name) for name in _WRENCH}
    if "t" not in references and not layout.rated:
        references = {"t": layout.columns.get("t", "t"), **references}
    clocks = {"rate": layout.rate_from, "period": layout.period_from}
    return {**references, **{key: text for key, text in clocks.items() if text}}


def mat_elements(path: str | Path, layout: Layout) -> int | None:
    """How many recordings a ``.mat`` file's layout reads: the elements its wildcard ranges over, each checked to
    read alike (None: the layout holds no wildcard, one recording)."""
    path = Path(path)
    references = references_of(layout)
    if not any(mat_references.WILDCARD in text for text in references.values()):
        return None
    return mat_references.elements(path, matlab.read_variables(path), references, layout.samples)


def _read_mat(path: Path, layout: Layout) -> np.ndarray:
    """A ``.mat`` file's channels, by the layout's variable and channels or its column references."""
    variables = matlab.read_variables(path)
    references = references_of(layout)
    for key, text in references.items():
        if mat_references.parse(path, text, key).wildcards:
            if layout.element is None:
                raise BadInputError(
                    path, f"'{text}' reads every element ('*'): fit-task makes one recording of each; name one here"
                )
            references[key] = mat_references.substitute(text, layout.element)
    clocks = {key: references.pop(key) for key in ("rate", "period") if key in references}
    found = mat_references.channels(path, variables, references, layout.samples, _MAT_HINT)
    time = found.get("t", np.zeros(len(found["fx"])))
    if clocks:
        key, text = next(iter(clocks.items()))
        value = mat_references.scalar(path, variables, text, f"the sample {key}")
        time = np.arange(len(time)) * (value if key == "period" else 1.0 / value)
    return np.column_stack([time, *(found[name] for name in _WRENCH)])


def _read_header(path: Path, suffix: str) -> list[str]:
    if suffix == ".csv":
        try:
            with open(path, newline="", encoding=ENCODING) as handle:
                header = next(csv.reader(handle, delimiter=sniff(path).sep), [])
        except (UnicodeDecodeError, csv.Error) as exc:
            raise BadInputError(path, f"not a readable CSV ({type(exc).__name__})") from exc
        if not header:
            raise BadInputError(path, "empty file")
        return [c.strip() for c in header]
    try:
        return list(pq.read_schema(path).names)
    except (pa.ArrowException, OSError) as exc:
        raise BadInputError(path, f"not a readable Parquet file ({type(exc).__name__})") from exc


def _check_columns(path: Path, file_columns: list[str], rename: Mapping[str, str], layout: Layout) -> list[str]:
    """The file's columns to read, in file order: each needed canonical column once, and no other unless the
    layout ignores it."""
    ignored = set(layout.ignore) if layout.ignore != REST else set()
    kept = [c for c in file_columns if c not in ignored]
    names = [rename.get(c, c) for c in kept]
    seen = set()
    for name in names:
        if name in seen:
            raise BadInputError(path, "duplicate column", column=name)
        seen.add(name)
    inverse = {v: k for k, v in rename.items()}
    for name in layout.needed:
        if name not in seen:
            raise BadInputError(path, _missing(name, inverse.get(name, name), kept), column=inverse.get(name, name))
    if layout.rate_hz and "t" in seen:
        raise BadInputError(
            path, "a time column and rate_hz both give the time: give one", column=inverse.get("t", "t")
        )
    if layout.ignore == REST:
        return [c for c, name in zip(kept, names, strict=True) if name in layout.needed]
    for name in names:
        if name not in layout.needed:
            raise BadInputError(
                path,
                f"unexpected column (expected {', '.join(layout.needed)}): map it in the tool config's columns, "
                "or leave it out with ignore_columns (a list, or 'rest' for every column not mapped)",
                column=inverse.get(name, name),
            )
    return kept


def _missing(name: str, wanted: str, names: list[str]) -> str:
    """The line for a missing column: what the file has, and the setting that maps it."""
    near = next((n for n in names if n.lower() == wanted.lower()), None)
    if near is not None:
        return (
            f"missing column; the file has '{near}': name the file's columns in a tool config (--tool), e.g. "
            f"columns: {{{name}: {near}}}"
        )
    shown = ", ".join(names[:12]) + (f", ... ({len(names)} in all)" if len(names) > 12 else "")
    rate = "; a file without time stamps gives rate_hz instead" if name == "t" else ""
    setting = (
        f"the tool config's columns map {name} to it: name the file's own column there"
        if wanted != name
        else f"map the file's columns in a tool config (--tool, or the manifest's tool column): columns: {{{name}: "
        "COLUMN}"
    )
    return f"missing column (the file has: {shown}); {setting}{rate}"


def _read_table(path: Path, suffix: str, wanted: list[str], file_columns: list[str]) -> pa.Table:
    if suffix != ".csv":
        try:
            return pq.read_table(path, columns=wanted)
        except (pa.ArrowException, OSError) as exc:
            raise BadInputError(path, f"not a readable Parquet file ({type(exc).__name__})") from exc
    try:
        # pandas' C parser reads numeric CSV faster than pyarrow's on this machine's two cores
        # (usecols would double the parse time; the header is already checked, so read all and drop the rest)
        options = sniff(path).read_csv_options()
        frame = pd.read_csv(path, dtype={c: np.float64 for c in wanted}, engine="c", **options)[wanted]
    except (ValueError, pd.errors.ParserError):  # UnicodeDecodeError is a ValueError
        try:
            _locate_non_numeric(path, wanted)
        except BadInputError:
            raise
        except (ValueError, pd.errors.ParserError):
            pass  # not even the slow reader can parse it: malformed
        raise BadInputError(path, "malformed CSV (ragged rows, bad quoting or bytes that are not text)") from None
    return pa.Table.from_pandas(frame, preserve_index=False)


def _locate_non_numeric(path: Path, wanted: list[str]) -> None:
    """The fast parser says only that something is wrong; find the exact cell the slow way."""
    frame = pd.read_csv(path, dtype=str, keep_default_na=False, usecols=wanted, **sniff(path).read_csv_options())
    for column in wanted:
        text = frame[column].str.strip()
        numeric = pd.to_numeric(text, errors="coerce")
        bad = numeric.isna() & ~text.str.lower().isin(["nan", "", "inf", "-inf", "+inf"])
        if bad.any():
            row = int(np.flatnonzero(bad.to_numpy())[0])
            raise BadInputError(path, f"non-numeric value {frame[column].iloc[row]!r}", row=row + 1, column=column)


def _to_float(path: Path, table: pa.Table, wanted: list[str], names: list[str]) -> np.ndarray:
    """The table's canonical columns as ``(n, 7)`` floats; a time column it does not have is left as zeros."""
    if table.num_rows == 0:
        raise BadInputError(path, f"no samples (at least {MIN_SAMPLES} are needed)")
    order = {name: file_name for file_name, name in zip(wanted, names, strict=True)}
    # column-major, so that each column is copied in one contiguous run
    data = np.empty((table.num_rows, len(CANONICAL_COLUMNS)), order="F")
    if "t" not in order:
        data[:, 0] = 0.0
    for k, name in enumerate(CANONICAL_COLUMNS):
        if name not in order:
            continue
        column = table.column(order[name])
        if pa.types.is_string(column.type) or pa.types.is_large_string(column.type):
            values = pd.to_numeric(column.to_pandas(), errors="coerce")
            bad = values.isna() & column.to_pandas().notna()
            if bad.any():
                row = int(np.flatnonzero(bad.to_numpy())[0])
                raise BadInputError(path, f"non-numeric value {column[row].as_py()!r}", row=row + 1, column=order[name])
            data[:, k] = values.to_numpy(dtype=float)
        elif pa.types.is_integer(column.type) or pa.types.is_floating(column.type):
            start = 0
            for chunk in column.chunks:  # one copy, straight from Arrow's buffers (nulls become NaN)
                data[start : start + len(chunk), k] = chunk.to_numpy(zero_copy_only=False)
                start += len(chunk)
        else:
            raise BadInputError(path, f"non-numeric column of type {column.type}", column=order[name])
    return data


def check_values(path: str | Path, data: np.ndarray) -> None:
    """Finite samples, enough of them, and time strictly increasing; rows count from 1."""
    finite = np.isfinite(data)
    if not finite.all():
        row, col = np.argwhere(~finite)[0]
        what = "NaN (or empty)" if np.isnan(data[row, col]) else "infinite value"
        raise BadInputError(path, what, row=int(row) + 1, column=CANONICAL_COLUMNS[col])
    # finite, yet too large to square and sum over the samples (1e308 ended in a LinAlgError in fit-task)
    limit = np.sqrt(np.finfo(float).max / max(len(data), 1))
    huge = np.abs(data[:, 1:]) > limit
    if huge.any():
        row, col = np.argwhere(huge)[0]
        value = data[row, col + 1]
        raise BadInputError(
            path, f"value {value:.3g} too large to compute with", row=int(row) + 1, column=CANONICAL_COLUMNS[col + 1]
        )
    if len(data) < MIN_SAMPLES:
        said = f"{len(data)} sample" + ("" if len(data) == 1 else "s")
        raise BadInputError(path, f"only {said} (at least {MIN_SAMPLES} are needed)")
    steps = np.diff(data[:, 0])
    if not (steps > 0).all():
        row = int(np.flatnonzero(steps <= 0)[0]) + 2
        raise BadInputError(path, "time is not strictly increasing", row=row, column="t")


def window_mask(where: str | Path, t: np.ndarray, start_s: float | None, end_s: float | None) -> np.ndarray:
    """The samples between ``start_s`` and ``end_s`` seconds after the first (``t`` in seconds; either may be
    None); an empty window is one line naming the recording's span."""
    keep = np.ones(len(t), dtype=bool)
    since = t - t[0]
    if start_s is not None:
        keep &= since >= start_s
    if end_s is not None:
        keep &= since <= end_s
    if not keep.any():
        raise BadInputError(
            where, f"no samples in the window {start_s} .. {end_s} s (the recording spans 0 .. {since[-1]:.6g} s)"
        )
    return keep


def write_recording(path: Path, data: np.ndarray) -> None:
    """Write ``(n, 7)`` samples with the canonical header; the format follows the suffix."""
    table = pa.table({name: data[:, k] for k, name in enumerate(CANONICAL_COLUMNS)})
    if path.suffix == ".csv":
        with open(path, "wb") as handle:
            handle.write((",".join(CANONICAL_COLUMNS) + "\n").encode())
            pacsv.write_csv(table, handle, pacsv.WriteOptions(include_header=False, quoting_style="none"))
    else:
        pq.write_table(table, path)
