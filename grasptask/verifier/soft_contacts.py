"""Soft-finger contacts, as the verifier reads them: a flat pad pressed on a surface resists a twist about the
contact normal up to a torsional friction coefficient ``mu_t`` (m) times its normal force (Salisbury and
Mason's soft finger; MuJoCo's ``condim`` 4). Linearised as two more primitive wrenches per soft contact, a push
along the normal that twists about it either way, ``(n, p x n +- mu_t n)``: with the cone's edges their hull holds
``|f_t| / mu + |m| / mu_t <= f_n``. A point contact has none."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the two twists' signs, in the order their columns follow the cone edges'
SIGNS = (1.0, -1.0)


@dataclass(frozen=True)
class Twists:
    """Per contact: the inward unit normal, its torsional coefficient (m; 0 for a point contact) and the finger's
    turn Jacobian ``(3, n_j)`` (a turning joint's axis, a sliding joint's zero), which maps a twist ``m n`` on
    the pad to the joint torques ``m turn^T n``."""

    normals: np.ndarray
    coefficients: np.ndarray
    turns: list[np.ndarray]

    @property
    def soft(self) -> np.ndarray:
        """The indices of the soft contacts."""
        return np.flatnonzero(self.coefficients > 0)

    def wrenches(
        self, points: np.ndarray, reference: np.ndarray | None = None, torque_scale: float = 1.0
    ) -> np.ndarray:
        """``(s, 2, 6)``: each soft contact's two twists ``(n, ((p - c) x n +- mu_t n) / L)``."""
        arms = np.atleast_2d(points) - (np.zeros(3) if reference is None else reference)
        out = np.zeros((len(self.soft), len(SIGNS), 6))
        for row, j in enumerate(self.soft):
            n = self.normals[j]
            for k, sign in enumerate(SIGNS):
                out[row, k] = np.concatenate(
                    [n, (np.cross(arms[j], n) + sign * self.coefficients[j] * n) / torque_scale]
                )
        return out

    def joint_torques(self, jacobians: list[np.ndarray]) -> list[np.ndarray]:
        """Per soft contact ``(n_j, 2)``: the joint torques of its two unit twists, ``J^T n +- mu_t turn^T n``."""
        out = []
        for j in self.soft:
            n = self.normals[j]
            push, turn = jacobians[j].T @ n, self.turns[j].T @ n
            out.append(np.column_stack([push + sign * self.coefficients[j] * turn for sign in SIGNS]))
        return out

    def torque_rows(self, n_joints: list[int]) -> np.ndarray:
        """``(s, q)``: the joint torques of a unit twist about each soft contact's normal, ``turn^T n`` in its
        finger's columns: the rows a twist adds to the hand Jacobian ``J`` of eq. 13."""
        starts = np.concatenate([[0], np.cumsum(n_joints)])
        rows = np.zeros((len(self.soft), int(starts[-1])))
        for row, j in enumerate(self.soft):
            rows[row, starts[j] : starts[j + 1]] = self.turns[j].T @ self.normals[j]
        return rows

    def grasp_columns(self) -> np.ndarray:
        """``(6, s)``: the object wrench of a unit twist about each soft contact's normal, ``(0, n)``: the columns a
        twist adds to the grasp matrix ``G``."""
        return np.vstack([np.zeros((3, len(self.soft))), self.normals[self.soft].T])

    def scaled(self, factor: float) -> Twists:
        """The same contacts with every coefficient times ``factor`` (the margin's, as its friction)."""
        return Twists(self.normals, factor * self.coefficients, self.turns)
