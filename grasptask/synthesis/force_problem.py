"""The force problem of a fixed grasp (SPEC section 12): with the contacts, cone edges and Jacobians held, eqs.
6-13's forces and Q as one small convex QP per task axis, kept feasible by penalised slacks.

For each unit task axis u_i, with weight gamma_i and length L_i:

    min  gamma_i (f^T W f + rho |s|^2)  +  rho (|r+-|^2 + |t+-|^2)  +  e_l |lam|^2 + e_a |a|^2
    s.t. G f - s = u_i                                        eq. 8 (W = blockdiag J^j J^j^T, so f^T W f = |J^T f|^2)
         sum_e lam+-_e w_e - r+- = +-L_i u_i,  lam >= 0        eq. 6, 10: cone-edge forces apply the real wrench
         T (J^T l) lam+- - t+- = A a+-,  0 <= a <= cap - margin  eq. 1, 10: the hand's strength, the shipped margin
         each contact presses with the margin's least normal force

Q is sum_i gamma_i |J^T f_i|^2 (eq. 12); ``value`` adds the slack penalties. The task forces' slack is weighed
by the axis's own weight, so that the six axes' closed form shares one matrix
(:func:`~grasptask.synthesis.batch_geometry.closed_form_q`).
Where the task forces can balance every axis (s = 0) Q is the Section 6 NLP's at the same geometry; where a
grasp cannot close, the slacks keep the problem feasible and the value finite, falling as the contacts move
toward closure. The task forces and
eq. 10's cone forces share no variable, so the two parts of each QP are independent; they are one QP so that the
polish gets every force of the NLP from one solve.

:func:`~grasptask.synthesis.batch_geometry.closed_form_q` is the eq. 8 part in closed form, which the batched
search (:mod:`grasptask.synthesis.batch_search`) minimises; :meth:`ForceSolution.gradient` is its envelope
gradient, read off the QP's solution and multipliers.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import casadi
import numpy as np

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand.hand_model import Capability
from grasptask.synthesis.algebra import cross_matrix
from grasptask.synthesis.solver_config import Regularisation, SearchBounds
from grasptask.task.task_model import TaskModel

#: CasADi's conic plugin for the QPs, chosen by measurement (docs/design/synthesis.md)
QP_SOLVER = "daqp"
#: the least weight of eq. 10's small terms on the edge forces and activations, relative to its residuals'
STRENGTH_FLOOR = 1e-9


@dataclass(frozen=True)
class GraspGeometry:
    """What the force problem holds fixed, in the object frame: ``contacts`` (b, 3); ``edges`` (b, m, 3), the
    friction cones' unit edges; ``jacobians``, per finger (n_j, 3), row k the Jacobian's column a_k x (p - P_k)."""

    contacts: np.ndarray
    edges: np.ndarray
    jacobians: tuple[np.ndarray, ...]
    #: per contact, its torsional friction (m; 0: a point contact), its inward normal, and its finger's joint
    #: torques of a unit twist about that normal (a turning joint's axis . n; a sliding joint's 0); None: every
    #: contact a point contact
    twists: np.ndarray | None = None
    normals: np.ndarray | None = None
    twist_torques: tuple[np.ndarray, ...] | None = None

    @property
    def b(self) -> int:
        return len(self.contacts)

    @property
    def soft(self) -> np.ndarray:
        """The soft contacts (flat pads), whose two twists follow the cone edges' columns."""
        return np.zeros(0, dtype=int) if self.twists is None else np.flatnonzero(self.twists > 0)

    @cached_property
    def _twist_columns(self) -> tuple[np.ndarray, np.ndarray]:
        """The soft contacts' twists ``(n, p x n +- mu_t n)`` (6, 2s) and their joint torques (joints, 2s)."""
        soft, sizes = self.soft, [len(J) for J in self.jacobians]
        wrenches, torques = np.zeros((6, 2 * len(soft))), np.zeros((sum(sizes), 2 * len(soft)))
        starts = np.concatenate([[0], np.cumsum(sizes)])
        for k, j in enumerate(soft):
            assert self.normals is not None and self.twist_torques is not None and self.twists is not None
            n, c = self.normals[j], self.twists[j]
            for i, sign in enumerate((1.0, -1.0)):
                wrenches[:, 2 * k + i] = np.concatenate([n, np.cross(self.contacts[j], n) + sign * c * n])
                torques[starts[j] : starts[j + 1], 2 * k + i] = self.jacobians[j] @ n + sign * c * self.twist_torques[j]
        return wrenches, torques

    def twist_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Eq. 8's twist columns: the object wrench of a unit twist about each soft contact's normal, ``(0, n)``
        (6, s); the cross terms ``J^T (turn^T n)`` with the contact forces (3b, s) and the twists' own
        ``|turn^T n|^2`` (s, s) in ``|tau|^2``."""
        soft = self.soft
        G = np.zeros((6, len(soft)))
        cross, own = np.zeros((3 * self.b, len(soft))), np.zeros((len(soft), len(soft)))
        for k, j in enumerate(soft):
            assert self.normals is not None and self.twist_torques is not None
            G[3:, k] = self.normals[j]
            cross[3 * j : 3 * j + 3, k] = self.jacobians[j].T @ self.twist_torques[j]
            own[k, k] = float(self.twist_torques[j] @ self.twist_torques[j])
        return G, cross, own

    def grasp_matrix(self) -> np.ndarray:
        """G (6 x 3b): a contact force's total force and its torque about the object frame's origin."""
        blocks = [np.vstack([np.eye(3), cross_matrix(p)]) for p in self.contacts]
        return np.hstack(blocks)

    def torque_weights(self) -> np.ndarray:
        """W = blockdiag(J^j J^j^T), so that f^T W f = |J^T f|^2 (eq. 13 with M_tau = I)."""
        n = 3 * self.b
        W = np.zeros((n, n))
        for j, J in enumerate(self.jacobians):
            W[3 * j : 3 * j + 3, 3 * j : 3 * j + 3] = J.T @ J
        return W

    def edge_wrenches(self) -> np.ndarray:
        """Primitive wrenches (6, b m + 2 s): (l, p x l) per contact and edge (eq. 5), then the soft contacts'
        twists."""
        pairs = zip(self.contacts, self.edges, strict=True)
        columns = [np.concatenate([edge, np.cross(p, edge)]) for p, edges in pairs for edge in edges]
        return np.hstack([np.array(columns).T, self._twist_columns[0]])

    def edge_joint_torques(self) -> np.ndarray:
        """(joints, b m + 2 s): the joint torques J^T l of a unit force along each edge (eq. 7), then of the soft
        contacts' twists."""
        m = self.edges.shape[1]
        sizes = [len(J) for J in self.jacobians]
        out = np.zeros((sum(sizes), self.b * m))
        row = 0
        for j, J in enumerate(self.jacobians):
            out[row : row + len(J), j * m : (j + 1) * m] = J @ self.edges[j].T
            row += len(J)
        return np.hstack([out, self._twist_columns[1]])


@dataclass(frozen=True)
class ForceSolution:
    """The force problem's solution: Q (eq. 12 alone), ``value`` (Q plus the slack penalties), per axis the task
    forces ``forces`` (6, b, 3) and slacks, eq. 10's cone-edge forces ``edge_forces`` (6, 2, b, m), activations
    ``activations`` (6, 2, actuators) and residuals (wrench rows, then torque rows, per sign);
    ``multipliers`` (6, 6) of G f - s = u_i, for the envelope gradient."""

    Q: float
    value: float
    forces: np.ndarray
    slacks: np.ndarray
    edge_forces: np.ndarray
    activations: np.ndarray
    wrench_residuals: np.ndarray
    multipliers: np.ndarray
    weights: np.ndarray
    #: the soft contacts' task twists (6, s) and eq. 10's twist forces (6, 2, s, 2); empty for point contacts
    twists: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    twist_forces: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 0, 2)))

    @property
    def closes(self) -> bool:
        """Every axis balanced by the task forces, and every real task wrench applied within the hand's
        strength, to 1e-5 (N, N m)."""
        return max(float(np.abs(self.slacks).max()), float(np.abs(self.wrench_residuals).max())) <= 1e-5

    def gradient(self, geometry: GraspGeometry) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        """dQ-part/d(contacts) (b, 3) and dQ-part/d(Jacobian rows), per finger (n_j, 3): the envelope theorem's
        gradient of eq. 8's part of ``value``, read off the solution (forces, multipliers y of G f - s = u) with
        them held fixed: d/dJ_k gamma |J^T f|^2 = 2 gamma (J_k . f) f, and d/dp (y_tau . p x f) = f x y_tau."""
        d_contacts = np.zeros_like(geometry.contacts)
        d_jacobians = [np.zeros_like(J) for J in geometry.jacobians]
        for i, gamma in enumerate(self.weights):
            y_torque = self.multipliers[i, 3:]
            for j, J in enumerate(geometry.jacobians):
                f = self.forces[i, j]
                d_jacobians[j] += 2 * gamma * np.outer(J @ f, f)
                d_contacts[j] += np.cross(f, y_torque)
        return d_contacts, tuple(d_jacobians)


class ForceProblem:
    """The force problem of one hand, task and settings; :meth:`solve` for a grasp's geometry.

    Each axis's QP falls into independent parts, solved apart (an active-set method's cost grows with the cube of
    the variables): the task forces, a linear KKT system whenever eq. 8's force bound is inactive (else a QP), and
    eq. 10 for each sign of the real task wrench, a QP whose sparsity the hand fixes, so one CasADi conic solver
    serves every grasp."""

    def __init__(
        self,
        capability: Capability,
        joints_per_finger: tuple[int, ...],
        task: TaskModel,
        settings: GraspSettings,
        rho: float,
        bounds: SearchBounds = SearchBounds(),
        regularisation: Regularisation = Regularisation(),
        soft: int = 0,
    ):
        self.capability, self.joints = capability, joints_per_finger
        self.task, self.settings, self.rho = task, settings, float(rho)
        self.bounds, self.regularisation = bounds, regularisation
        self.b, self.m = len(joints_per_finger), settings.cone_edges
        self.soft = soft  # the soft contacts (flat pads), each with two twists
        self.n_edges = self.b * self.m + 2 * soft
        self.n_act = len(capability.actuators)
        self.cap = settings.activation_cap(capability.kind) - settings.activation_margin

    @property
    def _strength_size(self) -> tuple[int, int]:
        """Eq. 10's QP for one sign: variables (edge forces, activations, the wrench rows' and the torque rows'
        residuals) and rows."""
        floor = self.b if self.settings.min_normal_force_n > 0 else 0
        n_t = len(self.capability.transmission)
        return self.n_edges + self.n_act + 6 + n_t, 6 + n_t + floor

    @cached_property
    def _strength_solver(self) -> casadi.Function:
        n, rows = self._strength_size
        H, A = casadi.Sparsity.diag(n), casadi.Sparsity.dense(rows, n)
        return casadi.conic("strength", QP_SOLVER, {"h": H, "a": A}, {"print_time": False, "error_on_fail": False})

    @cached_property
    def _task_solver(self) -> casadi.Function:
        n = 3 * self.b + self.soft
        H, A = casadi.Sparsity.dense(n, n), casadi.Sparsity(0, n)
        return casadi.conic("task_forces", QP_SOLVER, {"h": H, "a": A}, {"print_time": False, "error_on_fail": False})

    def _task_forces(self, G: np.ndarray, W: np.ndarray, gamma: float, u: np.ndarray) -> np.ndarray:
        """argmin_f gamma (f^T W f + rho |G f - u|^2) within eq. 8's force bound: the KKT system
        [[W, G^T], [G, -I/rho]] [f; z] = [0; u] (z = rho s), or the QP where the bound binds. A soft contact's
        twist is one more column of G and W (:meth:`GraspGeometry.twist_matrices`)."""
        n = len(W)
        kkt = np.block([[W, G.T], [G, -np.eye(6) / self.rho]])
        f = np.linalg.solve(kkt, np.concatenate([np.zeros(n), u]))[:n]
        f_max = self.bounds.task_force_n
        if f_max is None or np.abs(f).max() <= f_max:
            return f
        H = 2 * gamma * (W + self.rho * G.T @ G)
        solved = self._task_solver(h=H, g=-2 * gamma * self.rho * G.T @ u, lbx=-f_max, ubx=f_max)
        return np.asarray(solved["x"]).ravel()

    @cached_property
    def _strength_bounds(self) -> tuple[casadi.DM, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """What eq. 10's QP keeps from grasp to grasp: its Hessian, its variables' bounds and its rows' (the
        wrench rows' targets are set per wrench). The objective is divided by rho: the residuals' weight 1, the
        small terms' at least STRENGTH_FLOOR, for with the NLP's 1e-7 against a rho of 1e7 the QP's condition
        (1e14) left DAQP's residuals 1e3 off their least."""
        n_edges = self.n_edges
        n, rows = self._strength_size
        n_residuals, n_t = n - n_edges - self.n_act, len(self.capability.transmission)
        weights = np.concatenate(
            [
                np.full(n_edges, max(self.regularisation.edge_force / self.rho, STRENGTH_FLOOR)),
                np.full(self.n_act, max(self.regularisation.activation / self.rho, STRENGTH_FLOOR)),
                np.ones(n_residuals),
            ]
        )
        edge_max = np.inf if self.bounds.edge_force_n is None else self.bounds.edge_force_n
        lbx = np.concatenate([np.zeros(n_edges + self.n_act), np.full(n_residuals, -np.inf)])
        ubx = np.concatenate([np.full(n_edges, edge_max), np.full(self.n_act, self.cap), np.full(n_residuals, np.inf)])
        lower, upper = np.zeros(rows), np.zeros(rows)
        lower[6 + n_t :], upper[6 + n_t :] = self.settings.min_normal_force_n, np.inf  # the least normal force
        return casadi.DM(casadi.Sparsity.diag(n), 2 * weights), lbx, ubx, lower, upper

    def _strength_rows(self, geometry: GraspGeometry) -> np.ndarray:
        """Eq. 10's rows for one sign at ``geometry``: wrench, transmission, least normal force (a twist presses
        with its whole magnitude)."""
        n_edges, cap = self.n_edges, self.capability
        if len(geometry.soft) != self.soft:
            raise ValueError(f"the geometry has {len(geometry.soft)} soft contacts, the force problem {self.soft}")
        n, rows = self._strength_size
        A = np.zeros((rows, n))
        A[:6, :n_edges], A[:6, n_edges + self.n_act : n_edges + self.n_act + 6] = geometry.edge_wrenches(), -np.eye(6)
        n_t = len(cap.transmission)
        A[6 : 6 + n_t, :n_edges] = cap.transmission @ geometry.edge_joint_torques()
        A[6 : 6 + n_t, n_edges : n_edges + self.n_act] = -cap.torque_map
        A[6 : 6 + n_t, n_edges + self.n_act + 6 :] = -np.eye(n_t)  # what the hand's strength falls short by
        if self.settings.min_normal_force_n > 0:
            mu = self.settings.friction_scale * self.settings.friction_coefficient
            for j in range(self.b):
                A[6 + n_t + j, j * self.m : (j + 1) * self.m] = 1.0 / np.sqrt(1.0 + mu**2)
            for k, j in enumerate(geometry.soft):
                A[6 + n_t + j, self.b * self.m + 2 * k : self.b * self.m + 2 * k + 2] = 1.0
        return A

    def _strength(self, A: np.ndarray, target: np.ndarray) -> np.ndarray:
        """Eq. 10 for one real task wrench ``target``: edge forces, activations and the rows' residuals."""
        h, lbx, ubx, lower, upper = self._strength_bounds
        lba, uba = lower.copy(), upper.copy()
        lba[:6] = uba[:6] = target
        solved = self._strength_solver(h=h, a=A, lba=lba, uba=uba, lbx=lbx, ubx=ubx)
        return np.asarray(solved["x"]).ravel()

    def solve(self, geometry: GraspGeometry) -> ForceSolution:
        """The six QPs at ``geometry``; any non-finite input is refused (no NaN reaches the solver)."""
        arrays = [geometry.contacts, geometry.edges, *geometry.jacobians]
        if not all(np.isfinite(a).all() for a in arrays):
            raise ValueError("the force problem's geometry is not finite")
        G, W = self._task_matrices(geometry)
        A = self._strength_rows(geometry)
        weights = np.asarray(self.task.weights, dtype=float)
        n_edges, cone = self.n_edges, self.b * self.m
        forces, twists, slacks, edge, spun, act, residuals = [], [], [], [], [], [], []
        for gamma, u, length in zip(weights, self.task.axes, self.task.lengths, strict=True):
            f = self._task_forces(G, W, float(gamma), u)
            forces.append(f[: 3 * self.b].reshape(self.b, 3))
            twists.append(f[3 * self.b :])
            slacks.append(G @ f - u)
            signs = [self._strength(A, sign * length * u) for sign in (1.0, -1.0)]
            edge.append([x[:cone].reshape(self.b, self.m) for x in signs])
            spun.append([x[cone:n_edges].reshape(self.soft, 2) for x in signs])
            act.append([x[n_edges : n_edges + self.n_act] for x in signs])
            residuals.append([x[n_edges + self.n_act :] for x in signs])
        forces_a, slacks_a, residuals_a = np.array(forces), np.array(slacks), np.array(residuals)
        Q = quality(geometry, forces_a, weights, np.array(twists))
        slack_penalty = float(weights @ (slacks_a**2).sum(axis=1))
        value = Q + self.rho * (slack_penalty + float((residuals_a**2).sum()))
        # the multipliers of G f - s = u: stationarity in s makes them 2 gamma_i rho s
        multipliers = 2 * self.rho * weights[:, None] * slacks_a
        return ForceSolution(
            Q, value, forces_a, slacks_a, np.array(edge), np.array(act), residuals_a, multipliers, weights,
            np.array(twists), np.array(spun),
        )  # fmt: skip

    def _task_matrices(self, geometry: GraspGeometry) -> tuple[np.ndarray, np.ndarray]:
        """Eq. 8's G and W, a soft contact's twist a column more; the twists' own weight floored at the
        regularisation's task_force, for a sliding jaw's twist costs no torque and W would be singular."""
        G, W = geometry.grasp_matrix(), geometry.torque_weights()
        if not self.soft:
            return G, W
        twist_G, cross, own = geometry.twist_matrices()
        floor = max(self.regularisation.task_force, 1e-9) * np.eye(self.soft)
        return np.hstack([G, twist_G]), np.block([[W, cross], [cross.T, own + floor]])


def quality(
    geometry: GraspGeometry, forces: np.ndarray, weights: np.ndarray, twists: np.ndarray | None = None
) -> float:
    """Eq. 12: sum_i gamma_i sum_j |J^j^T f_i^j|^2 for task forces ``forces`` (axes, b, 3), a soft contact's
    task twist ``twists`` (axes, s) adding its joint torques."""
    total, soft = 0.0, list(geometry.soft)
    for i, (gamma, per_axis) in enumerate(zip(weights, forces, strict=True)):
        torques = [J @ f for J, f in zip(geometry.jacobians, per_axis, strict=True)]
        for k, j in enumerate(soft):
            assert twists is not None and geometry.twist_torques is not None
            torques[j] = torques[j] + twists[i, k] * geometry.twist_torques[j]
        total += float(gamma) * sum(float(t @ t) for t in torques)
    return total
