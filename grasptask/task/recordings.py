"""Reading one recording (CSV or Parquet) into a validated ``(n, 7)`` array of t, fx, fy, fz, tx, ty, tz.

Row numbers in error messages count data rows from 1, not counting a CSV header.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from grasptask.errors import BadInputError, existing_file
from grasptask.io.csv_format import ENCODING, sniff
from grasptask.task.tool import CANONICAL_COLUMNS

MIN_SAMPLES = 10
RECORDING_SUFFIXES = (".csv", ".parquet", ".pq")


def read_recording(
    path: str | Path,
    columns: Mapping[str, str] | None = None,
    ignore_columns: Sequence[str] = (),
) -> np.ndarray:
    """The recording's samples as float64 ``(n, 7)`` in canonical column order, units as stored.

    ``columns`` maps a canonical name (``t``, ``fx``, ...) to the file's own column name; ``ignore_columns``
    names file columns to drop. Anything else that is missing, extra, non-numeric, NaN or infinite, too short
    or not strictly increasing in time raises :class:`BadInputError` naming the file, row and column.
    """
    path = Path(path)
    existing_file(path)
    if path.stat().st_size == 0:
        raise BadInputError(path, "empty file")
    suffix = path.suffix.lower()
    if suffix not in RECORDING_SUFFIXES:
        raise BadInputError(path, f"unknown recording format '{suffix}' (expected .csv or .parquet)")
    rename = {file_name: canonical for canonical, file_name in (columns or {}).items()}
    file_columns = _read_header(path, suffix)
    names = [rename.get(c, c) for c in file_columns if c not in set(ignore_columns)]
    _check_columns(path, names, rename)
    wanted = [c for c in file_columns if c not in set(ignore_columns)]
    table = _read_table(path, suffix, wanted, file_columns)
    data = _to_float(path, table, wanted, names)
    check_values(path, data)
    return data


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


def _check_columns(path: Path, names: list[str], rename: Mapping[str, str]) -> None:
    seen = set()
    for name in names:
        if name in seen:
            raise BadInputError(path, "duplicate column", column=name)
        seen.add(name)
    inverse = {v: k for k, v in rename.items()}
    for name in CANONICAL_COLUMNS:
        if name not in seen:
            wanted = inverse.get(name, name)
            near = next((n for n in names if n.lower() == wanted.lower()), None)
            hint = (
                f"; the file has '{near}': name the file's columns in a tool config (--tool), e.g. "
                f"columns: {{{name}: {near}}}"
                if near is not None
                else ""
            )
            raise BadInputError(path, f"missing column{hint}", column=wanted)
    for name in names:
        if name not in CANONICAL_COLUMNS:
            raise BadInputError(
                path, f"unexpected column (expected {', '.join(CANONICAL_COLUMNS)})", column=inverse.get(name, name)
            )


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
    if table.num_rows == 0:
        raise BadInputError(path, f"no samples (at least {MIN_SAMPLES} are needed)")
    order = {name: file_name for file_name, name in zip(wanted, names, strict=True)}
    # column-major, so that each column is copied in one contiguous run
    data = np.empty((table.num_rows, len(CANONICAL_COLUMNS)), order="F")
    for k, name in enumerate(CANONICAL_COLUMNS):
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
        raise BadInputError(path, f"only {len(data)} samples (at least {MIN_SAMPLES} are needed)")
    steps = np.diff(data[:, 0])
    if not (steps > 0).all():
        row = int(np.flatnonzero(steps <= 0)[0]) + 2
        raise BadInputError(path, "time is not strictly increasing", row=row, column="t")


def write_recording(path: Path, data: np.ndarray) -> None:
    """Write ``(n, 7)`` samples with the canonical header; the format follows the suffix."""
    table = pa.table({name: data[:, k] for k, name in enumerate(CANONICAL_COLUMNS)})
    if path.suffix == ".csv":
        with open(path, "wb") as handle:
            handle.write((",".join(CANONICAL_COLUMNS) + "\n").encode())
            pacsv.write_csv(table, handle, pacsv.WriteOptions(include_header=False, quoting_style="none"))
    else:
        pq.write_table(table, path)
