"""The surrogate surface of a mesh or point cloud as CasADi functions: a quintic B-spline of its signed-distance
grid, with exact derivatives of every order (``Function.bspline``).

The coefficients are prefiltered so that the spline passes through the grid values. The contact normals are
the spline's gradient, so the Lagrangian's Hessian holds its third derivatives; a quintic keeps them continuous.
Outside the grid the spline is zero, which would read as "on the surface": a point there is clamped into the
grid and its distance beyond added, smoothed within a tenth of a millimetre so that the gradient stays
continuous. Only far-away hand spheres go there, and their clearance is never in doubt.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import casadi
import numpy as np
from scipy import ndimage

from grasptask.objects.distance_grid import DistanceGrid

SMOOTHING_M = 1e-4
#: the spline's degree in each axis: quintic, so that the third derivatives in the normals' Hessian are
#: continuous (a cubic's jump at every knot); see docs/design/synthesis.md
DEGREE = 5
#: the grid is smoothed by a Gaussian of this many cells before the spline interpolates it: the distance field's
#: creases (a handle meeting a body, the middle of a thin part) otherwise give the spline large higher
#: derivatives. It moves the mug's zero set by 0.04 mm (median; at most 0.9 mm, at the handle's crease).
SMOOTHING_CELLS = 0.7


@dataclass(frozen=True)
class SurrogateSpec:
    """What a backend needs to put the B-spline into the NL model's placeholder rows ``value == 0``: for each,
    its row, the value's column, the point's three columns, and None (the distance) or a gradient component."""

    grid: DistanceGrid
    rows: tuple[int, ...]
    values: tuple[int, ...]
    points: tuple[tuple[int, int, int], ...]
    components: tuple[int | None, ...]


@dataclass(frozen=True)
class _Spline:
    """A grid's B-spline: its knots and coefficients, and the box where every basis function is present."""

    knots: list[np.ndarray]
    coefficients: np.ndarray
    low: np.ndarray
    high: np.ndarray
    #: each partial's B-spline, made once: its coefficients are as large as the grid
    _partials: dict[tuple[int, int, int], casadi.Function] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def of(cls, grid: DistanceGrid) -> _Spline:
        """The grid's spline, made once per grid: a worker builds several functions of it."""
        cached = _SPLINES.get(id(grid))
        if cached is not None and cached[0] is grid:
            return cached[1]
        h, counts, d = grid.spacing, np.array(grid.shape), DEGREE
        # each basis function is centred on its grid point
        knots = [grid.origin[i] + h * (np.arange(counts[i] + d + 1) - (d + 1) / 2) for i in range(3)]
        low, high = grid.origin + h * (d - 1) / 2, grid.upper - h * (d - 1) / 2
        spline = cls(knots, interpolating_coefficients(grid.values), low, high)
        if len(_SPLINES) >= _KEPT:  # a worker has one grid; a notebook or a test process may make many
            del _SPLINES[next(iter(_SPLINES))]
        _SPLINES[id(grid)] = (grid, spline)
        return spline

    def partial(self, orders: tuple[int, int, int]) -> casadi.Function:
        """The spline of ``d^|orders| / dq^orders``: on uniform knots, differenced coefficients over the spacing,
        one degree lower and one knot shorter at each end per derivative along an axis."""
        if orders in self._partials:
            return self._partials[orders]
        coefficients, knots = self.coefficients, []
        for axis, k in enumerate(orders):
            h = float(self.knots[axis][1] - self.knots[axis][0])
            coefficients = np.diff(coefficients, n=k, axis=axis) / h**k
            knots.append(self.knots[axis][k : len(self.knots[axis]) - k].tolist())
        degrees = [DEGREE - k for k in orders]
        spline = casadi.Function.bspline("grid", knots, coefficients.ravel(order="F").tolist(), degrees, 1, {})
        self._partials[orders] = spline
        return spline


_SPLINES: dict[int, tuple[DistanceGrid, _Spline]] = {}
_KEPT = 4


def _clamped(spline: _Spline, q: Any) -> tuple[Any, Any]:
    """``q`` clamped into the spline's box, and the smoothed distance beyond it."""
    inside = casadi.fmin(casadi.fmax(q, spline.low), spline.high)
    return inside, casadi.sqrt(casadi.sumsqr(q - inside) + SMOOTHING_M**2) - SMOOTHING_M


def distance_function(grid: DistanceGrid) -> casadi.Function:
    """``S(q)``: the signed distance (m) at a point ``q`` (3 x 1), as an MX function."""
    spline = _Spline.of(grid)
    q = casadi.MX.sym("q", 3)
    inside, beyond = _clamped(spline, q)
    return casadi.Function("surrogate_distance", [q], [spline.partial((0, 0, 0))(inside) + beyond])


def derivative_function(grid: DistanceGrid, order: int) -> casadi.Function:
    """The ``3^order`` derivatives of ``S`` at ``q``, the entry of ``(i1, .., ik)`` at ``sum_m i_m 3^(m-1)``.

    Each distinct partial is its own B-spline (:meth:`_Spline.partial`). CasADi's own derivatives of the
    spline are exact too, but they keep every permutation of each order: 39 coefficient arrays the size of the
    grid for orders 1-3, where 19 are distinct."""
    spline = _Spline.of(grid)
    q = casadi.MX.sym("q", 3)
    inside, beyond = _clamped(spline, q)
    # where q is clamped along an axis the spline does not change along it; the distance beyond carries it
    within = [casadi.logic_and(q[i] > spline.low[i], q[i] < spline.high[i]) for i in range(3)]
    partials: dict[tuple[int, int, int], Any] = {}
    entries = []
    for flat in range(3**order):
        axes = [(flat // 3**m) % 3 for m in range(order)]
        counts = (axes.count(0), axes.count(1), axes.count(2))
        if counts not in partials:
            mask = casadi.MX(1)
            for i in set(axes):
                mask = mask * within[i]
            partials[counts] = mask * spline.partial(counts)(inside)
        entries.append(partials[counts])
    beyond_part = beyond
    for _ in range(order):
        beyond_part = casadi.vec(casadi.jacobian(beyond_part, q))
    return casadi.Function(f"surrogate_order_{order}", [q], [casadi.vertcat(*entries) + beyond_part])


def interpolating_coefficients(values: np.ndarray) -> np.ndarray:
    """The B-spline coefficients whose spline passes through the grid values smoothed by
    :data:`SMOOTHING_CELLS` (scipy's prefilter). With the values themselves as coefficients the spline smooths
    by an amount that depends on the shape: its zero set then lies ``h^2 / 6`` times the surface's mean
    curvature inside it, 0.1 mm on a 1 cm radius at 2.5 mm spacing."""
    smoothed = ndimage.gaussian_filter(values, SMOOTHING_CELLS, mode="nearest")
    return ndimage.spline_filter(smoothed, order=DEGREE, mode="mirror")


def gradient_function(distance: casadi.Function) -> casadi.Function:
    """``grad S(q)`` (3 x 1)."""
    q = casadi.MX.sym("q", 3)
    return casadi.Function("surrogate_gradient", [q], [casadi.jacobian(distance(q), q).T])


def evaluate(function: casadi.Function, points: np.ndarray) -> np.ndarray:
    """``function`` at ``(N, 3)`` points: ``(N,)`` distances or ``(N, 3)`` gradients."""
    points = np.atleast_2d(points)
    out = np.asarray(function.map(len(points))(points.T))
    return out.ravel() if out.shape[0] == 1 else out.T


@dataclass(frozen=True)
class SurrogateTerms:
    """The spline's part of the NLP, as MX: ``correction`` makes each placeholder row ``value - S(point)``
    (or ``value - dS/dq_i``), ``jacobian`` is its derivative and ``hessian`` the upper triangle of
    ``sum_r lam_r d2(row_r)/dx2``. Written out from the spline's derivatives at each distinct point, so that
    the rest of the NLP keeps its expanded SX derivatives, which CasADi's MX derivatives of the whole model
    would lose (docs/design/synthesis.md)."""

    correction: Any
    jacobian: Any
    hessian: Any


def surrogate_terms(x: Any, lam: Any, spec: SurrogateSpec, n_rows: int) -> SurrogateTerms:
    """:class:`SurrogateTerms` for the NLP's variables ``x`` and constraint multipliers ``lam`` (MX)."""
    points = list(dict.fromkeys(spec.points))  # distinct points, in order of first use
    which = [points.index(p) for p in spec.points]
    normals = sorted({which[k] for k, c in enumerate(spec.components) if c is not None})
    where = casadi.horzcat(*[casadi.vertcat(*[x[c] for c in p]) for p in points])
    q = casadi.MX.sym("q", 3)
    # order k: the 3^k derivatives d^k S / dq_i1 .. dq_ik, the entry of (i1, .., ik) at sum_m i_m 3^(m-1)
    distance = distance_function(spec.grid)
    orders = [
        distance(q),
        gradient_function(distance)(q),
        derivative_function(spec.grid, 2)(q),
        derivative_function(spec.grid, 3)(q),
    ]
    blocks: dict[int, tuple[list[int], Any]] = {}

    def block(k: int) -> tuple[list[int], Any]:
        """Order ``k`` at every point that needs it (the third only at the normals' points), evaluated once."""
        if k not in blocks:
            at = normals if k == 3 else list(range(len(points)))
            function = casadi.Function(f"surrogate_order_{k}", [q], [orders[k]])
            blocks[k] = (at, casadi.vec(function.map(len(at))(where[:, at])))
        return blocks[k]

    def picked(entries: list[tuple[int, int, int]]) -> Any:
        """The ``(order, point, index)`` entries as one MX vector, from only the orders they need."""
        offset, parts, size = {}, [], 0
        for k in sorted({k for k, _, _ in entries}):
            at, values = block(k)
            offset[k], size = (size, at), size + values.shape[0]
            parts.append(values)
        stacked = casadi.vertcat(*parts)
        return stacked[[offset[k][0] + 3**k * offset[k][1].index(j) + i for k, j, i in entries]]

    values, jac, hess = _entries(spec, which)
    n_x = x.shape[0]
    correction = casadi.MX(
        casadi.Sparsity.triplet(n_rows, 1, [r for r, _ in values], [0] * len(values)), -picked([e for _, e in values])
    )
    jac.sort(key=lambda t: (t[1], t[0]))  # column-major, as CasADi stores nonzeros
    jacobian = casadi.MX(
        casadi.Sparsity.triplet(n_rows, n_x, [r for r, _, _ in jac], [c for _, c, _ in jac]),
        -picked([e for *_, e in jac]),
    )
    # several rows share a point (a contact's distance and its normal): their entries are summed into one
    keys = sorted({(c, r) for r, c, _, _ in hess})
    slot = {key: i for i, key in enumerate(keys)}
    assembly = casadi.DM(
        casadi.Sparsity.triplet(len(keys), len(hess), [slot[c, r] for r, c, _, _ in hess], list(range(len(hess)))), 1.0
    )
    contributions = -lam[[m for _, _, m, _ in hess]] * picked([e for *_, e in hess])
    hessian = casadi.MX(
        casadi.Sparsity.triplet(n_x, n_x, [r for _, r in keys], [c for c, _ in keys]),
        casadi.mtimes(assembly, contributions),
    )
    return SurrogateTerms(correction, jacobian, hessian)


def _entries(spec: SurrogateSpec, which: list[int]) -> tuple[list, list, list]:
    """Where each derivative the surrogate's rows need goes, as ``(order, point, index)`` entries: the rows'
    values ``(row, entry)`` (sorted), their Jacobian ``(row, column, entry)`` and the upper triangle of their
    Hessians ``(row, column, multiplier row, entry)``."""
    values, jac, hess = [], [], []
    for k, component in enumerate(spec.components):
        j, columns, row = which[k], spec.points[k], spec.rows[k]
        c = 0 if component is None else 1  # a distance row is S, a normal's row its derivative dS/dq_component
        first = 0 if component is None else component
        values.append((row, (c, j, first)))
        for a in range(3):
            jac.append((row, columns[a], (c + 1, j, first + 3**c * a)))
            for b in range(3):
                if columns[a] <= columns[b]:  # the upper triangle
                    hess.append((columns[a], columns[b], row, (c + 2, j, first + 3**c * (a + 3 * b))))
    values.sort()
    return values, jac, hess
