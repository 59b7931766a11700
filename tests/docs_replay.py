"""The replay of the physics check that docs/guide/mujoco.md gives its readers, taken from the page as a reader
would paste it: the tests and ``benchmarks/mujoco_scenes.py`` run the docs' own code, not a copy of it."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

PAGE = Path(__file__).resolve().parents[1] / "docs" / "guide" / "mujoco.md"


def docs_replay() -> Callable:
    """The page's ``replay(folder) -> (held, worst)``."""
    text = PAGE.read_text()
    block = next(b for b in re.findall(r"```python\n(.*?)```", text, re.S) if "def replay" in b)
    namespace: dict = {}
    exec(block.split("\nheld, worst = replay(")[0], namespace)
    return namespace["replay"]
