"""The per-start log of a sweep, ``solutions.jsonl``: one JSON object a line, appended and synced as each start
finishes, so that a kill loses nothing but the start in progress.

Reading it repairs what a crash or a full disk can leave: a last line cut short (no newline, or not JSON) and
any other line that is not a row are dropped and said so, and a start that appears twice keeps its first row,
so every start has one row, by ``start_id``. Appending after a failed write truncates the fragment back off.
"""

from __future__ import annotations

import errno
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from grasptask.errors import BadInputError
from grasptask.io.artifacts import write_text_atomic


@dataclass
class LogContents:
    rows: list[dict[str, Any]] = field(default_factory=list)
    #: what reading had to set aside, one sentence each (empty for a clean log)
    repairs: list[str] = field(default_factory=list)

    @property
    def start_ids(self) -> set[int]:
        return {row["start_id"] for row in self.rows}


def read_log(path: Path) -> LogContents:
    """The log's rows, one per start, and what had to be dropped to get them."""
    if not path.exists():
        return LogContents()
    data = path.read_bytes()
    lines = data.split(b"\n")
    fragment = lines.pop()  # after the last newline: empty unless the last write was cut short
    contents = LogContents()
    bad, repeated = [], []
    for number, line in enumerate(lines, start=1):
        try:
            row = json.loads(line)
        except (ValueError, UnicodeDecodeError):
            row = None
        if (
            not isinstance(row, dict)
            or isinstance(row.get("start_id"), bool)
            or not isinstance(row.get("start_id"), int)
        ):
            bad.append(number)
        elif row["start_id"] in contents.start_ids:
            repeated.append(row["start_id"])
        else:
            contents.rows.append(row)
    if fragment.strip():
        contents.repairs.append(
            f"dropped an incomplete last line (line {len(lines) + 1}, cut short by a kill or a full disk)"
        )
    if bad:
        contents.repairs.append(f"dropped {len(bad)} line(s) that are not rows (line {', '.join(map(str, bad[:5]))})")
    if repeated:
        contents.repairs.append(
            f"kept the first of two rows for start(s) {', '.join(map(str, sorted(set(repeated))[:5]))}"
        )
    return contents


def rewrite_log(path: Path, rows: list[dict[str, Any]]) -> None:
    """Replace the log by ``rows`` in one rename (after a repair, or to start a sweep afresh)."""
    write_text_atomic(path, "".join(_line(row) for row in rows))


def _jsonable(value: Any) -> Any:
    return value.item() if hasattr(value, "item") else value


def _line(row: dict[str, Any]) -> str:
    return json.dumps({k: _jsonable(v) for k, v in row.items()}) + "\n"


class LogWriter:
    """Appends rows to the log, each flushed and synced. A write that fails (a full disk) is taken back, so the
    log never ends in a fragment, and raised as a one-line error that says the finished rows are kept."""

    def __init__(self, path: Path):
        self.path = path
        self._handle: TextIO = open(path, "a")

    def append(self, row: dict[str, Any]) -> None:
        size = self._handle.tell()
        try:
            self._handle.write(_line(row))
            self._handle.flush()
            os.fsync(self._handle.fileno())
        except OSError as exc:
            self._take_back(size)
            reason = "no space left on device" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
            raise BadInputError(
                self.path,
                f"{reason} writing start {row.get('start_id')}; the finished starts are kept, rerun with --resume",
            ) from exc

    def _take_back(self, size: int) -> None:
        try:
            self._handle.close()
        except OSError:
            pass  # the buffered fragment could not be written either
        try:
            os.truncate(self.path, size)
        except OSError:
            pass  # read_log drops the fragment on the next --resume
        self._handle = open(self.path, "a")

    def close(self) -> None:
        try:
            self._handle.close()
        except OSError:
            pass

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
