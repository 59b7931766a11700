"""One look for every figure: colours per task, markers per grasp type, readable sizes."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

TASK_COLOURS = {"drawing": "#1f77b4", "cutting": "#d62728", "screwdriving": "#2ca02c"}
GRASP_MARKERS = {"tripod": "o", "cylindrical": "s", "power": "^", "free": "D"}
FALLBACK_COLOURS = ["#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"]
FONT_SIZE = 10


def task_colour(task: str, known: list[str] | None = None) -> str:
    if task in TASK_COLOURS:
        return TASK_COLOURS[task]
    others = sorted(t for t in (known or [task]) if t not in TASK_COLOURS)
    return FALLBACK_COLOURS[others.index(task) % len(FALLBACK_COLOURS)] if task in others else FALLBACK_COLOURS[0]


def task_order(task: str) -> tuple[int, str]:
    """Sort key: the paper's tasks in its order (drawing, cutting, screw driving), then the rest by name."""
    known = list(TASK_COLOURS)
    return (known.index(task) if task in known else len(known), task)


def save_figure(fig: Any, path: Path) -> None:
    """Save ``fig`` as a PNG of at most 256 colours: a third of the bytes of a full-colour one for these flat
    plots, and the report inlines every figure (its 15 MB budget)."""
    from PIL import Image  # deferred: Pillow, only to write a PNG

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    buffer.seek(0)
    with Image.open(buffer) as image:
        image.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)


def apply_style() -> None:
    matplotlib.rcParams.update(
        {"font.size": FONT_SIZE, "axes.titlesize": FONT_SIZE + 1, "figure.dpi": 110, "savefig.bbox": "tight"}
    )
