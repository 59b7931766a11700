"""Reading a Parquet artifact back, with one clear line when it is missing, unreadable or incomplete."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from grasptask.errors import BadInputError, existing_file


def read_table(path: str | Path, required: tuple[str, ...] | list[str] = ()) -> pd.DataFrame:
    path = existing_file(path)
    try:
        frame = pd.read_parquet(path)
    except Exception as exc:  # pyarrow raises several types for a file that is not Parquet
        raise BadInputError(path, f"not a readable Parquet file ({type(exc).__name__})") from exc
    for column in required:
        if column not in frame.columns:
            raise BadInputError(path, "missing column", column=column)
    return frame
