"""How a CSV file was written: spreadsheets write a byte-order mark (Excel's "CSV UTF-8") and, in the many
locales where the comma is the decimal mark, a semicolon between fields and a comma in numbers. Sniffed from
the header and the first data line, so that every CSV reader reads such a file as the user saved it."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

#: read every CSV with this: it is UTF-8 that drops a leading byte-order mark
ENCODING = "utf-8-sig"


@dataclass(frozen=True)
class CsvFormat:
    sep: str = ","
    decimal: str = "."

    def read_csv_options(self) -> dict[str, str]:
        """Keyword arguments for :func:`pandas.read_csv`."""
        return {"sep": self.sep, "decimal": self.decimal, "encoding": ENCODING}


def sniff(path: str | Path) -> CsvFormat:
    """The separator (comma, semicolon or tab, whichever splits the header most) and, with a semicolon or a tab,
    the decimal mark (a comma where the first data line has one). A file that is not text is left to the
    reader to refuse."""
    try:
        with open(path, encoding=ENCODING, newline="") as handle:
            header, first = handle.readline(), handle.readline()
    except (OSError, UnicodeDecodeError):
        return CsvFormat()
    sep = max((",", ";", "\t"), key=header.count)
    if header.count(sep) == 0:
        return CsvFormat()
    decimal = "," if sep != "," and "," in first else "."
    return CsvFormat(sep, decimal)


def header(path: str | Path) -> list[str]:
    """The column names of a CSV's first line, as :func:`sniff` reads it (stripped of spaces and quotes)."""
    with open(path, encoding=ENCODING, errors="replace", newline="") as handle:
        line = handle.readline()
    return [c.strip().strip('"') for c in line.rstrip("\r\n").split(sniff(path).sep)]
