"""Task ellipsoids from wrench samples (paper Section 2)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

FORCE = slice(0, 3)
TORQUE = slice(3, 6)
#: ``S`` with its smallest eigenvalue below this fraction of the largest is treated as singular
SINGULAR_RATIO = 1e-12


def second_moment(wrenches: np.ndarray, centered: bool = False) -> np.ndarray:
    """``S = mean(w w^T)`` over ``(n, 6)`` samples, or their covariance when ``centered``.

    The second moment about the origin is the default so that a constant pressing force counts.
    """
    w = np.asarray(wrenches, dtype=float)
    if centered:
        w = w - w.mean(axis=0)
    s = w.T @ w / len(w)
    return 0.5 * (s + s.T)


def principal_axes(matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lengths ``sqrt(eigenvalue)`` in descending order and unit axes as the columns of a matrix.

    Each axis is signed so that its largest-magnitude component is positive, which makes axes comparable
    across recordings.
    """
    values, vectors = np.linalg.eigh(matrix)
    order = np.argsort(values)[::-1]
    values, vectors = values[order], vectors[:, order]
    pivot = np.argmax(np.abs(vectors), axis=0)
    vectors = vectors * np.sign(vectors[pivot, np.arange(vectors.shape[1])])
    return np.sqrt(np.clip(values, 0.0, None)), vectors


def semi_axes(matrix: np.ndarray) -> np.ndarray:
    """The ellipsoid's semi-axes ``gamma_i u_i`` as the rows of a matrix, the longest first, signed as
    :func:`principal_axes` signs them."""
    lengths, axes = principal_axes(matrix)
    return (axes * lengths).T


def is_singular(matrix: np.ndarray) -> bool:
    values = np.linalg.eigvalsh(matrix)
    return bool(values[-1] <= 0 or values[0] <= SINGULAR_RATIO * values[-1])


@dataclass(frozen=True)
class Ellipsoid:
    """A 6D task ellipsoid: ``S``, its axes ``u_i`` (columns, longest first) and lengths ``gamma_i`` (SI)."""

    S: np.ndarray
    axes: np.ndarray
    lengths: np.ndarray

    @classmethod
    def from_matrix(cls, matrix: np.ndarray) -> Ellipsoid:
        lengths, axes = principal_axes(matrix)
        return cls(S=np.asarray(matrix), axes=axes, lengths=lengths)

    @classmethod
    def from_wrenches(cls, wrenches: np.ndarray, centered: bool = False) -> Ellipsoid:
        return cls.from_matrix(second_moment(wrenches, centered))

    @property
    def weights(self) -> np.ndarray:
        """Normalised lengths ``gamma_i / sum(gamma)``, the weights of eq. 12."""
        return self.lengths / self.lengths.sum()


def torque_to_force(matrix: np.ndarray) -> float:
    """The RMS torque magnitude over the RMS force magnitude, ``sqrt(tr S_tt / tr S_ff)`` (m): in SI units a
    1 N.m torque weighs as a 1 N force, so this is how much the torques weigh beside the forces."""
    force = float(np.trace(matrix[FORCE, FORCE]))
    return float(np.sqrt(np.trace(matrix[TORQUE, TORQUE]) / force)) if force > 0 else float("inf")


def torque_axes_weight(ellipsoid: Ellipsoid) -> float:
    """The share of eq. 12's weights held by the axes that are mostly torque (``|u_i,torque|^2 > 1/2``)."""
    torque = (ellipsoid.axes[TORQUE, :] ** 2).sum(axis=0) > 0.5
    return float(ellipsoid.weights[torque].sum())


def block_lengths(matrices: np.ndarray, block: slice) -> np.ndarray:
    """Axis lengths of the force or torque projection (3x3 block) of ``(..., 6, 6)`` matrices, ascending."""
    return np.sqrt(np.clip(np.linalg.eigvalsh(matrices[..., block, block]), 0.0, None))


def block_extents(matrices: np.ndarray, block: slice) -> np.ndarray:
    """Half-widths ``sqrt(S_kk)`` along the object axes x, y, z of a force or torque block."""
    return np.sqrt(np.clip(np.diagonal(matrices[..., block, block], axis1=-2, axis2=-1), 0.0, None))


def ellipsoid_matrices(frame: pd.DataFrame) -> np.ndarray:
    """The ``(k, 6, 6)`` stack of ``S`` from an ellipsoids table."""
    return np.stack([np.asarray(s, dtype=float).reshape(6, 6) for s in frame["S"]])
