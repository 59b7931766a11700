"""Placement, the step before IPOPT: the hand is moved from its far-away start (Section 7.3) to the object.

The palm keeps the start's orientation and joint angles (mid-range); only its position changes. It is put where
the centroid of the fingertip pads falls on an anchor point inside the object: the start position pulled into
the object's bounding box shrunk to ``inset`` of its size, so the three palm positions of the starts (diagonal,
middle, above) become three places along the object, or a surface seed's own point. On a mesh the anchor then
moves to the nearest part thick enough for the surrogate to resolve (:class:`Anchors`). The palm then backs away
from the pads until no hand point is inside the object, so IPOPT begins near a grasp and collision-free. From
the far-away starts IPOPT spent most of its iterations bringing the hand to the object, through restoration
phases; a placed start begins there.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from grasptask.objects.distance_grid import DistanceGrid
from grasptask.synthesis.nlp import GraspNLP
from grasptask.synthesis.starts import Start

#: how deep inside a mesh's surrogate an anchor lies, in grid cells. The grid does not resolve a part thinner than
#: a few cells (a knife's blade, a screwdriver's shaft): its surrogate normals are wrong by tens of degrees there,
#: and IPOPT started on such a part ended locally infeasible (docs/design/synthesis.md)
ANCHOR_DEPTH_CELLS = 1.5


def anchor_point(start_position: np.ndarray, bounds: np.ndarray, inset: float = 0.8) -> np.ndarray:
    """The point of the object's bounding box (``(2, 3)``: min, max), shrunk to ``inset``, nearest the start."""
    centre, half = bounds.mean(axis=0), (bounds[1] - bounds[0]) / 2
    return centre + np.clip(np.asarray(start_position) - centre, -inset * half, inset * half)


class Anchors:
    """Where placement puts the pads' centroid for a start: :func:`anchor_point`, and for an object seen through
    a distance grid (a mesh or point cloud) the nearest grid point at least :data:`ANCHOR_DEPTH_CELLS` cells
    inside it, so that a start begins on a part the surrogate resolves. An object with no such point (thinner than
    that everywhere) keeps the box's anchors."""

    def __init__(self, bounds: np.ndarray, grid: DistanceGrid | None = None):
        self.bounds = np.asarray(bounds, dtype=float)
        inside = grid.points_inside(ANCHOR_DEPTH_CELLS * grid.spacing) if grid is not None else np.zeros((0, 3))
        self._inside = cKDTree(inside) if len(inside) else None

    def __call__(self, start_position: np.ndarray) -> np.ndarray:
        return self.inside(anchor_point(start_position, self.bounds))

    def inside(self, point: np.ndarray) -> np.ndarray:
        """``point``, or on a grid's object the nearest point a start may begin on."""
        if self._inside is None:
            return np.asarray(point, dtype=float)
        return self._inside.data[self._inside.query(point)[1]]


def place(
    nlp: GraspNLP,
    start: Start,
    anchors: Anchors,
    joint_angles: np.ndarray,
    step: float = 0.005,
    max_backoff: float = 0.08,
) -> float:
    """Initialise ``nlp`` at the placed pose of ``start``; returns how far the palm backed away (m)."""
    nlp.initialise(start.palm_rotation, np.zeros(3), joint_angles)
    pads = nlp.read()["contacts"].mean(axis=0)  # palm at the origin: the pads' centroid relative to the palm
    away = -pads / np.linalg.norm(pads)
    target = anchors(start.palm_position) if start.anchor is None else anchors.inside(start.anchor)
    grasp_centre = target - pads
    for backoff in np.arange(0.0, max_backoff + step / 2, step):
        if nlp.min_clearance(palm_position=grasp_centre + backoff * away) >= 0:
            break
    nlp.initialise(start.palm_rotation, grasp_centre + backoff * away, joint_angles)
    return float(backoff)
