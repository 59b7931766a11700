"""``load_hand``: a hand from any file a user has, checked once here."""

from __future__ import annotations

from pathlib import Path

from grasptask.hand.from_yaml import hand_from_yaml
from grasptask.hand.model import Hand
from grasptask.io.config import load_yaml
from grasptask.paths import DEFAULT_HAND


def load_hand(path: str | Path = DEFAULT_HAND) -> Hand:
    """The hand described by ``path``; a one-line error names the file and the field at fault."""
    path = Path(path)
    return hand_from_yaml(load_yaml(path), path)
