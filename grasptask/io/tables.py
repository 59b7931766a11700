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
