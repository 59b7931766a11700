"""Superquadrics (paper Section 4): F = ((x/a1)^(2/e2) + (y/a2)^(2/e2))^(e2/e1) + (z/a3)^(2/e1), g = F - 1."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from grasptask.objects.surface import ImplicitObject, Symmetry


@dataclass(eq=False)
class Superquadric(ImplicitObject):
    """A superquadric with half-sizes ``a`` (m), shape exponents ``(e1, e2)`` and a pose in the object frame.

    The defaults are the paper's sensorized tool: a cylinder 20 cm long and 2 cm in diameter along z, with
    ``e1 = 0.1`` and ``e2 = 1`` so that every exponent is an even integer and ``g`` is smooth.
    """

    a: np.ndarray = field(default_factory=lambda: np.array([0.01, 0.01, 0.10]))
    e1: float = 0.1
    e2: float = 1.0
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    name: str = "superquadric"
    symmetry: Symmetry | None = None

    def __post_init__(self):
        self.a = np.asarray(self.a, dtype=float)
        self.rotation = np.asarray(self.rotation, dtype=float)
        self.position = np.asarray(self.position, dtype=float)

    def local(self, p: np.ndarray) -> np.ndarray:
        return (np.atleast_2d(p) - self.position) @ self.rotation

    def inside_outside(self, p: np.ndarray) -> np.ndarray:
        """``F(p)``: 1 on the surface."""
        u, v, w = (self.local(p) / self.a).T ** 2
        return (u ** (1 / self.e2) + v ** (1 / self.e2)) ** (self.e2 / self.e1) + w ** (1 / self.e1)

    def g(self, p: np.ndarray) -> np.ndarray:
        return self.inside_outside(p) - 1.0

    def gradient(self, p: np.ndarray) -> np.ndarray:
        x = self.local(p)
        u, v, w = (x / self.a).T ** 2
        p_, r_, s_ = 1 / self.e2, self.e2 / self.e1, 1 / self.e1
        tiny = 1e-300
        base = np.maximum(u**p_ + v**p_, tiny)
        outer = r_ * base ** (r_ - 1) * p_
        local_grad = np.column_stack(
            [
                outer * np.maximum(u, tiny) ** (p_ - 1) * 2 * x[:, 0] / self.a[0] ** 2,
                outer * np.maximum(v, tiny) ** (p_ - 1) * 2 * x[:, 1] / self.a[1] ** 2,
                s_ * np.maximum(w, tiny) ** (s_ - 1) * 2 * x[:, 2] / self.a[2] ** 2,
            ]
        )
        return local_grad @ self.rotation.T

    def radial_distance(self, p: np.ndarray) -> np.ndarray:
        """``d(p) = |p|(1 - F^(-e1/2))`` in the object's own frame: exact for a sphere, a margin in metres."""
        x = self.local(p)
        return np.linalg.norm(x, axis=1) * (1 - self.inside_outside(p) ** (-self.e1 / 2))

    def revolution_axis(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The axis (direction, a point on it) about which any turn leaves the surface unchanged: its own z when
        its cross-sections are circles (``a1 = a2``, ``e2 = 1``); None otherwise."""
        if self.a[0] != self.a[1] or self.e2 != 1.0:
            return None
        return self.rotation[:, 2].copy(), self.position.copy()

    def bounds(self) -> np.ndarray:
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * self.a
        world = corners @ self.rotation.T + self.position
        return np.stack([world.min(axis=0), world.max(axis=0)])
