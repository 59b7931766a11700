"""Symmetric positive definite matrices under the Log-Euclidean metric (Arsigny et al. 2006, paper eq. 15).

Every function takes a single ``(d, d)`` matrix or a stack ``(..., d, d)``; logs are taken through one
symmetric eigendecomposition per matrix.
"""

from __future__ import annotations

import numpy as np


def _eig_map(matrices: np.ndarray, function) -> np.ndarray:
    values, vectors = np.linalg.eigh(matrices)
    return (vectors * function(values)[..., None, :]) @ np.swapaxes(vectors, -1, -2)


def spd_log(matrices: np.ndarray) -> np.ndarray:
    """Matrix logarithm of SPD matrices; raises ``ValueError`` if one is not positive definite."""
    values = np.linalg.eigvalsh(matrices)
    if np.any(values <= 0):
        raise ValueError("matrix is not positive definite")
    return _eig_map(matrices, np.log)


def spd_exp(matrices: np.ndarray) -> np.ndarray:
    """Matrix exponential of symmetric matrices."""
    return _eig_map(matrices, np.exp)


def log_euclidean_mean(matrices: np.ndarray) -> np.ndarray:
    """``exp(mean(log S_k))`` of a stack of SPD matrices."""
    return spd_exp(spd_log(matrices).mean(axis=0))


def log_vectors(matrices: np.ndarray) -> np.ndarray:
    """Upper triangles of ``log S``, off-diagonals scaled by sqrt(2), so Euclidean norm = Frobenius norm.

    Distances between these ``d(d+1)/2`` vectors are the Log-Euclidean distances of eq. 15.
    """
    logs = spd_log(matrices)
    d = logs.shape[-1]
    rows, cols = np.triu_indices(d)
    weights = np.where(rows == cols, 1.0, np.sqrt(2.0))
    return logs[..., rows, cols] * weights


def log_euclidean_distance(x: np.ndarray, y: np.ndarray) -> float:
    """``||log X - log Y||_F`` for two SPD matrices."""
    return float(np.linalg.norm(spd_log(x) - spd_log(y)))


def spd_problem(matrix: object, d: int = 6, rtol: float = 1e-9, ratio: float = 1e-12) -> str | None:
    """Why ``matrix`` is not a ``(d, d)`` symmetric positive definite matrix of finite numbers, or None: it
    must be symmetric to ``rtol`` and its smallest eigenvalue above ``ratio`` times its largest (the bound
    under which ``fit-task`` calls an ellipsoid singular)."""
    try:
        m = np.asarray(matrix, dtype=float)
    except (TypeError, ValueError):
        return "is not a matrix of numbers"
    if m.shape != (d, d):
        return f"must be {d} x {d}, got shape {m.shape}"
    if not np.isfinite(m).all():
        return "holds NaN or infinite values"
    scale = float(np.abs(m).max())
    if scale == 0:
        return "is all zero"
    if np.abs(m - m.T).max() > rtol * scale:
        return "is not symmetric"
    values = np.linalg.eigvalsh(m)
    if values[0] <= ratio * values[-1]:
        return f"is not positive definite (smallest eigenvalue {values[0]:.3g})"
    return None
