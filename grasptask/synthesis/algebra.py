"""Vector algebra on lists of Pyomo expressions (or numbers), for writing the NLP's equations by component."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

#: the three coordinate indices
XYZ = (0, 1, 2)


def cross(a: Sequence[Any], b: Sequence[Any]) -> list[Any]:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a: Sequence[Any], b: Sequence[Any]) -> Any:
    return sum(x * y for x, y in zip(a, b, strict=True))


def power(x: Any, exponent: float) -> Any:
    """``x ** exponent``, written out for the exponents 0 and 1: the derivative of ``x ** 0`` is
    ``0 * x ** -1``, NaN at ``x = 0``, and a cylinder (e2 = 1) puts that on every contact on its axis plane."""
    if exponent == 0:
        return 1.0
    if exponent == 1:
        return x
    return x**exponent


def cross_matrix(axis: np.ndarray) -> np.ndarray:
    """``[axis]x``, so that ``[axis]x v = axis x v``, for a constant axis."""
    return np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])


def constant_times(matrix: np.ndarray, v: Sequence[Any]) -> list[Any]:
    """``matrix @ v`` for a constant matrix, leaving out its zero entries (no ``0 * x`` terms in the model)."""
    return [sum(matrix[i, k] * v[k] for k in XYZ if matrix[i, k] != 0) for i in XYZ]


def axis_rotation(axis: np.ndarray, c: Any, s: Any) -> list[list[Any]]:
    """Rodrigues' rotation about a constant unit axis, with c = cos theta and s = sin theta as expressions."""
    k = cross_matrix(axis)
    kk = k @ k
    return [[(1.0 if i == j else 0.0) + s * k[i, j] + (1 - c) * kk[i, j] for j in XYZ] for i in XYZ]
