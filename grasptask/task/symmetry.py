"""How far a task is from symmetric about an axis: the most eq. 12's Q can change, relative, as a grasp turns
about it.

Q = tr(K^-1 S) for a grasp-dependent K and the task's S = sum_i gamma_i u_i u_i^T. Turning the grasp by psi about
the axis turns S by B(psi) = diag(R(psi), R(psi)) (wrenches taken about a point on the axis). Split S into its
mean over the turn, S_bar, which no turn changes, and the rest D. If -c S_bar <= D <= c S_bar, then for every
grasp and turn |Q(psi) - Q_bar| <= c Q_bar, with c the largest |eigenvalue| of S_bar^-1/2 D S_bar^-1/2.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from grasptask.task.frames import wrench_transform

# B S B^T is a trigonometric polynomial of degree 2 in psi, so its mean over 8 equal steps is exact
_TURNS = 8


def axis_asymmetry(weights: np.ndarray, axes: np.ndarray, axis: np.ndarray, point: np.ndarray) -> float:
    """The bound c above for a task with eq. 12's ``weights`` and unit wrench ``axes`` (rows, about the
    origin), turned about the line through ``point`` along ``axis``: 0 for a task symmetric about it."""
    about_point = wrench_transform(np.eye(3), -np.asarray(point, dtype=float))
    units = np.asarray(axes, dtype=float) @ about_point.T
    s = units.T @ (np.asarray(weights, dtype=float)[:, None] * units)
    direction = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    turned = []
    for psi in 2 * np.pi * np.arange(_TURNS) / _TURNS:
        b = wrench_transform(Rotation.from_rotvec(psi * direction).as_matrix(), np.zeros(3))
        turned.append(b @ s @ b.T)
    mean = np.mean(turned, axis=0)
    values, vectors = np.linalg.eigh(mean)
    whitening = vectors @ np.diag(values**-0.5) @ vectors.T
    return float(np.max(np.abs(np.linalg.eigvalsh(whitening @ (s - mean) @ whitening))))
