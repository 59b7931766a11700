"""Joint torques to actuator activations, exactly: ``a = argmin |A a - tau|^2`` over ``0 <= a <= 1``, with ``A``
the joint torques of each actuator at full activation.

Motors that each drive their own joints, pushing both ways (a robot hand's), make the problem separable, and it
is solved in closed form (:class:`IndependentMotors`). Tendons that share joints (the human hand's) make it a
small bounded least squares, solved to optimality by quadprog's dual active-set method
(:class:`BoundedLeastSquares`): finite, deterministic, and about ten times faster here than SciPy's BVLS, which
the tests compare it with."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import quadprog

#: a torque the actuators miss by more than this fraction of its size (plus 1e-6 N m) counts as saturated
SATURATION_TOLERANCE = 1e-3
#: a tie-breaker on the activations: the Gram matrix of more tendons than joints is singular, and quadprog
#: needs it positive definite; at 1e-10 it moves the residual by far less than the tolerance above
REGULARISATION = 1e-10


@dataclass(frozen=True)
class Mapped:
    """The activations, and whether they saturated: some actuator at its limit, and the torque asked for out
    of reach (a torque no actuator can push in at all, such as a pure sideways twist of a tendon-driven joint,
    is missed without saturating)."""

    activations: np.ndarray
    saturated: bool


@dataclass(frozen=True)
class IndependentMotors:
    """The exact map for motors in pairs ``[C, -C]`` (each motor's push and pull, as
    :meth:`~grasptask.hand.hand_model.Capability.motors` makes them) whose columns ``C`` are orthogonal, each motor
    driving joints no other drives: per motor, ``m = clip(c . tau / |c|^2, -1, 1)``, its push ``max(m, 0)`` and
    its pull ``max(-m, 0)``."""

    push: np.ndarray  # C (joints x motors)
    norms: np.ndarray  # |c|^2 per motor

    @classmethod
    def of(cls, actuation: np.ndarray) -> IndependentMotors | None:
        """The map for ``actuation`` (joints x actuators), or None when it is not of that form."""
        count = actuation.shape[1] // 2
        if count == 0 or actuation.shape[1] != 2 * count:
            return None
        push, pull = actuation[:, :count], actuation[:, count:]
        gram = push.T @ push
        norms = np.diag(gram).copy()
        if not np.allclose(pull, -push) or np.any(norms <= 0) or not np.allclose(gram, np.diag(norms)):
            return None
        return cls(push, norms)

    def solve(self, torque: np.ndarray) -> np.ndarray:
        motor = np.minimum(np.maximum(self.push.T @ torque / self.norms, -1.0), 1.0)
        return np.concatenate([np.maximum(motor, 0.0), np.maximum(-motor, 0.0)])


@dataclass(frozen=True)
class BoundedLeastSquares:
    """``argmin 1/2 |A a - tau|^2`` over ``0 <= a <= 1`` by quadprog (a dual active-set method: exact at its
    finite end)."""

    actuation: np.ndarray
    gram: np.ndarray
    bounds: np.ndarray  # quadprog's constraint matrix for 0 <= a <= 1
    limits: np.ndarray

    @classmethod
    def of(cls, actuation: np.ndarray) -> BoundedLeastSquares:
        n = actuation.shape[1]
        gram = actuation.T @ actuation + REGULARISATION * np.eye(n)
        return cls(actuation, gram, np.hstack([np.eye(n), -np.eye(n)]), np.concatenate([np.zeros(n), -np.ones(n)]))

    def solve(self, torque: np.ndarray) -> np.ndarray:
        found = quadprog.solve_qp(self.gram, self.actuation.T @ torque, self.bounds, self.limits, 0)[0]
        return np.minimum(np.maximum(found, 0.0), 1.0)


@dataclass(frozen=True)
class ActuatorMap:
    """The exact map from joint torques to activations for one actuation matrix (joints x actuators)."""

    actuation: np.ndarray
    method: IndependentMotors | BoundedLeastSquares

    @classmethod
    def of(cls, actuation: np.ndarray) -> ActuatorMap:
        actuation = np.asarray(actuation, dtype=float)
        return cls(actuation, IndependentMotors.of(actuation) or BoundedLeastSquares.of(actuation))

    def __call__(self, torque: np.ndarray) -> Mapped:
        activations = self.method.solve(torque)
        miss = float(np.linalg.norm(self.actuation @ activations - torque))
        missed = miss > SATURATION_TOLERANCE * float(np.linalg.norm(torque)) + 1e-6
        return Mapped(activations, missed and bool(activations.max(initial=0.0) >= 1.0 - 1e-9))
