"""The one exception type that the CLI turns into a single line and exit code 2."""

from __future__ import annotations

from pathlib import Path


class BadInputError(ValueError):
    """Input that the user must fix: a file, and where possible the row and column at fault.

    ``str(err)`` is the one line the CLI prints, e.g.
    ``data/t1.csv: row 57, column 'fy': non-numeric value 'abc'``.
    """

    def __init__(
        self,
        source: str | Path,
        problem: str,
        *,
        row: int | None = None,
        column: str | None = None,
    ):
        self.source = str(source)
        # one line, always: messages quoted from parsers (YAML, IPOPT) can run over several
        problem = " ".join(part.strip() for part in str(problem).splitlines() if part.strip())
        self.problem = problem
        self.row = row
        self.column = column
        where = []
        if row is not None:
            where.append(f"row {row}")
        if column is not None:
            where.append(f"column '{column}'")
        location = f"{self.source}: " + (", ".join(where) + ": " if where else "")
        super().__init__(location + problem)


def existing_file(path: str | Path, what: str = "file") -> Path:
    """``path`` if it is a file, else a one-line error that says whether it is missing or a folder."""
    path = Path(path)
    if path.is_dir():
        raise BadInputError(path, f"is a folder, not a {what}")
    if not path.is_file():
        raise BadInputError(path, f"{what} not found")
    return path
