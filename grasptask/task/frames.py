"""Rigid-body wrench transformation between a sensor frame and the object frame."""

from __future__ import annotations

import numpy as np


def skew(p: np.ndarray) -> np.ndarray:
    """The matrix ``[p]x`` with ``[p]x v = p x v``."""
    x, y, z = p
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def wrench_transform(rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    """6x6 map from a wrench in a frame at pose (R, p) to the same wrench in the reference frame.

    ``f_o = R f_s`` and, taken about the reference origin, ``t_o = R t_s + p x (R f_s)``.
    """
    adjoint = np.zeros((6, 6))
    adjoint[:3, :3] = rotation
    adjoint[3:, 3:] = rotation
    adjoint[3:, :3] = skew(position) @ rotation
    return adjoint


def transform_wrenches(wrenches: np.ndarray, rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    """Rows of ``(n, 6)`` wrenches in the sensor frame, re-expressed in the object frame."""
    return wrenches @ wrench_transform(rotation, position).T
