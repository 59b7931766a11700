"""Placement, the step before IPOPT: the hand is moved from its far-away start (Section 7.3) to the object.

The palm keeps the start's orientation and joint angles (mid-range); only its position changes. It is put where
the centroid of the fingertip pads falls on an anchor point inside the object, the start position pulled into
the object's bounding box shrunk to ``inset`` of its size, so the three palm positions of the starts (diagonal,
middle, above) become three places along the object. The palm then backs away from the pads until no hand
point is inside the object, so IPOPT begins near a grasp and collision-free. From the far-away starts IPOPT spent
most of its iterations bringing the hand to the object, through restoration phases; a placed start begins there.
"""

from __future__ import annotations

import numpy as np

from grasptask.synthesis.model import GraspNLP
from grasptask.synthesis.starts import Start


def anchor_point(start_position: np.ndarray, bounds: np.ndarray, inset: float = 0.8) -> np.ndarray:
    """The point of the object's bounding box (``(2, 3)``: min, max), shrunk to ``inset``, nearest the start."""
    centre, half = bounds.mean(axis=0), (bounds[1] - bounds[0]) / 2
    return centre + np.clip(np.asarray(start_position) - centre, -inset * half, inset * half)


def place(
    nlp: GraspNLP,
    start: Start,
    bounds: np.ndarray,
    joint_angles: np.ndarray,
    step: float = 0.005,
    max_backoff: float = 0.08,
) -> float:
    """Initialise ``nlp`` at the placed pose of ``start``; returns how far the palm backed away (m)."""
    nlp.initialise(start.palm_rotation, np.zeros(3), joint_angles)
    pads = nlp.read()["contacts"].mean(axis=0)  # palm at the origin: the pads' centroid relative to the palm
    away = -pads / np.linalg.norm(pads)
    grasp_centre = anchor_point(start.palm_position, bounds) - pads
    for backoff in np.arange(0.0, max_backoff + step / 2, step):
        if nlp.min_clearance(palm_position=grasp_centre + backoff * away) >= 0:
            break
    nlp.initialise(start.palm_rotation, grasp_centre + backoff * away, joint_angles)
    return float(backoff)
