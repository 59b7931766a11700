"""The physics check's controller: each fingertip pad held by a Cartesian spring,
``F_j = s P_j + K (r_j - x_j) - D v_j``, plus a weak pull towards the synthesized posture for the joints the pads
leave free. While the hand closes, the rest points ``r_j`` lie a squeeze depth inside the object along its
inward normals at the synthesized contacts, and ``P = 0``. Once it has settled, :meth:`FingertipController.hold`
makes the settled pads the rest points and the settled spring forces the preload ``P``: forces that hold the
object in equilibrium, which the protocol scales by ``s`` with each test's load, as a hand raises its grip. The
joint torques this asks for, ``sum_j J_j^T F_j + K_q (q* - q)``, are projected onto what the hand's tendons or
motors can produce with activations in [0, 1].

The projection is ``min |A a - tau|^2, 0 <= a <= 1``, solved by accelerated projected gradient warm-started
from the last control step: small matrix products only, deterministic, fast enough for the control rate."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Gains:
    """Fingertip stiffness (N/m) and damping (N s/m); posture stiffness (N m/rad) and damping (N m s/rad)."""

    tip_stiffness: float
    tip_damping: float
    posture_stiffness: float
    posture_damping: float


class FingertipController:
    """``activations(q, qdot, tips, jacobians)``: actuator controls for joint angles and velocities, the pads'
    current positions ``(b, 3)`` and their Jacobians ``(b, 3, joints)``."""

    def __init__(
        self,
        actuation: np.ndarray,
        posture: np.ndarray,
        contacts: np.ndarray,
        normals: np.ndarray,
        squeeze_m: float,
        gains: Gains,
        iterations: int = 12,
    ):
        self.actuation = actuation
        self.posture = posture
        self.rest = contacts - squeeze_m * normals
        self.preload = np.zeros_like(contacts)
        self.scale = 1.0
        self.gains = gains
        self.iterations = iterations
        self.hessian = actuation.T @ actuation
        self.step = 1.0 / max(float(np.linalg.eigvalsh(self.hessian).max()), 1e-12)
        self.current = np.zeros(actuation.shape[1])

    def torques(self, q: np.ndarray, qdot: np.ndarray, tips: np.ndarray, jacobians: np.ndarray) -> np.ndarray:
        g = self.gains
        velocities = jacobians @ qdot
        forces = self.scale * self.preload + g.tip_stiffness * (self.rest - tips) - g.tip_damping * velocities
        return (
            np.einsum("bij,bi->j", jacobians, forces)
            + g.posture_stiffness * (self.posture - q)
            - g.posture_damping * qdot
        )

    def hold(self, tips: np.ndarray) -> float:
        """Hold the pads where they are with the forces the springs give there; returns the mean preload (N)."""
        self.preload = self.preload + self.gains.tip_stiffness * (self.rest - tips)
        self.rest = tips.copy()
        return float(np.linalg.norm(self.preload, axis=1).mean())

    def activations(self, q: np.ndarray, qdot: np.ndarray, tips: np.ndarray, jacobians: np.ndarray) -> np.ndarray:
        wanted = self.torques(q, qdot, tips, jacobians)
        self.current = box_least_squares(
            self.hessian, self.actuation.T @ wanted, self.step, self.current, self.iterations
        )
        return self.current


def box_least_squares(
    hessian: np.ndarray, linear: np.ndarray, step: float, start: np.ndarray, iterations: int
) -> np.ndarray:
    """``argmin 1/2 a^T H a - b^T a`` over ``0 <= a <= 1`` by FISTA from ``start`` (``step`` <= 1 / |H|)."""
    a = previous = np.minimum(np.maximum(start, 0.0), 1.0)
    momentum = 1.0
    for _ in range(iterations):  # np.minimum / np.maximum: np.clip's dispatch is most of a small step's cost
        ahead = np.minimum(np.maximum(a - step * (hessian @ a - linear), 0.0), 1.0)
        following = 0.5 * (1.0 + np.sqrt(1.0 + 4.0 * momentum**2))
        previous, a = ahead, ahead + ((momentum - 1.0) / following) * (ahead - previous)
        momentum = following
    return previous
