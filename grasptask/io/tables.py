"""Reading a Parquet artifact back, with one clear line when it is missing, unreadable or incomplete."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq

from grasptask.errors import BadInputError, existing_file


def read_table(path: str | Path, required: tuple[str, ...] | list[str] = ()) -> pd.DataFrame:
    path = existing_file(path)
    try:
        table = pq.read_table(path)
        table.validate(full=True)  # bytes that are not UTF-8 in a text column fail here, not later in pandas
        frame = table.to_pandas()
    except Exception as exc:  # pyarrow raises several types for a file that is not Parquet
        raise BadInputError(path, f"not a readable Parquet file ({type(exc).__name__})") from exc
    for column in required:
        if column not in frame.columns:
            raise BadInputError(path, "missing column", column=column)
    return frame


def check_numbers(path: str | Path, table: pd.DataFrame, columns: list[str], missing_ok: bool) -> None:
    """One line naming the row and column of the first value in ``columns`` that is not a finite number (a
    missing one allowed where ``missing_ok``)."""
    for column in columns:
        if not pd.api.types.is_numeric_dtype(table[column]) or pd.api.types.is_bool_dtype(table[column]):
            raise BadInputError(path, f"must hold numbers, not {table[column].dtype} values", column=column)
        values = table[column].astype(float)
        bad = values.isin([float("inf"), float("-inf")])
        if not missing_ok:
            bad |= values.isna()
        if bad.any():
            row = int(bad.to_numpy().argmax())
            raise BadInputError(path, f"not a finite number: {table[column].iloc[row]!r}", row=row + 1, column=column)
