"""The surrogate surface of a mesh or point cloud as CasADi functions: a cubic B-spline of its signed-distance
grid, with exact derivatives of every order (``Function.bspline``).

The coefficients are the grid values themselves, so the spline is smooth and reproduces a linear field exactly.
Outside the grid the spline is zero, which would read as "on the surface": a point there is clamped into the
grid and its distance beyond added, smoothed within a tenth of a millimetre so that the gradient stays
continuous. Only far-away hand spheres go there, and their clearance is never in doubt.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi
import numpy as np

from grasptask.objects.distance_grid import DistanceGrid

SMOOTHING_M = 1e-4


@dataclass(frozen=True)
class SurrogateSpec:
    """What a backend needs to put the B-spline into the NL model's placeholder rows ``value == 0``: for each,
    its row, the value's column, the point's three columns, and None (the distance) or a gradient component."""

    grid: DistanceGrid
    rows: tuple[int, ...]
    values: tuple[int, ...]
    points: tuple[tuple[int, int, int], ...]
    components: tuple[int | None, ...]


def distance_function(grid: DistanceGrid) -> casadi.Function:
    """``S(q)``: the signed distance (m) at a point ``q`` (3 x 1), as an MX function."""
    h, counts = grid.spacing, np.array(grid.shape)
    knots = [(grid.origin[i] + h * (np.arange(counts[i] + 4) - 2)).tolist() for i in range(3)]
    spline = casadi.Function.bspline("grid", knots, grid.values.ravel(order="F").tolist(), [3, 3, 3], 1, {})
    q = casadi.MX.sym("q", 3)
    # the spline is a partition of unity between the second and the last-but-one grid points
    low, high = grid.origin + h, grid.upper - h
    inside = casadi.fmin(casadi.fmax(q, low), high)
    beyond = casadi.sqrt(casadi.sumsqr(q - inside) + SMOOTHING_M**2) - SMOOTHING_M
    return casadi.Function("surrogate_distance", [q], [spline(inside) + beyond])


def gradient_function(distance: casadi.Function) -> casadi.Function:
    """``grad S(q)`` (3 x 1)."""
    q = casadi.MX.sym("q", 3)
    return casadi.Function("surrogate_gradient", [q], [casadi.jacobian(distance(q), q).T])


def evaluate(function: casadi.Function, points: np.ndarray) -> np.ndarray:
    """``function`` at ``(N, 3)`` points: ``(N,)`` distances or ``(N, 3)`` gradients."""
    points = np.atleast_2d(points)
    out = np.asarray(function.map(len(points))(points.T))
    return out.ravel() if out.shape[0] == 1 else out.T


def substituted(x: Any, g: Any, spec: SurrogateSpec) -> Any:
    """``g`` with each placeholder row ``value`` (its body) made ``value - S(point)``, or ``value - dS/dq_i``."""
    distance = distance_function(spec.grid)
    gradient = gradient_function(distance)
    correction = casadi.MX.zeros(g.shape[0], 1)
    for kind, function in ((None, distance), ("gradient", gradient)):
        picks = [k for k, c in enumerate(spec.components) if (c is None) == (kind is None)]
        if not picks:
            continue
        points = casadi.horzcat(*[casadi.vertcat(*[x[c] for c in spec.points[k]]) for k in picks])
        out = function.map(len(picks))(points)
        for n, k in enumerate(picks):
            component = spec.components[k]
            correction[spec.rows[k]] = -(out[0, n] if component is None else out[component, n])
    return g + correction
