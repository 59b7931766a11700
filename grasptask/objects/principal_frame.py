"""A bare mesh's or point cloud's default task frame: its centre of volume and principal axes.

z is the axis the object is told apart along: its longest, or, where two principal moments are equal within a
scan's noise (a bowl, a can, a bottle), the remaining one, its axis of symmetry; where all three are (a ball, a
cube), no axis is told apart and the file's own axes are kept. An axis points to the side where the object
reaches farther (its third moment), or, where that is within noise too, along the file's nearest axis, so the
frame turns with the object and does not flip on a scan's last bits."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: two principal moments this close, relative to the largest, are one (a scan's noise: the YCB bowl's two
#: across are 161 x 161 mm)
EQUAL_MOMENTS = 0.02
#: a third moment this small, relative to the absolute one, says no side (a can's along its axis)
EVEN_SIDES = 0.05


@dataclass(frozen=True)
class PrincipalFrame:
    """The 4 x 4 frame in the file's coordinates, and how its axes were chosen, as a summary says it."""

    matrix: np.ndarray
    axes: str


def principal_frame(centre: np.ndarray, inertia: np.ndarray, spread: np.ndarray, weights: np.ndarray) -> PrincipalFrame:
    """The frame at ``centre`` from the object's ``inertia`` about it (3 x 3, any positive scale), its surface
    samples' offsets from the centre ``spread`` (n x 3) and their ``weights`` (areas, or ones for a cloud)."""
    moments, vectors = np.linalg.eigh(inertia)  # ascending: the least inertia is about the longest axis
    near = np.diff(moments) <= EQUAL_MOMENTS * moments[2]
    frame = np.eye(4)
    frame[:3, 3] = centre
    if near.all():
        return PrincipalFrame(frame, "the file's own axes: its three principal moments are equal")
    if near[0]:  # the two least moments equal: a disc or a bowl, wide about the axis of the largest
        z, x, said = vectors[:, 2], None, "z along its symmetry axis"
    elif near[1]:  # the two largest equal: a can or a bottle, long about the axis of the least
        z, x, said = vectors[:, 0], None, "z along its symmetry axis"
    else:
        z, x, said = vectors[:, 0], vectors[:, 1], "z along its longest axis"
    z = _pointed(z, spread, weights)
    x = _across(z) if x is None else _pointed(x, spread, weights)
    frame[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    return PrincipalFrame(frame, said)


def _pointed(axis: np.ndarray, spread: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``axis`` pointed to the side where the object reaches farther, or along the file's nearest axis where
    neither side does."""
    along = spread @ axis
    skew, scale = float(weights @ along**3), float(weights @ np.abs(along) ** 3)
    if abs(skew) > EVEN_SIDES * scale:
        return axis if skew > 0 else -axis
    return axis if axis[np.argmax(np.abs(axis))] > 0 else -axis


def _across(z: np.ndarray) -> np.ndarray:
    """x for a frame whose turn about ``z`` nothing fixes: the file's axis farthest from z, made square to it."""
    file_axis = np.eye(3)[np.argmin(np.abs(z))]
    x = file_axis - (file_axis @ z) * z
    return x / np.linalg.norm(x)
