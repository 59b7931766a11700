"""Finger force capabilities (paper eq. 1 and 10): joint torques ``tau`` with ``T tau = A a`` and activations
``0 <= a <= 1``, for tendons (``A = M P``) and motors alike (:class:`grasptask.hand.hand_model.Capability`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from grasptask.hand.hand_model import Capability


@dataclass(frozen=True)
class Activation:
    """Whether a torque is producible, and the least-effort activations that produce it."""

    feasible: bool
    activations: np.ndarray | None
    effort: float  # the largest activation needed (inf when no activation pattern produces the torque)


def activation_for(capability: Capability, torque: np.ndarray, cap: float = 1.0) -> Activation:
    """Activations ``a`` with ``A a = T torque``, minimising the largest activation ``max(a)``.

    The LP is ``min t`` subject to ``A a = T torque``, ``0 <= a <= t``; the torque is producible when
    ``t <= cap`` (1: every actuator at most fully active).
    """
    mp = capability.torque_map
    m = mp.shape[1]
    cost = np.zeros(m + 1)
    cost[-1] = 1.0
    a_eq = np.hstack([mp, np.zeros((mp.shape[0], 1))])
    a_ub = np.hstack([np.eye(m), -np.ones((m, 1))])
    result = linprog(
        cost,
        A_ub=a_ub,
        b_ub=np.zeros(m),
        A_eq=a_eq,
        b_eq=capability.transmission @ np.asarray(torque, dtype=float),
        bounds=[(0, None)] * (m + 1),
        method="highs",
    )
    if result.status != 0:
        return Activation(False, None, float("inf"))
    effort = float(result.x[-1])
    return Activation(effort <= cap + 1e-9, result.x[:m], effort)


def producible(capability: Capability, torque: np.ndarray) -> bool:
    """Whether ``torque`` (one per joint) is producible with every activation in ``[0, 1]``."""
    return activation_for(capability, torque).feasible
