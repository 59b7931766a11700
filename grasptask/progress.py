"""Progress bars for long stages: shown on a terminal, silent in logs and tests."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TypeVar

from tqdm import tqdm

T = TypeVar("T")


def progress(items: Iterable[T], desc: str, unit: str = "it") -> Iterable[T]:
    return tqdm(items, desc=desc, unit=unit, disable=None, leave=False)
