"""Counts in the lines a user reads: ``1 start``, ``2 starts``, ``1 distinct optimum``, ``3 distinct optima``."""

from __future__ import annotations

#: the plurals that are not the word and an s
IRREGULAR = {"optimum": "optima", "distinct optimum": "distinct optima", "basis": "bases"}


def plural(count: int, word: str, many: str | None = None) -> str:
    """``count`` and ``word``, in the plural unless ``count`` is 1 (``many``, else the known or regular one)."""
    if count == 1:
        return f"{count} {word}"
    return f"{count} {many or IRREGULAR.get(word) or word + 's'}"
