"""The grasp-synthesis NLP of the paper's Sections 5-6 as a Pyomo ``ConcreteModel`` (SPEC section 7).

One model per (task, hand, object). Variables: the palm pose (R_h, d_h), joint angles theta, the frames of every
link and the fingertip contact points (auxiliary variables tied by equalities, as in the paper's 579-variable
model), the contact normals and cone tangents, the force-closure weights phi, task contact forces f_i and, for
feasibility, contact forces and tendon activations per task wrench. Component names cite the paper's equations:

    eq2_*           finger kinematics: link frames, joint positions, contact points (eq. 2)
    eq3_contact     g(p^j) = 0, contacts on the surface
    eq4_*           force closure: phi >= eps, sum phi = 1, sum phi w = 0
    eq5_wrench      primitive wrenches w_i^j = (l_i^j, p^j x l_i^j): their torque parts as variables
    eq7_*           the finger Jacobians J^j (columns a_k x (p^j - P_k)) and the joint torques J^j^T l_i^j of
                    a unit force along each cone edge, as variables
    eq24_cone_edge  the friction cone edges l_i^j, as variables
    eq8_task_force  G f_i = u_i (the G^R u_i + A x of eq. 8, without a matrix inverse)
    eq10_*          torque feasibility: for each axis and sign, forces in the friction cones apply +-gamma_i u_i
                    with joint torques J^T f = M P a, 0 <= a <= 1 - margin (eq. 1; the margin keeps the
                    verifier's own LP from reading a hair over 1 at an active bound)
    eq12_Q          Q = sum_i gamma_i tau_i^T tau_i with tau_i = J^T f_i (eq. 12-13)
    eq12_objective  Q plus small quadratic terms on phi, eq. 10's forces and activations (``Regularisation``)
    eq14_collision  hand sample points stay out of the object by their radius
    eq16_23_*       palm rotation orthonormal; joint limits as bounds (eq. 20-21); DIP-PIP coupling
    pad_facing      the pad normal within the configured angle of the inward surface normal
    normal_*, tangent_*  the inward unit normal -grad g/|grad g| at each contact, and the first cone tangent:
                    the distal phalanx's axis projected on the tangent plane (the cone is attached to the finger
                    frame, as in App. 10.3, eq. 24)

Every quantity the task constraints share (cone edges, wrenches, Jacobians, edge torques) is a variable defined
once by an equality, so that eq. 4, 10 and 12 are bilinear in them: written out inline, eq. 10's 12 task wrenches
each repeated the whole finger kinematics, and the Lagrangian's Hessian (and IPOPT's KKT factor) was several
times denser. Variables that are unit vectors or rotation entries carry no bounds: their equalities already
bound them, and a bound at +-1 that a rotation entry touches made IPOPT's barrier cut most steps short.

Eq. 9 is checked on each solution by the verifier, not imposed. The surface function is written here in Pyomo
independently of ``grasptask.objects`` (which the verifier uses): for a superquadric the contact constraint uses
``F^(e1/2) - 1``, which is well scaled, and collisions use the superquadric inflated by the sample's radius,
because the radial distance beside a long thin cylinder overstates the true clearance several-fold.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import pyomo.environ as pyo
from scipy.optimize import lsq_linear, nnls

from grasptask.grasp.settings import GraspSettings
from grasptask.hand.model import Hand
from grasptask.objects.gp import GPImplicitSurface
from grasptask.objects.superquadric import Superquadric
from grasptask.synthesis.compiled import CompiledExpressions
from grasptask.synthesis.config import Regularisation, SearchBounds
from grasptask.task.model import TaskModel

XYZ = (0, 1, 2)


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b, strict=True))


def _matvec(rows, v):
    return [_dot(row, v) for row in rows]


def _power(x, exponent: float):
    """``x ** exponent``, written out for the exponents 0 and 1: the derivative of ``x ** 0`` is
    ``0 * x ** -1``, NaN at ``x = 0``, and a cylinder (e2 = 1) puts that on every contact on its axis plane."""
    if exponent == 0:
        return 1.0
    if exponent == 1:
        return x
    return x**exponent


def _axis_rotation(axis: np.ndarray, c, s):
    """Rodrigues' rotation about a constant unit axis, with c = cos theta and s = sin theta as expressions."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    kk = k @ k
    return [[(1.0 if i == j else 0.0) + s * k[i, j] + (1 - c) * kk[i, j] for j in XYZ] for i in XYZ]


# ---- the object's surface in Pyomo, independent of grasptask.objects' numpy code ----------------------------


class _SuperquadricSurface:
    def __init__(self, sq: Superquadric):
        self.a, self.e1, self.e2 = sq.a, sq.e1, sq.e2
        self.rotation, self.position = sq.rotation, sq.position

    def _local(self, p):
        d = [p[i] - self.position[i] for i in XYZ]
        return [sum(self.rotation[i, j] * d[i] for i in XYZ) for j in XYZ]  # R^T (p - t)

    def _inside_outside(self, x, a):
        u = (x[0] / a[0]) ** 2
        v = (x[1] / a[1]) ** 2
        w = (x[2] / a[2]) ** 2
        p_, r_, s_ = 1 / self.e2, self.e2 / self.e1, 1 / self.e1
        return _power(_power(u, p_) + _power(v, p_), r_) + _power(w, s_)

    def contact(self, p):
        """``F^(e1/2) - 1``: zero on the surface, well scaled near it."""
        return self._inside_outside(self._local(p), self.a) ** (self.e1 / 2) - 1

    def clearance(self, p, radius):
        """``>= 0`` when a ball of ``radius`` at ``p`` stays out: outside the superquadric inflated by it."""
        return self._inside_outside(self._local(p), self.a + radius) ** (self.e1 / 2) - 1

    def gradient(self, p):
        """Gradient of ``F^(e1/2)`` in the object frame."""
        x = self._local(p)
        a = self.a
        u, v, w = ((x[i] / a[i]) ** 2 for i in XYZ)
        p_, r_, s_ = 1 / self.e2, self.e2 / self.e1, 1 / self.e1
        base = _power(u, p_) + _power(v, p_)
        big_f = _power(base, r_) + _power(w, s_)
        outer = (self.e1 / 2) * _power(big_f, self.e1 / 2 - 1)
        radial = outer * r_ * _power(base, r_ - 1) * p_
        local = [
            radial * _power(u, p_ - 1) * 2 * x[0] / a[0] ** 2,
            radial * _power(v, p_ - 1) * 2 * x[1] / a[1] ** 2,
            outer * s_ * _power(w, s_ - 1) * 2 * x[2] / a[2] ** 2,
        ]
        return [sum(self.rotation[i, j] * local[j] for j in XYZ) for i in XYZ]


class _GPSurface:
    """The GP's posterior mean ``sum_k alpha_k |p - x_k|^3 + c0 + c.p``: a signed distance in metres."""

    def __init__(self, gp: GPImplicitSurface):
        self.support, self.alpha, self.coef = gp.support, gp.alpha, gp.mean_coefficients

    def _squared(self, p, x):
        return sum((p[i] - x[i]) ** 2 for i in XYZ)

    def contact(self, p):
        terms = sum(a * self._squared(p, x) ** 1.5 for a, x in zip(self.alpha, self.support, strict=True))
        return terms + self.coef[0] + sum(self.coef[1 + i] * p[i] for i in XYZ)

    def clearance(self, p, radius):
        return self.contact(p) - radius

    def gradient(self, p):
        weights = [3 * a * self._squared(p, x) ** 0.5 for a, x in zip(self.alpha, self.support, strict=True)]
        return [
            sum(w * (p[i] - x[i]) for w, x in zip(weights, self.support, strict=True)) + self.coef[1 + i] for i in XYZ
        ]


def surface_for(obj):
    if isinstance(obj, Superquadric):
        return _SuperquadricSurface(obj)
    if isinstance(obj, GPImplicitSurface):
        return _GPSurface(obj)
    raise TypeError(f"no NLP surface for {type(obj).__name__}")


# ---- the model ---------------------------------------------------------------------------------------------


@dataclass
class GraspNLP:
    """The Pyomo model and what is needed to start it from a palm pose and read a solution back."""

    model: pyo.ConcreteModel
    hand: Hand
    definitions: list = field(default_factory=list)  # (variable, expression) pairs, in dependency order
    #: eq. 10's data for the warm start: per block (axis, sign) the target wrench; the cone edges and primitive
    #: wrenches as expressions; and tau^j = J^j^T f as a function of a finger and its force
    targets: dict = field(default_factory=dict)
    edges: list = field(default_factory=list)
    wrenches: list = field(default_factory=list)
    joint_torques: object = None

    def size(self) -> dict[str, int]:
        n_vars = sum(1 for v in self.model.component_data_objects(pyo.Var, active=True) if not v.fixed)
        n_cons = sum(1 for _ in self.model.component_data_objects(pyo.Constraint, active=True))
        return {"variables": n_vars, "constraints": n_cons}

    def compile(self) -> CompiledExpressions:
        """The defined variables and eq. 14's margins as one CasADi function of the palm pose and joints, built
        on first use (:meth:`initialise`, :meth:`min_clearance`) or when called."""
        return self._compiled

    @cached_property
    def _compiled(self) -> CompiledExpressions:
        m = self.model
        inputs = [m.R_h[i, j] for i in XYZ for j in XYZ] + [m.d_h[i] for i in XYZ] + list(m.theta.values())
        margins = [c.body - c.lower for c in m.eq14_collision.values()]
        return CompiledExpressions(inputs, self.definitions, margins)

    def initialise(self, palm_rotation: np.ndarray, palm_position: np.ndarray, joint_angles: np.ndarray) -> None:
        """Set the palm pose and joints, then every defined variable from its defining expression."""
        m = self.model
        for i in XYZ:
            m.d_h[i].set_value(float(palm_position[i]))
            for j in XYZ:
                m.R_h[i, j].set_value(float(palm_rotation[i, j]))
        for k, value in enumerate(joint_angles):
            m.theta[k].set_value(float(np.clip(value, m.theta[k].lb, m.theta[k].ub)))
        self._compiled.assign_defined(self._compiled.input_values())
        for var in m.phi.values():
            var.set_value(1.0 / len(m.phi))
        for var in m.force.values():
            var.set_value(0.0)
        for var in m.lam.values():
            var.set_value(0.1)
        for var in m.act.values():
            var.set_value(0.2)

    @contextmanager
    def approach(self):
        """The model without torque feasibility (eq. 1, 10): the grasp's geometry, force closure and Q only.

        Inside the ``with`` block eq. 10 is deactivated, its forces and activations are fixed and left out of the
        objective, so a model written there is the smaller first phase of a two-phase solve."""
        m = self.model
        switched = (m.eq10_wrench, m.eq10_torque, m.eq12_objective)
        for component in switched:
            component.deactivate()
        m.approach_objective.activate()
        m.lam.fix()
        m.act.fix()
        try:
            yield self
        finally:
            for component in switched:
                component.activate()
            m.approach_objective.deactivate()
            m.lam.unfix()
            m.act.unfix()

    def warm_start_feasibility(self, activation_cap: float) -> None:
        """Eq. 10's forces and activations for the current grasp by bounded least squares: per task wrench the
        cone-edge magnitudes ``lam >= 0`` closest to applying it, then per finger the activations in
        ``[0, cap]`` closest to the joint torques those forces need. A starting point for the second phase."""
        m = self.model
        b, m_edges = len(self.edges), len(self.edges[0])
        wrench_matrix = (
            np.array([[[pyo.value(c) for c in self.wrenches[j][e]] for e in range(m_edges)] for j in range(b)])
            .reshape(b * m_edges, 6)
            .T
        )
        edge_values = np.array([[[pyo.value(c) for c in self.edges[j][e]] for e in range(m_edges)] for j in range(b)])
        fingers = list(self.hand.fingers.values())
        for (a, s), target in self.targets.items():
            lam = nnls(wrench_matrix, target, maxiter=50 * b * m_edges)[0].reshape(b, m_edges)
            for j, e in np.ndindex(b, m_edges):
                m.lam[a, s, j, e].set_value(float(lam[j, e]))
            for j, finger in enumerate(fingers):
                tau = np.array([pyo.value(t) for t in self.joint_torques(j, list(lam[j] @ edge_values[j]))])
                act = lsq_linear(finger.torque_map, tau, bounds=(0.0, activation_cap)).x
                for q, value in enumerate(act):
                    m.act[a, s, j, q].set_value(float(value))

    def min_clearance(self, palm_position: np.ndarray | None = None) -> float:
        """The smallest eq. 14 margin (negative: a hand point is inside the object) at the current palm pose and
        joints, or with the palm moved to ``palm_position`` first. Only the palm moves; the defined variables
        (contacts, normals) keep their old values until the next :meth:`initialise`."""
        if palm_position is not None:
            for i in XYZ:
                self.model.d_h[i].set_value(float(palm_position[i]))
        return float(self._compiled.extra(self._compiled.input_values()).min())

    def read(self) -> dict:
        """The current variable values as arrays: palm pose, joints, contacts and normals."""
        m = self.model
        b = len(self.hand.fingers)
        return {
            "palm_rotation": np.array([[pyo.value(m.R_h[i, j]) for j in XYZ] for i in XYZ]),
            "palm_position": np.array([pyo.value(m.d_h[i]) for i in XYZ]),
            "joint_angles": np.array([pyo.value(m.theta[k]) for k in m.theta]),
            "contacts": np.array([[pyo.value(m.p[j, i]) for i in XYZ] for j in range(b)]),
            "normals": -np.array([[pyo.value(m.n[j, i]) for i in XYZ] for j in range(b)]),  # outward
            "Q": pyo.value(m.eq12_Q),
        }


def build_model(
    hand: Hand,
    obj,
    task: TaskModel,
    settings: GraspSettings = GraspSettings(),
    bounds: SearchBounds = SearchBounds(),
    regularisation: Regularisation = Regularisation(),
) -> GraspNLP:
    """The NLP for ``hand``'s grasping fingers on ``obj`` for ``task``, its forces searched within ``bounds``,
    its objective eq. 12 plus the small terms of ``regularisation``."""
    hand = hand.grasping_hand()
    fingers = list(hand.fingers.values())
    b, m_edges = len(fingers), settings.cone_edges
    mu = settings.friction_coefficient
    surface = surface_for(obj)
    axes, lengths, weights = task.axes, task.lengths, task.weights
    n_axes = len(weights)
    definitions = []

    def define(constraints, var, expr):
        """``var == expr`` as a constraint, and ``var`` set from ``expr`` by :meth:`GraspNLP.initialise`."""
        constraints.add(var == expr)
        definitions.append((var, expr))

    m = pyo.ConcreteModel(name="task_oriented_grasp")
    m.R_h = pyo.Var(XYZ, XYZ, doc="palm rotation R_h in the object frame")
    m.d_h = pyo.Var(XYZ, bounds=(-1, 1), doc="palm position d_h in the object frame (m)")
    lower, upper = hand.lower, hand.upper
    m.theta = pyo.Var(range(hand.n_joints), bounds=lambda _, k: (lower[k], upper[k]), doc="joint angles, eq. 20-21")

    # eq. 16-23 in spirit: the palm rotation is orthonormal (columns of unit length, mutually orthogonal)
    m.eq16_23_palm_orthonormal = pyo.ConstraintList()
    for i in XYZ:
        for j in XYZ:
            if j >= i:
                expr = sum(m.R_h[k, i] * m.R_h[k, j] for k in XYZ)
                m.eq16_23_palm_orthonormal.add(expr == (1.0 if i == j else 0.0))
    m.eq22_coupling = pyo.ConstraintList(doc="DIP = k PIP")
    for dependent, independent, ratio in hand.couplings():
        m.eq22_coupling.add(m.theta[dependent] == ratio * m.theta[independent])

    # eq. 2: each link's frame in the object frame, then joint positions and the pad contact point
    link_index = [(j, k) for j, f in enumerate(fingers) for k in range(f.n_joints)]
    m.frame = pyo.Var(link_index, XYZ, XYZ, doc="link frames R_k^j (object frame)")
    m.eq2_frame = pyo.ConstraintList()
    m.p = pyo.Var(range(b), XYZ, bounds=(-1, 1), doc="contact points p^j")
    m.eq2_contact_point = pyo.ConstraintList()
    R_h = [[m.R_h[i, j] for j in XYZ] for i in XYZ]
    joint_axes, joint_positions, distal, samples = [], [], [], []
    column = 0
    for j, finger in enumerate(fingers):
        base = [[sum(R_h[i][k] * finger.base_rotation[k, c] for k in XYZ) for c in XYZ] for i in XYZ]
        position = [m.d_h[i] + sum(R_h[i][k] * finger.base_position[k] for k in XYZ) for i in XYZ]
        previous = base
        axes_j, positions_j = [], []
        for k, joint in enumerate(finger.joints):
            theta = m.theta[column + k]
            axes_j.append([sum(previous[i][c] * joint.axis[c] for c in XYZ) for i in XYZ])
            positions_j.append(position)
            rot = _axis_rotation(joint.axis, pyo.cos(theta), pyo.sin(theta))
            for r in XYZ:
                for c in XYZ:
                    expr = sum(previous[r][q] * rot[q][c] for q in XYZ)
                    define(m.eq2_frame, m.frame[j, k, r, c], expr)
            current = [[m.frame[j, k, r, c] for c in XYZ] for r in XYZ]
            if joint.link > 0:
                is_distal = k == max(i for i, jt in enumerate(finger.joints) if jt.link > 0)
                fractions = finger.distal_sample_fractions if is_distal else finger.sample_fractions
                for f in fractions:
                    samples.append(([position[i] + f * joint.link * current[i][0] for i in XYZ], finger.radius))
                distal_start, distal_frame, distal_length = position, current, joint.link
                position = [position[i] + joint.link * current[i][0] for i in XYZ]
            previous = current
        column += finger.n_joints
        for i in XYZ:
            expr = (
                distal_start[i]
                + finger.pad_along * distal_length * distal_frame[i][0]
                + finger.radius * distal_frame[i][2]
            )
            define(m.eq2_contact_point, m.p[j, i], expr)
        joint_axes.append(axes_j)
        joint_positions.append(positions_j)
        distal.append(distal_frame)
    palm = hand.palm
    for point in palm.points:
        samples.append(([m.d_h[i] + sum(R_h[i][k] * point[k] for k in XYZ) for i in XYZ], palm.radius))

    p = [[m.p[j, i] for i in XYZ] for j in range(b)]
    m.eq3_contact = pyo.Constraint(range(b), rule=lambda _, j: surface.contact(p[j]) == 0)
    m.eq14_collision = pyo.Constraint(
        range(len(samples)), rule=lambda _, s: surface.clearance(samples[s][0], samples[s][1]) >= 0
    )

    # contact normals (inward) and the cone tangents attached to the finger (App. 10.3)
    m.n = pyo.Var(range(b), XYZ, doc="inward unit normal at p^j")
    m.t = pyo.Var(range(b), XYZ, doc="first cone tangent at p^j")
    m.normal_definition = pyo.ConstraintList()
    m.tangent_definition = pyo.ConstraintList()
    for j in range(b):
        grad = surface.gradient(p[j])
        norm = sum(g * g for g in grad) ** 0.5
        for i in XYZ:
            m.normal_definition.add(m.n[j, i] * norm == -grad[i])
            definitions.append((m.n[j, i], -grad[i] / norm))
        n_j = [m.n[j, i] for i in XYZ]
        x_d = [distal[j][i][0] for i in XYZ]
        along = _dot(x_d, n_j)
        w = [x_d[i] - along * n_j[i] for i in XYZ]
        w_norm = sum(c * c for c in w) ** 0.5
        for i in XYZ:
            m.tangent_definition.add(m.t[j, i] * w_norm == w[i])
            definitions.append((m.t[j, i], w[i] / w_norm))
    cos_bound = float(np.cos(np.radians(settings.pad_angle_max_deg)))
    m.pad_facing = pyo.Constraint(
        range(b), rule=lambda _, j: sum(distal[j][i][2] * m.n[j, i] for i in XYZ) >= cos_bound
    )

    # friction cone edges l_i^j (eq. 24) and the torque parts p^j x l_i^j of the primitive wrenches (eq. 5), each
    # a variable defined once: the force-closure and eq. 10 constraints are then bilinear in them, which keeps
    # their Hessian, and IPOPT's KKT factor, sparse
    angles = 2 * np.pi * np.arange(1, m_edges + 1) / m_edges
    scale = 1.0 / np.sqrt(1 + mu**2)
    cells = [(j, e) for j in range(b) for e in range(m_edges)]
    m.l = pyo.Var(cells, XYZ, doc="friction cone edges l_i^j (eq. 24)")
    m.l_torque = pyo.Var(cells, XYZ, doc="p^j x l_i^j, the torque part of the primitive wrench (eq. 5)")
    m.eq24_cone_edge = pyo.ConstraintList()
    m.eq5_wrench = pyo.ConstraintList()
    for j in range(b):
        n_j = [m.n[j, i] for i in XYZ]
        t1 = [m.t[j, i] for i in XYZ]
        t2 = _cross(n_j, t1)
        for e, angle in enumerate(angles):
            edge = [scale * (n_j[i] + mu * (np.cos(angle) * t1[i] + np.sin(angle) * t2[i])) for i in XYZ]
            torque = _cross(p[j], [m.l[j, e, i] for i in XYZ])
            for i in XYZ:
                define(m.eq24_cone_edge, m.l[j, e, i], edge[i])
            for i in XYZ:
                define(m.eq5_wrench, m.l_torque[j, e, i], torque[i])
    edges = [[[m.l[j, e, i] for i in XYZ] for e in range(m_edges)] for j in range(b)]
    wrenches = [[edges[j][e] + [m.l_torque[j, e, i] for i in XYZ] for e in range(m_edges)] for j in range(b)]

    # eq. 7: the finger Jacobians J^j, columns a_k x (p^j - P_k), as variables shared by eq. 10, 12 and 13
    joints = [(j, k) for j in range(b) for k in range(fingers[j].n_joints)]
    m.J = pyo.Var(joints, XYZ, doc="finger Jacobian columns a_k x (p^j - P_k) (eq. 7)")
    m.eq7_jacobian = pyo.ConstraintList()
    for j, k in joints:
        column = _cross(joint_axes[j][k], [p[j][i] - joint_positions[j][k][i] for i in XYZ])
        for i in XYZ:
            define(m.eq7_jacobian, m.J[j, k, i], column[i])
    # the joint torques of a unit force along each cone edge, J^j^T l_i^j: eq. 10's torques are then linear
    # combinations of them
    m.edge_torque = pyo.Var(
        [(j, e, k) for j, e in cells for k in range(fingers[j].n_joints)], doc="J^j^T l_i^j (eq. 1, 7)"
    )
    m.eq7_edge_torque = pyo.ConstraintList()
    for j, e, k in m.edge_torque.index_set():
        define(m.eq7_edge_torque, m.edge_torque[j, e, k], _dot([m.J[j, k, i] for i in XYZ], edges[j][e]))

    # eq. 4: force closure
    m.phi = pyo.Var(cells, bounds=(settings.force_closure_min_weight, 1.0), doc="force-closure weights phi")
    m.eq4_weights_sum = pyo.Constraint(expr=sum(m.phi.values()) == 1)
    m.eq4_force_closure = pyo.Constraint(
        range(6), rule=lambda _, r: sum(m.phi[j, e] * wrenches[j][e][r] for j, e in cells) == 0
    )

    def joint_torques(j, force):
        """tau^j = J^j^T f^j (eq. 7)."""
        return [_dot([m.J[j, k, i] for i in XYZ], force) for k in range(fingers[j].n_joints)]

    # eq. 8 and 12-13: task forces for each unit axis, and the objective
    f_max = bounds.task_force_n
    m.force = pyo.Var(
        range(n_axes), range(b), XYZ, bounds=(None if f_max is None else -f_max, f_max), doc="task contact forces f_i"
    )
    m.eq8_task_force = pyo.ConstraintList()
    objective = 0
    for a in range(n_axes):
        forces = [[m.force[a, j, i] for i in XYZ] for j in range(b)]
        total_force = [sum(forces[j][i] for j in range(b)) for i in XYZ]
        total_torque = [sum(_cross(p[j], forces[j])[i] for j in range(b)) for i in XYZ]
        for r in range(6):
            m.eq8_task_force.add((total_force + total_torque)[r] == float(axes[a][r]))
        for j in range(b):
            objective += float(weights[a]) * sum(t * t for t in joint_torques(j, forces[j]))
    m.eq12_Q = pyo.Expression(expr=objective, doc="Q, eq. 12")

    # eq. 1 and 10: every task wrench +-gamma_i u_i applied with cone forces and activations in [0, 1]
    blocks = [(a, s) for a in range(n_axes) for s in (0, 1)]
    m.lam = pyo.Var(blocks, cells, bounds=(0, bounds.edge_force_n), doc="cone-edge force magnitudes per task wrench")
    muscles = [(j, q) for j, f in enumerate(fingers) for q in range(len(f.muscles))]
    cap = 1.0 - settings.activation_margin
    m.act = pyo.Var(blocks, muscles, bounds=(0, cap), doc="tendon activations per task wrench (eq. 1)")
    m.eq10_wrench = pyo.ConstraintList()
    m.eq10_torque = pyo.ConstraintList()
    targets = {(a, s): (1.0 if s == 0 else -1.0) * lengths[a] * axes[a] for a, s in blocks}
    for a, s in blocks:
        for r in range(6):
            m.eq10_wrench.add(sum(m.lam[a, s, j, e] * wrenches[j][e][r] for j, e in cells) == float(targets[a, s][r]))
        for j, finger in enumerate(fingers):
            torque_map = finger.torque_map
            for k in range(finger.n_joints):
                tau = sum(m.lam[a, s, j, e] * m.edge_torque[j, e, k] for e in range(m_edges))
                produced = sum(float(torque_map[k, q]) * m.act[a, s, j, q] for q in range(len(finger.muscles)))
                m.eq10_torque.add(tau == produced)

    def squares(weight, values):
        return weight * sum(v**2 for v in values) if weight > 0 else 0

    closure = squares(regularisation.closure_weight, [v - 1.0 / len(cells) for v in m.phi.values()])
    feasibility = squares(regularisation.edge_force, m.lam.values()) + squares(
        regularisation.activation, m.act.values()
    )
    m.eq12_objective = pyo.Objective(expr=m.eq12_Q + closure + feasibility, doc="eq. 12 and the regularising terms")
    m.approach_objective = pyo.Objective(expr=m.eq12_Q + closure, doc="the same without eq. 10's variables")
    m.approach_objective.deactivate()
    return GraspNLP(m, hand, definitions, targets, edges, wrenches, joint_torques)
