"""Contact mechanics of a grasp: friction cones (App. 10.3), primitive wrenches (eq. 5), the grasp matrix G,
the hand Jacobian J (eq. 7) and the task-oriented quality Q (eq. 12-13)."""

from __future__ import annotations

import numpy as np
import scipy.linalg

from grasptask.task.frames import skew


def tangent_basis(normals: np.ndarray, reference: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Two unit tangents per unit normal ``(b, 3)``, a right-handed ``(t1, t2, n)`` frame.

    ``t1`` is ``reference`` (one vector per normal) projected onto the tangent plane; without one, a fixed
    helper axis is used, which makes the frame, and so a linearised cone, depend on the world's axes.
    """
    normals = np.atleast_2d(normals)
    if reference is None:
        reference = np.where(np.abs(normals[:, [0]]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = np.atleast_2d(reference) - (np.atleast_2d(reference) * normals).sum(axis=1, keepdims=True) * normals
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    return t1, np.cross(normals, t1)


def friction_cone_edges(
    inward_normals: np.ndarray, mu: float, m: int, reference: np.ndarray | None = None
) -> np.ndarray:
    """``(b, m, 3)`` unit edges ``l_i`` of the linearised cone about each inward normal (eq. 24).

    As in eq. 24, where the cone is attached to the finger's frame ``R_h R_q^j``, ``reference`` gives each
    cone's first tangent direction (e.g. the distal phalanx's axis), so the cones move with the grasp.
    """
    n = np.atleast_2d(inward_normals)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    t1, t2 = tangent_basis(n, reference)
    angles = 2 * np.pi * np.arange(1, m + 1) / m
    cos, sin = np.cos(angles)[None, :, None], np.sin(angles)[None, :, None]
    edges = n[:, None, :] + mu * (cos * t1[:, None, :] + sin * t2[:, None, :])
    return edges / np.linalg.norm(edges, axis=2, keepdims=True)


def primitive_wrenches(
    points: np.ndarray, edges: np.ndarray, reference: np.ndarray | None = None, torque_scale: float = 1.0
) -> np.ndarray:
    """``(b, m, 6)`` wrenches ``(l, (p - c) x l / L)`` of the cone edges (eq. 5), about ``reference``."""
    arms = np.atleast_2d(points) - (np.zeros(3) if reference is None else reference)
    torques = np.cross(arms[:, None, :], edges) / torque_scale
    return np.concatenate([edges, torques], axis=2)


def grasp_matrix(points: np.ndarray, reference: np.ndarray | None = None) -> np.ndarray:
    """``G`` (6 x 3b): the object wrench ``w = G f`` of contact forces ``f`` stacked per contact."""
    arms = np.atleast_2d(points) - (np.zeros(3) if reference is None else reference)
    return np.hstack([np.vstack([np.eye(3), skew(a)]) for a in arms])


def hand_jacobian(jacobians: list[np.ndarray]) -> np.ndarray:
    """``J = diag(J^1, ..., J^b)`` (3b x q) from each finger's ``3 x q^j`` contact Jacobian."""
    return scipy.linalg.block_diag(*jacobians)


def internal_forces(G: np.ndarray) -> np.ndarray:
    """``A``: an orthonormal basis of the null space of ``G``, the internal forces (eq. 8)."""
    return scipy.linalg.null_space(G)


def task_torques(
    G: np.ndarray, J: np.ndarray, wrench: np.ndarray, particular: np.ndarray | None = None, A: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray] | tuple[None, None]:
    """Joint torques of least norm that apply ``wrench`` through the contacts (eq. 13).

    ``tau = J^T (f_p + A x)`` with ``G f_p = wrench`` and the internal forces ``x`` chosen to minimise ``|tau|``.
    ``A`` (the null space of G) may be passed in when it is already known.
    Returns ``(tau, f)``, or ``(None, None)`` if no contact forces produce the wrench.
    """
    f_p = np.linalg.lstsq(G, wrench, rcond=None)[0] if particular is None else particular
    if np.linalg.norm(G @ f_p - wrench) > 1e-8 * max(1.0, float(np.linalg.norm(wrench))):
        return None, None
    A = internal_forces(G) if A is None else A
    x = -np.linalg.lstsq(J.T @ A, J.T @ f_p, rcond=None)[0] if A.size else np.zeros(0)
    f = f_p + A @ x if A.size else f_p
    return J.T @ f, f


def task_quality(
    G: np.ndarray, J: np.ndarray, axes: np.ndarray, weights: np.ndarray, m_tau: np.ndarray | None = None
) -> tuple[float, np.ndarray | None]:
    """``Q = sum_i gamma_i tau_i^T M_tau tau_i`` over the task axes ``u_i`` (rows of ``axes``) (eq. 12).

    ``M_tau`` is the identity by default; with another SPD matrix the least-norm problem is solved in its
    metric. Returns ``(Q, torques (k, q))``; Q is infinite when some axis cannot be produced at all.
    """
    q = J.shape[1]
    chol = np.eye(q) if m_tau is None else np.linalg.cholesky(m_tau).T
    weighted_J = J @ chol.T  # |chol tau|^2 = tau^T M tau, and chol tau = (J chol^T)^T f
    torques, total = [], 0.0
    A = internal_forces(G)
    for weight, axis in zip(weights, axes, strict=True):
        tau_w, _ = task_torques(G, weighted_J, axis, A=A)
        if tau_w is None:
            return float("inf"), None
        total += weight * float(tau_w @ tau_w)
        torques.append(np.linalg.solve(chol, tau_w))
    return total, np.array(torques)
