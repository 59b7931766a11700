"""``grasptask hand``: what the loader understood of a hand file, before any sweep: a summary to read, and one
self-contained HTML view of the hand with its pads and collision spheres over its true collision surfaces."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from grasptask.hand.hand_files import load_hand
from grasptask.io.artifacts import write_text_atomic
from grasptask.paths import as_paths
from grasptask.report.hand_view import hand_lines, hand_page


@dataclass(frozen=True, kw_only=True)
class HandOptions:
    """The hand file to describe (a URDF, an MJCF file or a hand YAML) and, optionally, the folder for its page."""

    hand: Path
    out: Path | None = None

    def __post_init__(self) -> None:
        as_paths(self, "hand", optional=("out",))


@dataclass(frozen=True)
class HandDescription:
    lines: list[str]
    page: Path | None


def describe_hand(options: HandOptions) -> HandDescription:
    """Load the hand and describe it; with ``out``, write ``out/hand.html`` (written whole or not at all)."""
    hand = load_hand(options.hand)
    page = None
    if options.out is not None:
        page = options.out / "hand.html"
        page.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(page, hand_page(hand))
    return HandDescription(hand_lines(hand), page)
