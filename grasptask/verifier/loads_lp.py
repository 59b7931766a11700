"""The verifier's load LP: whether, and with how much effort, a hand applies a set of wrenches to the object
with contact forces in the linearised friction cones and joint torques its tendons or motors carry (eq. 1, 10).

Per wrench, the variables are the cone-edge magnitudes ``lam >= 0`` and the activations ``a >= 0``; one block
of rows asks ``sum lam l = w`` (the wrench) and ``T J^T L lam = A a`` (the torques carried); a soft contact's
two twists (:mod:`grasptask.verifier.soft_contacts`) are two more columns ``lam``. The effort LP finds
the least peak activation over all wrenches; the strength-margin LP the largest scale of the wrenches held at
full strength (:mod:`grasptask.verifier.margins`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.optimize import linprog

from grasptask.hand.hand_model import Hand
from grasptask.verifier.mechanics import primitive_wrenches
from grasptask.verifier.soft_contacts import Twists


@dataclass(frozen=True)
class LoadBlock:
    """One wrench's rows: ``[wrench of the cone edges, 0; T J^T L, -A]`` over ``(lam, a)``, the joint torques of
    each unit edge force (``J^T L``), the edge magnitudes' count and the actuators' count."""

    matrix: np.ndarray
    edge_torques: np.ndarray
    forces: int
    actuators: int
    #: the soft contacts' twists, whose columns follow the cone edges' (None: point contacts only)
    twists: Twists | None = None

    @property
    def width(self) -> int:
        return self.forces + self.actuators


def load_block(
    edges: np.ndarray, points: np.ndarray, jacobians: list[np.ndarray], hand: Hand, twists: Twists | None = None
) -> LoadBlock:
    b, m, _ = edges.shape
    capability = hand.capability
    n_act = capability.torque_map.shape[1]
    soft = [] if twists is None else list(twists.soft)
    n_force = b * m + 2 * len(soft)
    edge_torques = np.zeros((sum(j.shape[1] for j in jacobians), n_force))
    starts = np.concatenate([[0], np.cumsum([jac.shape[1] for jac in jacobians])])
    for j, jac in enumerate(jacobians):
        edge_torques[starts[j] : starts[j + 1], j * m : (j + 1) * m] = jac.T @ edges[j].T
    rows_q = capability.transmission.shape[0]
    block = np.zeros((6 + rows_q, n_force + n_act))
    block[:6, : b * m] = primitive_wrenches(points, edges).reshape(b * m, 6).T
    if twists is not None and soft:
        block[:6, b * m : n_force] = twists.wrenches(points).reshape(-1, 6).T
        for row, (j, torques) in enumerate(zip(soft, twists.joint_torques(jacobians), strict=True)):
            edge_torques[starts[j] : starts[j + 1], b * m + 2 * row : b * m + 2 * row + 2] = torques
    block[6:, :n_force] = capability.transmission @ edge_torques
    block[6:, n_force:] = -capability.torque_map
    return LoadBlock(block, edge_torques, n_force, n_act, twists if soft else None)


def normal_rows(edges: np.ndarray, normals: np.ndarray, block: LoadBlock) -> np.ndarray:
    """``(b, width)``: each contact's normal force ``sum_e lam_e (l_e . n)`` as a row over one block's
    variables (a twist presses with its whole magnitude)."""
    b, m, _ = edges.shape
    rows = np.zeros((b, block.width))
    for j in range(b):
        rows[j, j * m : (j + 1) * m] = edges[j] @ normals[j]
    if block.twists is not None:
        for row, j in enumerate(block.twists.soft):
            rows[j, b * m + 2 * row : b * m + 2 * row + 2] = 1.0
    return rows


def contact_forces(edges: np.ndarray, block: LoadBlock, x: np.ndarray) -> np.ndarray:
    """``(b, 3)``: each contact's force from one block's solution ``x``, its twists' pushes included."""
    b, m, _ = edges.shape
    forces = np.einsum("jm,jmk->jk", x[: b * m].reshape(b, m), edges)
    if block.twists is not None:
        for row, j in enumerate(block.twists.soft):
            forces[j] += x[b * m + 2 * row : b * m + 2 * row + 2].sum() * block.twists.normals[j]
    return forces


def solve_loads(
    block: LoadBlock,
    targets: list[np.ndarray],
    scale_wrenches: bool,
    activation_max: float | None,
    minimum_normal: tuple[np.ndarray, float] | None = None,
):
    """One LP over all ``targets`` (each wrench its own forces and activations) with one extra variable ``t``:

    - ``scale_wrenches=False``: every wrench applied exactly, activations ``a <= t``; minimise ``t`` (the effort);
    - ``scale_wrenches=True``: every wrench applied as ``t w``, activations ``a <= activation_max``; maximise
      ``t`` (the strength margin).

    ``minimum_normal`` (rows, force) asks each contact for at least that normal force under every wrench.
    Returns SciPy's result; its ``x[-1]`` is ``t``."""
    k, width, rows = len(targets), block.width, block.matrix.shape[0]
    wrenches = np.zeros(k * rows)
    for i, w in enumerate(targets):
        wrenches[i * rows : i * rows + 6] = w
    if scale_wrenches:  # t w moves to the left-hand side as a column
        column, b_eq = -wrenches, np.zeros(k * rows)
    else:
        column, b_eq = np.zeros(k * rows), wrenches
    a_eq = _repeated(block.matrix, k, column)
    pick = np.hstack([np.zeros((block.actuators, block.forces)), np.eye(block.actuators)])
    if scale_wrenches:
        a_ub = _repeated(pick, k, np.zeros(k * block.actuators))
        b_ub = np.full(k * block.actuators, float(activation_max if activation_max is not None else 1.0))
    else:
        a_ub = _repeated(pick, k, -np.ones(k * block.actuators))
        b_ub = np.zeros(k * block.actuators)
    if minimum_normal is not None:
        normals, force = minimum_normal
        a_ub = sp.vstack([a_ub, _repeated(-normals, k, np.zeros(k * len(normals)))])
        b_ub = np.concatenate([b_ub, np.full(k * len(normals), -force)])
    cost = np.zeros(k * width + 1)
    cost[-1] = -1.0 if scale_wrenches else 1.0
    bounds = [(0, None)] * (k * width) + [(0, MARGIN_CAP if scale_wrenches else None)]
    # presolve costs more than it saves on an LP this small and this well structured
    return linprog(
        cost, A_ub=sp.csr_matrix(a_ub), b_ub=b_ub, A_eq=a_eq, b_eq=b_eq, bounds=bounds, method="highs",
        options={"presolve": False},
    )  # fmt: skip


def _repeated(matrix: np.ndarray, k: int, last: np.ndarray) -> sp.csr_matrix:
    """``k`` copies of ``matrix`` down the diagonal and the column ``last`` beside them, as CSR, built from the
    nonzeros directly (SciPy's kron and hstack took a fifth of the verifier's time)."""
    rows, cols = np.nonzero(matrix)
    height, width = matrix.shape
    copy = np.arange(k)[:, None]
    r = (rows[None] + height * copy).ravel()
    c = (cols[None] + width * copy).ravel()
    v = np.tile(matrix[rows, cols], k)
    tail = np.flatnonzero(last)
    r, c = np.concatenate([r, tail]), np.concatenate([c, np.full(len(tail), k * width)])
    v = np.concatenate([v, last[tail]])
    return sp.csr_matrix((v, (r, c)), shape=(k * height, k * width + 1))


#: the largest strength margin reported: wrenches of zero size are held at any scale
MARGIN_CAP = 1e3
