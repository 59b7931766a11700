"""The physics check's controller: each fingertip pad held by a Cartesian spring,
``F_j = s P_j + K (r_j - x_j) - D v_j``, plus a weak pull towards the synthesized posture for the joints the pads
leave free. While the hand closes, the rest points ``r_j`` lie a squeeze depth inside the object along its
inward normals at the synthesized contacts, and ``P = 0``. Once it has settled, :meth:`FingertipController.hold`
makes the settled pads the rest points and the settled spring forces the preload ``P``: forces that hold the
object in equilibrium, which the protocol scales by ``s`` with each test's load, as a hand raises its grip. The
joint torques this asks for, ``sum_j J_j^T F_j + K_q (q* - q)``, are projected onto what the hand's tendons or
motors can produce with activations in [0, 1].

The projection is ``min |A a - tau|^2, 0 <= a <= 1``. Motors that each drive their own joints, pushing both ways
(a robot hand's), make it separable, and it is solved exactly (:class:`IndependentMotors`); tendons that share
joints (the human hand's) by accelerated projected gradient warm-started from the last control step
(:class:`BoxLeastSquares`): small matrix products only, deterministic, fast enough for the control rate."""

from __future__ import annotations

import math
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
        self.projection: IndependentMotors | BoxLeastSquares = IndependentMotors.of(actuation) or BoxLeastSquares.of(
            actuation.T @ actuation, iterations
        )
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
        self.current = self.projection.solve(self.actuation.T @ wanted, self.current)
        return self.current


@dataclass(frozen=True)
class IndependentMotors:
    """The exact projection for motors in pairs ``[C, -C]`` (each motor's push and pull, as
    :meth:`~grasptask.hand.model.Capability.motors` makes them) whose columns ``C`` are orthogonal, each motor
    driving joints no other drives: per motor, ``m = clip(c . tau / |c|^2, -1, 1)``, its push ``max(m, 0)`` and
    its pull ``max(-m, 0)``."""

    norms: np.ndarray  # |c|^2 per motor

    @classmethod
    def of(cls, actuation: np.ndarray) -> IndependentMotors | None:
        """The projection for ``actuation`` (joints x actuators), or None when it is not of that form."""
        count = actuation.shape[1] // 2
        if count == 0 or actuation.shape[1] != 2 * count:
            return None
        push, pull = actuation[:, :count], actuation[:, count:]
        gram = push.T @ push
        norms = np.diag(gram).copy()
        if not np.allclose(pull, -push) or np.any(norms <= 0) or not np.allclose(gram, np.diag(norms)):
            return None
        return cls(norms)

    def solve(self, linear: np.ndarray, start: np.ndarray) -> np.ndarray:
        """``linear`` is ``A^T tau``, whose first half is ``C^T tau``; ``start`` is not needed."""
        motor = np.minimum(np.maximum(linear[: len(self.norms)] / self.norms, -1.0), 1.0)
        return np.concatenate([np.maximum(motor, 0.0), np.maximum(-motor, 0.0)])


@dataclass(frozen=True)
class BoxLeastSquares:
    """``argmin 1/2 a^T H a - b^T a`` over ``0 <= a <= 1`` by a fixed number of FISTA steps from a warm start:
    the gradient step ``(I - H/L) a + b/L`` and the momentum sequence depend on ``H`` alone, so they are made
    once, and a control step is a handful of small in-place array operations."""

    descent: np.ndarray
    step: float
    momenta: tuple[float, ...]

    @classmethod
    def of(cls, hessian: np.ndarray, iterations: int) -> BoxLeastSquares:
        step = 1.0 / max(float(np.linalg.eigvalsh(hessian).max()), 1e-12)
        momenta, t = [], 1.0
        for _ in range(iterations):
            following = 0.5 * (1.0 + math.sqrt(1.0 + 4.0 * t * t))
            momenta.append((t - 1.0) / following)
            t = following
        return cls(np.eye(len(hessian)) - step * hessian, step, tuple(momenta))

    def solve(self, linear: np.ndarray, start: np.ndarray) -> np.ndarray:
        shift = self.step * linear
        a = previous = np.minimum(np.maximum(start, 0.0), 1.0)
        for momentum in self.momenta:  # np.minimum / np.maximum: np.clip's dispatch costs more than a step
            ahead = self.descent @ a
            ahead += shift
            np.maximum(ahead, 0.0, out=ahead)
            np.minimum(ahead, 1.0, out=ahead)
            a = ahead + momentum * (ahead - previous)
            previous = ahead
        return previous
