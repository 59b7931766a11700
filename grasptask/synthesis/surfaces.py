"""The object's surface as Pyomo expressions, written independently of :mod:`grasptask.objects` (whose numpy
code the verifier uses), so that the NLP and its judge share no code.

Each surface gives the contact residual of eq. 3 (zero on the surface), eq. 14's clearance of a ball (``>= 0``
when it stays out) and the gradient whose normalisation is the contact normal. A mesh's or point cloud's
surface is a B-spline of a signed-distance grid, which Pyomo cannot write: it is evaluated by the backend.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import pyomo.environ as pyo

from grasptask.objects.distance_grid import DistanceGrid
from grasptask.objects.gp import GPImplicitSurface
from grasptask.objects.mesh_object import MeshObject, PointCloudObject
from grasptask.objects.superquadric import Superquadric
from grasptask.objects.surface import ImplicitObject
from grasptask.synthesis.algebra import XYZ, power

Point = Sequence[Any]


class NLPSurface(Protocol):
    #: the surface's value is the distance to it, so a rolling fingertip's contact is found from its centre
    measures_distance: bool

    def attach(self, model: Any, definitions: list[tuple[Any, Any]]) -> None: ...

    def contact(self, p: Point) -> Any: ...

    def clearance(self, p: Point, radius: float) -> Any: ...

    def gradient(self, p: Point) -> list[Any]: ...


class SuperquadricSurface:
    """A superquadric in terms of ``F^(e1/2)``, which is well scaled near the surface. Collisions use the
    superquadric inflated by the ball's radius, because the radial distance beside a long thin cylinder
    overstates the true clearance several-fold."""

    measures_distance = False

    def __init__(self, sq: Superquadric):
        self.a, self.e1, self.e2 = sq.a, sq.e1, sq.e2
        self.rotation, self.position = sq.rotation, sq.position

    def attach(self, model: Any, definitions: list[tuple[Any, Any]]) -> None:
        """Nothing to add: the surface is an expression."""

    def _local(self, p: Point) -> list[Any]:
        d = [p[i] - self.position[i] for i in XYZ]
        return [sum(self.rotation[i, j] * d[i] for i in XYZ) for j in XYZ]  # R^T (p - t)

    def _inside_outside(self, x: Point, a: np.ndarray) -> Any:
        u = (x[0] / a[0]) ** 2
        v = (x[1] / a[1]) ** 2
        w = (x[2] / a[2]) ** 2
        p_, r_, s_ = 1 / self.e2, self.e2 / self.e1, 1 / self.e1
        return power(power(u, p_) + power(v, p_), r_) + power(w, s_)

    def contact(self, p: Point) -> Any:
        """``F^(e1/2) - 1``: zero on the surface."""
        return self._inside_outside(self._local(p), self.a) ** (self.e1 / 2) - 1

    def clearance(self, p: Point, radius: float) -> Any:
        """``>= 0`` when a ball of ``radius`` at ``p`` stays out: outside the superquadric inflated by it."""
        return self._inside_outside(self._local(p), self.a + radius) ** (self.e1 / 2) - 1

    def gradient(self, p: Point) -> list[Any]:
        """Gradient of ``F^(e1/2)`` in the object frame."""
        x = self._local(p)
        a = self.a
        u, v, w = ((x[i] / a[i]) ** 2 for i in XYZ)
        p_, r_, s_ = 1 / self.e2, self.e2 / self.e1, 1 / self.e1
        base = power(u, p_) + power(v, p_)
        big_f = power(base, r_) + power(w, s_)
        outer = (self.e1 / 2) * power(big_f, self.e1 / 2 - 1)
        radial = outer * r_ * power(base, r_ - 1) * p_
        local = [
            radial * power(u, p_ - 1) * 2 * x[0] / a[0] ** 2,
            radial * power(v, p_ - 1) * 2 * x[1] / a[1] ** 2,
            outer * s_ * power(w, s_ - 1) * 2 * x[2] / a[2] ** 2,
        ]
        return [sum(self.rotation[i, j] * local[j] for j in XYZ) for i in XYZ]


class GPSurface:
    """The GP's posterior mean ``sum_k alpha_k |p - x_k|^3 + c0 + c.p``: a signed distance in metres."""

    measures_distance = False  # a distance near the surface it was fitted to, not 6-8 mm off it

    def __init__(self, gp: GPImplicitSurface):
        self.support, self.alpha, self.coef = gp.support, gp.alpha, gp.mean_coefficients

    def attach(self, model: Any, definitions: list[tuple[Any, Any]]) -> None:
        """Nothing to add: the surface is an expression."""

    def _squared(self, p: Point, x: np.ndarray) -> Any:
        return sum((p[i] - x[i]) ** 2 for i in XYZ)

    def contact(self, p: Point) -> Any:
        terms = sum(a * self._squared(p, x) ** 1.5 for a, x in zip(self.alpha, self.support, strict=True))
        return terms + self.coef[0] + sum(self.coef[1 + i] * p[i] for i in XYZ)

    def clearance(self, p: Point, radius: float) -> Any:
        return self.contact(p) - radius

    def gradient(self, p: Point) -> list[Any]:
        weights = [3 * a * self._squared(p, x) ** 0.5 for a, x in zip(self.alpha, self.support, strict=True)]
        return [
            sum(w * (p[i] - x[i]) for w, x in zip(weights, self.support, strict=True)) + self.coef[1 + i] for i in XYZ
        ]


@dataclass
class SurrogateLink:
    """One ``value == S(point)`` equality that Pyomo cannot write: in the model it is the placeholder
    ``value == 0``, and the backend puts the B-spline in its place (:mod:`grasptask.synthesis.backends`)."""

    constraint: Any  # the placeholder's constraint data
    value: Any  # the variable that takes S(point), or one component of its gradient
    point: list[Any]  # three variables
    component: int | None  # None: the distance itself; 0-2: that component of its gradient


class GridSurface:
    """A mesh's or point cloud's signed-distance grid (:class:`DistanceGrid`), through a quintic B-spline that
    the backend evaluates. Each point where the NLP needs the surface gets variables for its coordinates (unless
    they are variables already), for the distance and, at contacts, for its gradient; eq. 3 is then
    ``distance == 0``, eq. 14 ``distance - radius >= 0``.

    A signed distance is smooth away from the surface, but a wall thinner than the grid's spacing (a scanned
    mug's, 1-3 mm) is not in its zero set: the zero set there is up to a millimetre off, and most of the mug's
    starts ended infeasible. So a rolling contact is found where the field is smooth, at its fingertip sphere's
    centre: ``distance(c) == r - compliance``, the normal from the gradient at ``c``, and
    ``p = c + (r - compliance) n``, which for an exact distance is the surface's point nearest ``c``."""

    measures_distance = True

    def __init__(self, grid: DistanceGrid):
        self.grid = grid
        self.links: list[SurrogateLink] = []
        self.model: Any = None
        self.definitions: list[tuple[Any, Any]] = []
        self._points: dict[tuple[int, ...], list[Any]] = {}

    def attach(self, model: Any, definitions: list[tuple[Any, Any]]) -> None:
        model.surrogate_point = pyo.VarList(doc="points where the surrogate surface is evaluated")
        model.surrogate_point_definition = pyo.ConstraintList()
        model.surrogate_value = pyo.VarList(doc="the surrogate's signed distance (m) and gradient at those points")
        model.surrogate_link = pyo.ConstraintList(doc="value == S(point), put in place by the backend")
        self.model, self.definitions = model, definitions

    def _point(self, p: Point) -> list[Any]:
        key = tuple(id(c) for c in p)
        if key not in self._points:
            if all(getattr(c, "is_variable_type", lambda: False)() for c in p):
                self._points[key] = list(p)
            else:
                point = [self.model.surrogate_point.add() for _ in XYZ]
                for var, expr in zip(point, p, strict=True):
                    self.model.surrogate_point_definition.add(var == expr)
                    self.definitions.append((var, expr))
                self._points[key] = point
        return self._points[key]

    def _value(self, p: Point, component: int | None) -> Any:
        point = self._point(p)
        value = self.model.surrogate_value.add()
        link = SurrogateLink(self.model.surrogate_link.add(value == 0), value, point, component)
        self.links.append(link)
        self.definitions.append((value, link))
        return value

    def contact(self, p: Point) -> Any:
        return self._value(p, None)

    def clearance(self, p: Point, radius: float) -> Any:
        return self._value(p, None) - radius

    def gradient(self, p: Point) -> list[Any]:
        return [self._value(p, i) for i in XYZ]


def surface_for(obj: ImplicitObject) -> NLPSurface:
    """The NLP's surface for a loaded object. A mesh or point cloud is constrained through a surrogate, the
    B-spline of its signed-distance grid; the verifier judges the grasp against the mesh or points."""
    if isinstance(obj, Superquadric):
        return SuperquadricSurface(obj)
    if isinstance(obj, GPImplicitSurface):
        return GPSurface(obj)
    if isinstance(obj, MeshObject | PointCloudObject):
        return GridSurface(obj.distance_grid)
    raise TypeError(f"no NLP surface for {type(obj).__name__}")
