"""The grasp-synthesis NLP of the paper's Sections 5-6 as a Pyomo ``ConcreteModel``.

One model per (task, hand, object). :data:`EQUATIONS` is the paper's equation map: each function adds one
family of variables and constraints, in this order, and the component names carry the equation numbers:

    palm_and_joints          eq. 16-23  palm rotation orthonormal; joint limits as bounds (eq. 20-21); DIP = k PIP
    held_axis_rotation       (none)     when asked, the grasp's turn about a solid of revolution's axis held at
                                        the start's (:func:`held_axis_rotation`; not in the paper)
    kinematics               eq. 2      link frames, joint positions, pad contact points (or the centres of the
                                        fingertip spheres the contacts roll over)
    contacts_and_collisions  eq. 3, 14  contacts on the surface; hand spheres outside it; inward unit normals,
                                        the cone tangent along the pad's own tangent (App. 10.3); pads facing it;
                                        a rolling contact one offset from its sphere's centre along the normal
    cones_and_wrenches       eq. 24, 5  friction cone edges and the torque parts of the primitive wrenches
    jacobians                eq. 7      finger Jacobian columns
    edge_torques             eq. 7      the joint torques of each unit cone edge (for eq. 10)
    force_closure            eq. 4      phi >= eps, sum phi = 1, sum phi w = 0
    task_forces_and_quality  eq. 8, 12  G f_i = u_i and Q = sum_i gamma_i tau_i^T tau_i, tau_i = J^T f_i (eq. 13)
    torque_feasibility       eq. 1, 10  every +-gamma_i u_i applied with cone forces, the joint torques carried by
                                        the finger's tendons or motors with activations in [0, cap] (for the
                                        task's longest axes only when asked: :func:`build_model`)
    objective                eq. 12     Q plus the small terms of :class:`Regularisation`

Every quantity that several constraints share (frames, contacts, normals, cone edges, wrenches, Jacobians, edge
torques) is a variable defined once by an equality, so that eq. 4, 10 and 12 are bilinear in them and the
Hessian stays sparse. Unit vectors and rotation entries carry no bounds: their equalities bound them, and a bound
at +-1 that they touch cuts IPOPT's barrier steps short. Eq. 9 is checked by the verifier, not imposed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
import pyomo.environ as pyo

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand.hand_model import Finger, GraspingHand, Hand, Pad, Sphere
from grasptask.hand.kinematics import forward
from grasptask.objects.surface import ImplicitObject
from grasptask.synthesis.algebra import XYZ, axis_rotation, constant_times, cross, cross_matrix, dot
from grasptask.synthesis.compiled import CompiledExpressions
from grasptask.synthesis.force_problem import ForceSolution, GraspGeometry
from grasptask.synthesis.resistance import soft_contacts
from grasptask.synthesis.solver_config import Regularisation, SearchBounds
from grasptask.synthesis.spline import SurrogateSpec
from grasptask.synthesis.surfaces import GridSurface, NLPSurface, surface_for
from grasptask.task.task_model import TaskModel

Vector = list[Any]
Matrix = list[list[Any]]


@dataclass
class NLPBuilder:
    """What the equation families share: the model, its index sets, and the expressions one family makes for
    the next (link geometry, contact points, cone edges, wrenches). Filled in :data:`EQUATIONS` order."""

    model: pyo.ConcreteModel
    hand: GraspingHand
    surface: NLPSurface
    task: TaskModel
    settings: GraspSettings
    bounds: SearchBounds
    regularisation: Regularisation
    #: the task axes whose wrenches eq. 10 holds, longest first
    torque_axes: range
    #: the object's axis of revolution (direction, point) about which the grasp's turn is held; None: free
    held_axis: tuple[np.ndarray, np.ndarray] | None = None
    #: a two-contact grasp's line between its pads, in the palm frame, whose turn the objective holds near the
    #: start's (:func:`pair_turn`); None: more contacts, or no such term
    pair_line: np.ndarray | None = None
    #: ``(variable, expression)`` pairs in dependency order, for :meth:`GraspNLP.initialise`
    definitions: list[tuple[Any, Any]] = field(default_factory=list)
    #: per finger, the distance from its fingertip sphere's centre to a rolling contact (0: a fixed pad point)
    contact_offsets: np.ndarray = field(default_factory=lambda: np.zeros(0))
    pad_centres: dict[int, Vector] = field(default_factory=dict)  # the rolling fingers' sphere centres
    palm_rotation: Matrix = field(default_factory=list)
    joint_axes: list[list[Vector]] = field(default_factory=list)  # per finger and joint, in the object frame
    joint_positions: list[list[Vector]] = field(default_factory=list)
    pad_normals: list[Vector] = field(default_factory=list)  # each pad's outward normal
    pad_tangents: list[Vector] = field(default_factory=list)  # the direction each cone's first edge follows
    #: per finger with a flat pad, its face's two in-plane directions, which the surface's normal must be square to
    flat_faces: dict[int, tuple[Vector, Vector]] = field(default_factory=dict)
    #: collision spheres: centre, radius, and how deep into the object they may sink (a rolling fingertip's
    #: compliance, on its last link; 0 elsewhere)
    samples: list[tuple[Vector, float, float]] = field(default_factory=list)
    contacts: list[Vector] = field(default_factory=list)  # p^j
    edges: list[list[Vector]] = field(default_factory=list)  # l_i^j
    wrenches: list[list[Vector]] = field(default_factory=list)  # (l_i^j, p^j x l_i^j)

    @property
    def fingers(self) -> list[Finger]:
        return list(self.hand.fingers.values())

    @property
    def b(self) -> int:
        """The number of grasping fingers, one contact each."""
        return len(self.hand.fingers)

    @property
    def twisting(self) -> list[int]:
        """The fingers whose contact is a soft finger's (a flat pad pressed on the surface): it resists a twist
        about its normal up to :attr:`twist_coefficient` times its normal force; a point contact does not."""
        return soft_contacts(self.hand, self.settings)

    @property
    def twist_coefficient(self) -> float:
        """The margin's torsional friction (m): the grasp config's, scaled as its friction is (eq. 4, 10)."""
        return self.settings.friction_scale * self.settings.torsional_friction_m

    def edge_count(self, j: int) -> int:
        """Finger ``j``'s primitive wrenches: its cone's edges, and a soft finger's two twists (+ and -)."""
        return self.settings.cone_edges + (2 if j in self.twisting else 0)

    @property
    def cells(self) -> list[tuple[int, int]]:
        """(finger, primitive wrench) pairs: the cone edges, then a soft finger's two twists."""
        return [(j, e) for j in range(self.b) for e in range(self.edge_count(j))]

    def define(self, constraints: pyo.ConstraintList, var: Any, expr: Any) -> None:
        """``var == expr`` as a constraint, and ``var`` set from ``expr`` by :meth:`GraspNLP.initialise`."""
        constraints.add(var == expr)
        self.definitions.append((var, expr))

    def joint_torques(self, j: int, force: Vector) -> Vector:
        """tau^j = J^j^T f^j (eq. 7)."""
        m = self.model
        return [dot([m.J[j, k, i] for i in XYZ], force) for k in range(self.fingers[j].n_joints)]


def palm_and_joints(nlp: NLPBuilder) -> None:
    """Eq. 16-23: the palm pose and joint angles, the palm rotation orthonormal, joint limits as bounds and the
    DIP-PIP coupling."""
    m, hand = nlp.model, nlp.hand
    m.R_h = pyo.Var(XYZ, XYZ, doc="palm rotation R_h in the object frame")
    m.d_h = pyo.Var(XYZ, bounds=(-1, 1), doc="palm position d_h in the object frame (m)")
    lower, upper = hand.lower, hand.upper
    m.theta = pyo.Var(range(hand.n_joints), bounds=lambda _, k: (lower[k], upper[k]), doc="joint angles, eq. 20-21")
    m.eq16_23_palm_orthonormal = pyo.ConstraintList()
    for i in XYZ:
        for j in XYZ:
            if j >= i:
                expr = sum(m.R_h[k, i] * m.R_h[k, j] for k in XYZ)
                m.eq16_23_palm_orthonormal.add(expr == (1.0 if i == j else 0.0))
    m.eq22_coupling = pyo.ConstraintList(doc="DIP = k PIP")
    for dependent, independent, ratio, offset in hand.couplings():
        coupled = ratio * m.theta[independent]
        m.eq22_coupling.add(m.theta[dependent] == (coupled + offset if offset else coupled))
    nlp.palm_rotation = [[m.R_h[i, j] for j in XYZ] for i in XYZ]


def held_axis_rotation(nlp: NLPBuilder) -> None:
    """The grasp's turn about the object's axis of revolution held at its start's, to first order: one row,
    linear in the palm pose, that keeps the palm's displacement from a reference pose orthogonal to that pose's
    turn about the axis.

    Turning a grasp about the axis leaves every constraint satisfied and changes Q only as much as the task is
    asymmetric about the axis (:func:`grasptask.task.symmetry.axis_asymmetry`). For a nearly symmetric task that
    direction is nearly flat and curved, and IPOPT spent most of its iterations turning the grasp along it in
    small steps (docs/design/synthesis.md). The reference is 12 variables (palm position, then the rotation's
    columns) that each solve pins to its own starting pose through their bounds, so IPOPT treats them as
    parameters (:meth:`GraspNLP.held_positions`)."""
    if nlp.held_axis is None and nlp.pair_line is None:
        return
    m = nlp.model
    m.held_reference = pyo.Var(
        range(12), initialize=0.0, doc="the palm pose the turn is held at: d_h, then R_h's columns"
    )
    if nlp.held_axis is None:  # the reference only, for a two-contact grasp's turn (pair_turn)
        return
    axis, point = (np.asarray(v, dtype=float) for v in nlp.held_axis)
    reference = [[m.held_reference[3 * c + i] for i in XYZ] for c in range(4)]
    current = [[m.d_h[i] for i in XYZ]] + [[m.R_h[i, j] for i in XYZ] for j in XYZ]
    centred = [[r[i] - point[i] for i in XYZ] for r in reference[:1]] + reference[1:]
    moved = [[v[i] - point[i] for i in XYZ] for v in current[:1]] + current[1:]
    turn = cross_matrix(axis)
    turns = [constant_times(turn, r) for r in centred]
    size = sum(dot(t, t) for t in turns) ** 0.5
    m.held_axis_rotation = pyo.Constraint(expr=sum(dot(t, v) for t, v in zip(turns, moved, strict=True)) / size == 0)


def _moved(start: Vector, frame: Matrix, offset: np.ndarray) -> Vector:
    """``start + frame offset``, written with the offset's non-zero components only."""
    point = list(start)
    for c in XYZ:
        if offset[c] != 0:
            point = [point[i] + float(offset[c]) * frame[i][c] for i in XYZ]
    return point


def _direction(frame: Matrix, vector: np.ndarray) -> Vector:
    """``frame vector``: a column of the frame when ``vector`` is a coordinate axis."""
    for c in XYZ:
        if vector[c] == 1 and np.count_nonzero(vector) == 1:
            return [frame[i][c] for i in XYZ]
    return [sum(frame[i][c] * float(vector[c]) for c in XYZ) for i in XYZ]


def _turned(frame: Matrix, rotation: np.ndarray) -> Matrix:
    """``frame rotation`` for a constant rotation."""
    return [[sum(frame[i][k] * rotation[k, c] for k in XYZ) for c in XYZ] for i in XYZ]


def _in_palm(nlp: NLPBuilder, point: np.ndarray) -> Vector:
    """A point fixed in the palm frame, in the object frame: ``d_h + R_h point``."""
    m, R_h = nlp.model, nlp.palm_rotation
    return [m.d_h[i] + sum(R_h[i][k] * point[k] for k in XYZ) for i in XYZ]


def _finger_chain(nlp: NLPBuilder, j: int, finger: Finger, first_column: int) -> None:
    """Eq. 2 along one finger: each link's frame defined, its joints' axes and positions, its collision
    spheres, and the pad contact point on the last link."""
    m = nlp.model
    previous = nlp.palm_rotation
    # a rolling fingertip sinks by the compliance, and so may the rest of its tip (a capsule's other spheres)
    last, fixed = finger.n_joints - 1, nlp.contact_offsets[j] <= 0
    allowance = 0.0 if fixed else nlp.hand.compliance_m
    axes_j: list[Vector] = []
    positions_j: list[Vector] = []
    position: Vector = []
    for k, joint in enumerate(finger.joints):
        # the first joint's place is fixed in the palm; each later one in the link before it
        position = _in_palm(nlp, joint.offset) if k == 0 else _moved(position, previous, joint.offset)
        if joint.rotation is not None:
            previous = _turned(previous, joint.rotation)
        theta = m.theta[first_column + k]
        axes_j.append([sum(previous[i][c] * joint.axis[c] for c in XYZ) for i in XYZ])
        if joint.sliding:  # a gripper's jaw: the link slides along the axis, its frame unturned
            position = [position[i] + theta * axes_j[-1][i] for i in XYZ]
            turned = previous
        else:
            rot = axis_rotation(joint.axis, pyo.cos(theta), pyo.sin(theta))
            turned = [[sum(previous[r][q] * rot[q][c] for q in XYZ) for c in XYZ] for r in XYZ]
        positions_j.append(position)
        for r in XYZ:
            for c in XYZ:
                nlp.define(m.eq2_frame, m.frame[j, k, r, c], turned[r][c])
        previous = [[m.frame[j, k, r, c] for c in XYZ] for r in XYZ]
        for sphere in finger.spheres:
            if sphere.link == k:
                sunk = allowance if k == last else 0.0
                clip = k == last and fixed
                radius = _under_a_fixed_pad(sphere, finger.pad, nlp.hand.compliance_m) if clip else sphere.radius
                if radius > 1e-4:
                    nlp.samples.append((_moved(position, previous, sphere.center), radius, sunk))
    pad = finger.pad
    pad_normal = _direction(previous, pad.normal)
    offset = float(nlp.contact_offsets[j])
    if offset > 0:  # rolling: p starts at the pad's home point, sunk by the compliance; eq2_rolling_contact holds it
        centre = _moved(position, previous, pad.centre)
        nlp.pad_centres[j] = centre
        nlp.definitions += [(m.p[j, i], centre[i] + offset * pad_normal[i]) for i in XYZ]
    else:
        for i, expr in enumerate(_moved(position, previous, pad.point)):
            nlp.define(m.eq2_contact_point, m.p[j, i], expr)
    nlp.joint_axes.append(axes_j)
    nlp.joint_positions.append(positions_j)
    nlp.pad_normals.append(pad_normal)
    nlp.pad_tangents.append(_direction(previous, pad.tangent))
    if pad.flat:
        nlp.flat_faces[j] = (_direction(previous, pad.tangent), _direction(previous, pad.across))


def _under_a_fixed_pad(sphere: Sphere, pad: Pad, compliance: float) -> float:
    """A tip sphere's radius clipped at the fixed pad point's tangent plane where it stands proud of it by less
    than the tip gives (``compliance``). The paper's contact is the pad point itself, and a capsule cover's sphere
    0.29 mm proud of it kept it off a flat face: the Allegro's drawing took 12.8 s a start in the paper's model,
    0.68 s clipped (6 starts). Clipped further, the BarrettHand's cylinder cover (1.18 mm proud) let its link sink
    past the verifier's clearance: 57% of 126 drawing starts verified, 6 of 6 unclipped. The human hand's tips have
    none to clip."""
    plane = float((pad.point - sphere.center) @ pad.normal)
    return plane if plane < sphere.radius <= plane + compliance else sphere.radius


def kinematics(nlp: NLPBuilder) -> None:
    """Eq. 2: every link's frame in the object frame, the joint positions and the pad contact points p^j; the
    palm's collision spheres."""
    m, fingers = nlp.model, nlp.fingers
    link_index = [(j, k) for j, f in enumerate(fingers) for k in range(f.n_joints)]
    m.frame = pyo.Var(link_index, XYZ, XYZ, doc="link frames R_k^j (object frame)")
    m.eq2_frame = pyo.ConstraintList()
    m.p = pyo.Var(range(nlp.b), XYZ, bounds=(-1, 1), doc="contact points p^j")
    m.eq2_contact_point = pyo.ConstraintList()
    column = 0
    for j, finger in enumerate(fingers):
        _finger_chain(nlp, j, finger, column)
        column += finger.n_joints
    palm = nlp.hand.palm
    for point, radius in zip(palm.points, palm.radii, strict=True):
        nlp.samples.append((_in_palm(nlp, point), float(radius), 0.0))
    nlp.contacts = [[m.p[j, i] for i in XYZ] for j in range(nlp.b)]


def contacts_and_collisions(nlp: NLPBuilder) -> None:
    """Eq. 3 and 14: the contacts on the surface and every hand sample outside it by its radius; the inward unit
    normal -grad g / |grad g| at each contact, the first cone tangent (the distal phalanx's axis projected on the
    tangent plane, App. 10.3), and the pad facing the surface within the configured angle, which keeps a rolling
    contact on the pad, off the nail and the back of the finger.

    A rolling contact is its fingertip sphere's point nearest the surface, sunk by the hand's compliance:
    ``p = c + (r - compliance) n``, with the sphere's centre ``c`` fixed in the distal link and ``n`` the
    inward normal at ``p`` (eq. 2 for a contact that moves over the fingertip). On a distance field eq. 3 holds
    ``c`` at ``r - compliance`` from the surface and ``n`` is the normal there, which is the same point for an
    exact distance, and a wall thinner than the grid is seen (:class:`~grasptask.synthesis.surfaces.GridSurface`).

    A flat pad's contact is its face's middle, and the face lies on the surface: the inward normal there is square
    to the face's two in-plane directions (``eq2_flat_pad``)."""
    m, surface, p, samples = nlp.model, nlp.surface, nlp.contacts, nlp.samples
    b = nlp.b
    # on a distance field, a rolling contact is where its sphere's centre stands r - compliance off the surface
    at_centre = {j: c for j, c in nlp.pad_centres.items() if surface.measures_distance}
    where = [at_centre.get(j, p[j]) for j in range(b)]
    level = [float(nlp.contact_offsets[j]) if j in at_centre else 0.0 for j in range(b)]
    m.eq3_contact = pyo.Constraint(range(b), rule=lambda _, j: surface.contact(where[j]) == level[j])
    m.eq14_collision = pyo.Constraint(
        range(len(samples)), rule=lambda _, s: surface.clearance(samples[s][0], samples[s][1]) >= -samples[s][2]
    )
    m.n = pyo.Var(range(b), XYZ, doc="inward unit normal at p^j")
    m.t = pyo.Var(range(b), XYZ, doc="first cone tangent at p^j")
    m.normal_definition = pyo.ConstraintList()
    m.tangent_definition = pyo.ConstraintList()
    for j in range(b):
        grad = surface.gradient(where[j])
        norm = sum(g * g for g in grad) ** 0.5
        for i in XYZ:
            m.normal_definition.add(m.n[j, i] * norm == -grad[i])
            nlp.definitions.append((m.n[j, i], -grad[i] / norm))
        n_j = [m.n[j, i] for i in XYZ]
        x_d = nlp.pad_tangents[j]
        along = dot(x_d, n_j)
        w = [x_d[i] - along * n_j[i] for i in XYZ]
        w_norm = sum(c * c for c in w) ** 0.5
        for i in XYZ:
            m.tangent_definition.add(m.t[j, i] * w_norm == w[i])
            nlp.definitions.append((m.t[j, i], w[i] / w_norm))
    m.eq2_rolling_contact = pyo.ConstraintList()
    for j, centre in nlp.pad_centres.items():
        offset = float(nlp.contact_offsets[j])
        for i in XYZ:
            m.eq2_rolling_contact.add(m.p[j, i] == centre[i] + offset * m.n[j, i])
    # a flat pad's face lies on the surface: the normal at its contact is square to the face's two directions
    if nlp.flat_faces:  # only then: the paper's model keeps its components as they were
        m.eq2_flat_pad = pyo.ConstraintList()
        for j, face in nlp.flat_faces.items():
            for direction in face:
                m.eq2_flat_pad.add(dot(direction, [m.n[j, i] for i in XYZ]) == 0)
    # per finger: a mesh fingertip's pad sphere may leave the real tip before the settings' bound
    cos_bound = np.cos(np.radians(nlp.hand.pad_angle_limits(nlp.settings.pad_angle_max_deg)))
    m.pad_facing = pyo.Constraint(
        range(b), rule=lambda _, j: sum(nlp.pad_normals[j][i] * m.n[j, i] for i in XYZ) >= float(cos_bound[j])
    )


def cones_and_wrenches(nlp: NLPBuilder) -> None:
    """Eq. 24 and 5: the linearised friction cone's edges l_i^j about the true normal, and the torque parts
    p^j x l_i^j of the primitive wrenches, each a variable. A soft finger's (a flat pad's) two more wrenches
    press along the normal and twist about it, ``(n, p x n +- mu_t n)``: the soft-finger model of Salisbury and
    Mason, linearised as its cone's edges and the two pure twists; their hull holds |f_t| / mu + |m| / mu_t <= f_n.
    """
    m, m_edges = nlp.model, nlp.settings.cone_edges
    mu = nlp.settings.friction_scale * nlp.settings.friction_coefficient  # the margin's cones (eq. 4 and 10)
    angles = 2 * np.pi * np.arange(1, m_edges + 1) / m_edges
    scale = 1.0 / np.sqrt(1 + mu**2)
    cells, twist = nlp.cells, nlp.twist_coefficient
    m.l = pyo.Var(cells, XYZ, doc="friction cone edges l_i^j (eq. 24)")
    m.l_torque = pyo.Var(cells, XYZ, doc="p^j x l_i^j, the torque part of the primitive wrench (eq. 5)")
    m.eq24_cone_edge = pyo.ConstraintList()
    m.eq5_wrench = pyo.ConstraintList()
    for j in range(nlp.b):
        n_j = [m.n[j, i] for i in XYZ]
        t1 = [m.t[j, i] for i in XYZ]
        t2 = cross(n_j, t1)
        for e in range(nlp.edge_count(j)):
            if e < m_edges:
                edge = [scale * (n_j[i] + mu * (np.cos(angles[e]) * t1[i] + np.sin(angles[e]) * t2[i])) for i in XYZ]
            else:  # a soft finger's twist: pressing along the normal, turning about it
                edge = n_j
            torque = cross(nlp.contacts[j], [m.l[j, e, i] for i in XYZ])
            if e >= m_edges:
                torque = [torque[i] + _twist_sign(nlp, e) * twist * m.l[j, e, i] for i in XYZ]
            for i in XYZ:
                nlp.define(m.eq24_cone_edge, m.l[j, e, i], edge[i])
            for i in XYZ:
                nlp.define(m.eq5_wrench, m.l_torque[j, e, i], torque[i])
    nlp.edges = [[[m.l[j, e, i] for i in XYZ] for e in range(nlp.edge_count(j))] for j in range(nlp.b)]
    nlp.wrenches = [
        [nlp.edges[j][e] + [m.l_torque[j, e, i] for i in XYZ] for e in range(nlp.edge_count(j))] for j in range(nlp.b)
    ]


def _twist_sign(nlp: NLPBuilder, e: int) -> float:
    """+1 for a soft finger's first twist, -1 for its second."""
    return 1.0 if e == nlp.settings.cone_edges else -1.0


def jacobians(nlp: NLPBuilder) -> None:
    """Eq. 7: the finger Jacobians J^j, columns a_k x (p^j - P_k) (a_k for a sliding joint)."""
    m, fingers, p = nlp.model, nlp.fingers, nlp.contacts
    joints = [(j, k) for j in range(nlp.b) for k in range(fingers[j].n_joints)]
    m.J = pyo.Var(joints, XYZ, doc="finger Jacobian columns a_k x (p^j - P_k) (eq. 7)")
    m.eq7_jacobian = pyo.ConstraintList()
    for j, k in joints:
        axis = nlp.joint_axes[j][k]
        if fingers[j].joints[k].sliding:  # a sliding joint moves every point of its link along its axis
            column = axis
        else:
            column = cross(axis, [p[j][i] - nlp.joint_positions[j][k][i] for i in XYZ])
        for i in XYZ:
            nlp.define(m.eq7_jacobian, m.J[j, k, i], column[i])


def edge_torques(nlp: NLPBuilder) -> None:
    """Eq. 7: the joint torques J^j^T l_i^j of a unit force along each cone edge, of which eq. 10's torques are
    linear combinations; a soft finger's twist adds its torque about the normal, +-mu_t a_k . n, on each turning
    joint (a sliding joint carries none)."""
    m, fingers, twist = nlp.model, nlp.fingers, nlp.twist_coefficient
    m.edge_torque = pyo.Var(
        [(j, e, k) for j, e in nlp.cells for k in range(fingers[j].n_joints)], doc="J^j^T l_i^j (eq. 1, 7)"
    )
    m.eq7_edge_torque = pyo.ConstraintList()
    for j, e, k in m.edge_torque.index_set():
        torque = dot([m.J[j, k, i] for i in XYZ], nlp.edges[j][e])
        if e >= nlp.settings.cone_edges and not fingers[j].joints[k].sliding:
            torque = torque + _twist_sign(nlp, e) * twist * dot(nlp.joint_axes[j][k], nlp.edges[j][e])
        nlp.define(m.eq7_edge_torque, m.edge_torque[j, e, k], torque)


def force_closure(nlp: NLPBuilder) -> None:
    """Eq. 4: positive weights phi of the primitive wrenches, summing to 1, whose wrench sum is zero."""
    m, cells, wrenches = nlp.model, nlp.cells, nlp.wrenches
    m.phi = pyo.Var(cells, bounds=(nlp.settings.force_closure_min_weight, 1.0), doc="force-closure weights phi")
    m.eq4_weights_sum = pyo.Constraint(expr=sum(m.phi.values()) == 1)
    m.eq4_force_closure = pyo.Constraint(
        range(6), rule=lambda _, r: sum(m.phi[j, e] * wrenches[j][e][r] for j, e in cells) == 0
    )


def task_forces_and_quality(nlp: NLPBuilder) -> None:
    """Eq. 8 and 12-13: contact forces f_i with G f_i = u_i for each unit task axis (eq. 8's G^R u_i + A x,
    without a matrix inverse), and Q = sum_i gamma_i sum_j |J^j^T f_i^j|^2 as an expression. A soft finger adds
    a twist about its normal to G f_i, and its torque on the finger's turning joints to J^T f_i."""
    m, b, p = nlp.model, nlp.b, nlp.contacts
    axes, weights = nlp.task.axes, nlp.task.weights
    f_max = nlp.bounds.task_force_n
    m.force = pyo.Var(
        range(len(weights)),
        range(b),
        XYZ,
        bounds=(None if f_max is None else -f_max, f_max),
        doc="task contact forces f_i",
    )
    m.eq8_task_force = pyo.ConstraintList()
    twisting = nlp.twisting
    if twisting:  # only then: the paper's model keeps its components as they were
        m.task_twist = pyo.Var(range(len(weights)), twisting, doc="task twist about each soft finger's normal")
    normals = [[m.n[j, i] for i in XYZ] for j in range(b)]
    quality = 0
    for a in range(len(weights)):
        forces = [[m.force[a, j, i] for i in XYZ] for j in range(b)]
        total_force = [sum(forces[j][i] for j in range(b)) for i in XYZ]
        total_torque = [sum(cross(p[j], forces[j])[i] for j in range(b)) for i in XYZ]
        for j in twisting:
            total_torque = [total_torque[i] + m.task_twist[a, j] * normals[j][i] for i in XYZ]
        for r in range(6):
            m.eq8_task_force.add((total_force + total_torque)[r] == float(axes[a][r]))
        for j in range(b):
            torques = nlp.joint_torques(j, forces[j])
            if j in twisting:  # the twist's torque on each turning joint, a_k . n
                torques = [
                    t + m.task_twist[a, j] * dot(nlp.joint_axes[j][k], normals[j])
                    if not nlp.fingers[j].joints[k].sliding
                    else t
                    for k, t in enumerate(torques)
                ]
            quality += float(weights[a]) * sum(t * t for t in torques)
    m.eq12_Q = pyo.Expression(expr=quality, doc="Q, eq. 12")


def torque_feasibility(nlp: NLPBuilder) -> None:
    """Eq. 1 and 10: for each task axis and sign, cone-edge forces lam >= 0 that apply +-gamma_i u_i, with joint
    torques tau = J^T f carried by the hand's tendons or motors, T tau = A a (:class:`Capability`), and
    activations 0 <= a <= 1 - margin (the margin keeps the verifier's own LP from reading a hair over 1 at an
    active bound)."""
    m, fingers, cells, wrenches = nlp.model, nlp.fingers, nlp.cells, nlp.wrenches
    axes, lengths, m_edges = nlp.task.axes, nlp.task.lengths, nlp.settings.cone_edges
    blocks = [(a, s) for a in nlp.torque_axes for s in (0, 1)]
    m.lam = pyo.Var(
        blocks, cells, bounds=(0, nlp.bounds.edge_force_n), doc="cone-edge force magnitudes per task wrench"
    )
    capability = nlp.hand.capability
    cap = nlp.settings.activation_cap(capability.kind) - nlp.settings.activation_margin
    actuators = range(len(capability.actuators))
    m.act = pyo.Var(blocks, actuators, bounds=(0, cap), doc="tendon or motor activations per task wrench (eq. 1)")
    m.eq10_wrench = pyo.ConstraintList()
    m.eq10_torque = pyo.ConstraintList()
    floor = nlp.settings.min_normal_force_n
    if floor > 0:  # the margin's least normal force: a component only where the margin asks for one
        m.eq10_normal = pyo.ConstraintList()
    along_normal = 1.0 / np.sqrt(1.0 + (nlp.settings.friction_scale * nlp.settings.friction_coefficient) ** 2)
    joints = [(j, k) for j, f in enumerate(fingers) for k in range(f.n_joints)]
    for a, s in blocks:
        target = (1.0 if s == 0 else -1.0) * lengths[a] * axes[a]
        for r in range(6):
            applied = sum(m.lam[a, s, j, e] * wrenches[j][e][r] for j, e in cells)
            m.eq10_wrench.add(applied == float(target[r]))
        if floor > 0:  # each contact presses with at least the margin's normal force
            for j in range(nlp.b):
                pressing = sum(
                    m.lam[a, s, j, e] * (along_normal if e < m_edges else 1.0) for e in range(nlp.edge_count(j))
                )
                m.eq10_normal.add(pressing >= floor)
        taus = [sum(m.lam[a, s, j, e] * m.edge_torque[j, e, k] for e in range(nlp.edge_count(j))) for j, k in joints]
        for r, row in enumerate(capability.transmission):
            used = np.flatnonzero(row)
            carried = taus[used[0]] if len(used) == 1 and row[used[0]] == 1 else sum(row[k] * taus[k] for k in used)
            produced = sum(
                float(capability.torque_map[r, q]) * m.act[a, s, q] for q in np.flatnonzero(capability.torque_map[r])
            )
            m.eq10_torque.add(carried == produced)


def objective(nlp: NLPBuilder) -> None:
    """Eq. 12's Q plus small quadratic terms on the variables Q does not see (phi about its mean, eq. 10's edge
    forces and activations), so that each optimum is isolated instead of a flat manifold. Zero weights give the
    paper's objective; the Q a solution reports is eq. 12 alone."""
    m = nlp.model
    closure, feasibility = _regularising(nlp)
    turn, unseen = pair_turn(nlp), _unseen_task_forces(nlp)
    m.eq12_objective = pyo.Objective(
        expr=m.eq12_Q + closure + feasibility + turn + unseen, doc="eq. 12 and the regularising terms"
    )


def _unseen_task_forces(nlp: NLPBuilder) -> Any:
    """Eq. 8's task forces (and twists) of the fingers whose joints cannot feel every direction of a contact
    force, squared and weighted: a jaw's slide feels only the force along it, so Q is flat in the rest and
    IPOPT regularised its Hessian by 1e3-1e4 for a thousand iterations. Fingers of three or more turning joints
    (the human hand's, the Allegro's) get no such term: the paper's objective is theirs as it was."""
    m, weight = nlp.model, nlp.regularisation.task_force
    blind = [j for j, f in enumerate(nlp.fingers) if sum(not joint.sliding for joint in f.joints) < 3]
    if weight <= 0 or not blind:
        return 0
    forces = [v for (a, j, i), v in m.force.items() if j in blind]
    twists = [v for (a, j), v in m.task_twist.items()] if m.component("task_twist") is not None else []
    return weight * sum(v**2 for v in forces + twists)


def pair_turn(nlp: NLPBuilder) -> Any:
    """A two-contact grasp's turn about the line joining its contacts, from its start's, squared and weighted
    (0 for more contacts). Turning a two-jaw grasp about that line moves neither contact nor normal, so Q and
    every force stay as they are, and without this term each optimum was a circle of grasps along which IPOPT
    crept for 750-2,000 iterations. The turn is the palm's to first order, ``a . vee(skew(R_0^T R_h))`` about
    the line ``a`` in the palm frame, against the reference pose each solve pins to its start's."""
    if nlp.pair_line is None or nlp.regularisation.pair_turn <= 0:
        return 0
    m, a = nlp.model, nlp.pair_line
    start = [[m.held_reference[3 + 3 * c + i] for i in XYZ] for c in XYZ]  # R_0's columns
    now = [[m.R_h[i, c] for i in XYZ] for c in XYZ]

    def entry(r: int, c: int) -> Any:  # (R_0^T R_h)[r, c]
        return dot(start[r], now[c])

    turn = [0.5 * (entry(2, 1) - entry(1, 2)), 0.5 * (entry(0, 2) - entry(2, 0)), 0.5 * (entry(1, 0) - entry(0, 1))]
    return nlp.regularisation.pair_turn * sum(float(a[i]) * turn[i] for i in XYZ) ** 2


def _regularising(nlp: NLPBuilder) -> tuple[Any, Any]:
    """:class:`Regularisation`'s terms: phi about its mean, and eq. 10's edge forces and activations (0 where the
    model has none)."""
    m, weights = nlp.model, nlp.regularisation

    def squares(weight: float, values: Any) -> Any:
        return weight * sum(v**2 for v in values) if weight > 0 else 0

    closure = squares(weights.closure_weight, [v - 1.0 / len(m.phi) for v in m.phi.values()])
    if m.component("lam") is None:
        return closure, 0
    return closure, squares(weights.edge_force, m.lam.values()) + squares(weights.activation, m.act.values())


#: the paper's equation map, in the order the components are created (which fixes the NL column order)
EQUATIONS: tuple[Callable[[NLPBuilder], None], ...] = (
    palm_and_joints,
    # its row and reference columns first: MUMPS's METIS ordering of the KKT matrix then took 15-20% less time
    # per iteration than with them last (docs/design/synthesis.md)
    held_axis_rotation,
    kinematics,
    contacts_and_collisions,
    cones_and_wrenches,
    jacobians,
    edge_torques,
    force_closure,
    task_forces_and_quality,
    torque_feasibility,
    objective,
)


def _set_within(var: Any, value: float) -> None:
    """``var`` set to ``value`` clipped to its bounds."""
    low, high = var.lb, var.ub
    value = float(value)
    value = value if low is None else max(value, low)
    var.set_value(value if high is None else min(value, high))


@dataclass
class GraspNLP:
    """The Pyomo model and what is needed to start it from a palm pose and read a solution back."""

    model: pyo.ConcreteModel
    hand: GraspingHand
    definitions: list[tuple[Any, Any]] = field(default_factory=list)  # (variable, expression), dependency order
    #: a mesh's or point cloud's surface, whose placeholder rows the backend fills (None: all Pyomo)
    surrogate: GridSurface | None = None
    #: the (finger, wrench) cells of the soft fingers' twists, which follow their cone edges, and the margin's
    #: torsional friction of each (m)
    twists: frozenset[tuple[int, int]] = frozenset()
    twist_coefficient: float = 0.0

    def size(self) -> dict[str, Any]:
        """Variables and constraints as IPOPT sees them (the held turn's reference is pinned, so not counted),
        and whether the turn about the object's axis is held."""
        held = self.model.component("held_reference")
        reference = set() if held is None else {id(v) for v in held.values()}
        variables = self.model.component_data_objects(pyo.Var, active=True)
        n_vars = sum(1 for v in variables if not v.fixed and id(v) not in reference)
        n_cons = sum(1 for _ in self.model.component_data_objects(pyo.Constraint, active=True))
        turn = self.model.component("held_axis_rotation")
        return {"variables": n_vars, "constraints": n_cons, "held_axis_rotation": turn is not None}

    def compile(self) -> CompiledExpressions:
        """The defined variables and eq. 14's margins as one CasADi function of the palm pose and joints, built
        on first use (:meth:`initialise`, :meth:`min_clearance`) or when called."""
        return self._compiled

    @cached_property
    def _compiled(self) -> CompiledExpressions:
        m = self.model
        inputs = [m.R_h[i, j] for i in XYZ for j in XYZ] + [m.d_h[i] for i in XYZ] + list(m.theta.values())
        margins = [c.body - c.lower for c in m.eq14_collision.values()]
        grid = self.surrogate.grid if self.surrogate is not None else None
        return CompiledExpressions(inputs, self.definitions, margins, grid)

    def surrogate_spec(self, variables: list, constraints: list) -> SurrogateSpec | None:
        """Where the backend puts the surrogate surface, by the NL file's column and row order."""
        if self.surrogate is None:
            return None
        column = {id(v): k for k, v in enumerate(variables)}
        row = {id(c): k for k, c in enumerate(constraints)}
        links = self.surrogate.links
        return SurrogateSpec(
            self.surrogate.grid,
            tuple(row[id(link.constraint)] for link in links),
            tuple(column[id(link.value)] for link in links),
            tuple(tuple(column[id(v)] for v in link.point) for link in links),  # type: ignore[misc]
            tuple(link.component for link in links),
        )

    def limit_positions(self, variables: list, constraints: list) -> tuple[np.ndarray, np.ndarray]:
        """Where the bounds of :class:`~grasptask.synthesis.feedback.Limits` sit, by the NL file's order: the
        columns of eq. 10's activations and the rows of the pads' angle constraints."""
        column = {id(v): k for k, v in enumerate(variables)}
        row = {id(c): k for k, c in enumerate(constraints)}
        m = self.model
        activations = m.act.values() if m.component("act") is not None else []  # none in the search's model
        return (
            np.array([column[id(v)] for v in activations], dtype=int),
            np.array([row[id(m.pad_facing[j])] for j in m.pad_facing], dtype=int),
        )

    def held_positions(self, variables: list) -> tuple[np.ndarray, np.ndarray] | None:
        """Where the held turn's reference variables are in ``variables``, and where the palm pose components
        they stand for are; None when the turn is free."""
        held = self.model.component("held_reference")
        if held is None:
            return None
        column = {id(v): k for k, v in enumerate(variables)}
        m = self.model
        palm = [m.d_h[i] for i in XYZ] + [m.R_h[i, j] for j in XYZ for i in XYZ]
        # a reference component with a zero coefficient (along the axis) is not in the NL file
        pairs = [(column[id(held[k])], column[id(v)]) for k, v in enumerate(palm) if id(held[k]) in column]
        return np.array([r for r, _ in pairs], dtype=int), np.array([p for _, p in pairs], dtype=int)

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
        self.initialise_forces()

    def initialise_forces(self) -> None:
        """The force-closure weights, task forces, eq. 10's cone-edge forces and activations at their initial
        values, which depend on no pose."""
        m = self.model
        for var in m.phi.values() if m.component("phi") is not None else []:
            var.set_value(1.0 / len(m.phi))
        for var in m.force.values() if m.component("force") is not None else []:  # the search's model has none
            var.set_value(0.0)
        for var in m.task_twist.values() if m.component("task_twist") is not None else []:
            var.set_value(0.0)
        if m.component("lam") is None:
            return
        for var in m.lam.values():
            var.set_value(0.1)
        for var in m.act.values():
            var.set_value(0.2)

    def set_forces(self, forces: ForceSolution) -> None:
        """A polish's warm start at the current geometry: the task forces, eq. 10's cone-edge forces and
        activations at the force problem's solution there (each within its bounds: the QPs' own tolerance may
        leave a hair outside), and eq. 4's weights from :meth:`closure_weights`. Without the weights IPOPT began
        0.1-0.5 off eq. 4 and spent its first iterations getting back."""
        m = self.model
        for var, value in zip(m.phi.values(), self.closure_weights(), strict=True):
            _set_within(var, value)
        for (a, j, i), var in m.force.items():
            _set_within(var, forces.forces[a, j, i])
        cone = forces.edge_forces.shape[-1]
        soft = sorted({j for j, _ in self.twists})
        for (a, s, j, e), var in m.lam.items():
            force = forces.edge_forces[a, s, j, e] if e < cone else forces.twist_forces[a, s, soft.index(j), e - cone]
            _set_within(var, force)
        for (a, j), var in m.task_twist.items() if m.component("task_twist") is not None else []:
            _set_within(var, forces.twists[a, soft.index(j)])
        for (a, s, q), var in m.act.items():
            _set_within(var, forces.activations[a, s, q])

    def closure_weights(self) -> np.ndarray:
        """Eq. 4's weights at the current geometry, in cell order: the weights within their bounds, summing to
        1, whose wrench sum is least (zero where the grasp closes), a little drawn to their mean so that the
        answer is unique. One small QP (quadprog)."""
        import quadprog

        m = self.model
        cells = list(m.phi.keys())
        wrenches = np.array([[pyo.value(m.l[j, e, i]) for i in XYZ] + [pyo.value(m.l_torque[j, e, i]) for i in XYZ]
                             for j, e in cells]).T  # fmt: skip
        n, floor = len(cells), m.phi[cells[0]].lb
        gram = wrenches.T @ wrenches
        tie = 1e-6 * max(float(np.trace(gram)) / n, 1e-12)
        hessian = gram + tie * np.eye(n)
        rows = np.vstack([np.ones(n), np.eye(n)])
        limits = np.r_[1.0, np.full(n, floor)]
        try:
            return quadprog.solve_qp(hessian, np.full(n, tie / n), rows.T, limits, 1)[0]
        except ValueError:  # inconsistent only by round-off: the mean, as initialise_forces has it
            return np.full(n, 1.0 / n)

    def min_clearance(self, palm_position: np.ndarray | None = None) -> float:
        """The smallest eq. 14 margin (negative: a hand point is inside the object) at the current palm pose and
        joints, or with the palm moved to ``palm_position`` first. Only the palm moves; the defined variables
        (contacts, normals) keep their old values until the next :meth:`initialise`. A model without collision
        spheres (a search route's on a hand of many, :mod:`.near_spheres`) has nothing in the way: infinity."""
        if palm_position is not None:
            for i in XYZ:
                self.model.d_h[i].set_value(float(palm_position[i]))
        return float(self._compiled.extra(self._compiled.input_values()).min(initial=np.inf))

    def geometry(self) -> GraspGeometry:
        """The contacts, cone edges and Jacobians at the current values: what the force problem holds fixed."""
        m, fingers = self.model, list(self.hand.fingers.values())
        b, edges = len(fingers), 1 + max(e for j, e, _ in m.l.index_set() if (j, e) not in self.twists)
        jacobians = tuple(
            np.array([[pyo.value(m.J[j, k, i]) for i in XYZ] for k in range(f.n_joints)]) for j, f in enumerate(fingers)
        )
        contacts = np.array([[pyo.value(m.p[j, i]) for i in XYZ] for j in range(b)])
        cones = np.array([[[pyo.value(m.l[j, e, i]) for i in XYZ] for e in range(edges)] for j in range(b)])
        if not self.twists:
            return GraspGeometry(contacts, cones, jacobians)
        normals = np.array([[pyo.value(m.n[j, i]) for i in XYZ] for j in range(b)])
        soft = {j for j, _ in self.twists}
        # a turning joint's axis is its link frame's image of the file's axis; a sliding joint feels no twist
        turns = tuple(
            np.array([0.0 if joint.sliding else self._axis(j, k, joint.axis) @ normals[j] for k, joint in
                      enumerate(f.joints)])
            for j, f in enumerate(fingers)
        )  # fmt: skip
        twists = np.array([self.twist_coefficient if j in soft else 0.0 for j in range(b)])
        return GraspGeometry(contacts, cones, jacobians, twists, normals, turns)

    def _axis(self, j: int, k: int, axis: np.ndarray) -> np.ndarray:
        """Joint ``k`` of finger ``j``'s axis in the object frame, from the link frame after it."""
        frame = np.array([[pyo.value(self.model.frame[j, k, r, c]) for c in XYZ] for r in XYZ])
        return frame @ axis

    def columns(self, variables: list, names: tuple[str, ...] = ("p", "J")) -> dict[str, dict]:
        """Where each of the components ``names`` has its variables in ``variables`` (the NL file's order), by
        index: for the search's closed-form objective."""
        column = {id(v): k for k, v in enumerate(variables)}
        return {name: {i: column[id(v)] for i, v in self.model.component(name).items()} for name in names}

    def read(self) -> dict[str, Any]:
        """The current variable values as arrays: palm pose, joints, contacts and outward normals, and Q."""
        m = self.model
        b = len(self.hand.fingers)
        return {
            "palm_rotation": np.array([[pyo.value(m.R_h[i, j]) for j in XYZ] for i in XYZ]),
            "palm_position": np.array([pyo.value(m.d_h[i]) for i in XYZ]),
            "joint_angles": np.array([pyo.value(m.theta[k]) for k in m.theta]),
            "contacts": np.array([[pyo.value(m.p[j, i]) for i in XYZ] for j in range(b)]),
            "normals": -np.array([[pyo.value(m.n[j, i]) for i in XYZ] for j in range(b)]),
            "Q": pyo.value(m.eq12_Q) if m.component("eq12_Q") is not None else float("nan"),
        }


def _pair_line(hand: GraspingHand) -> np.ndarray | None:
    """The unit line from the first pad to the second at mid-range, in the palm frame, for a two-contact hand."""
    if len(hand.fingers) != 2:
        return None
    pads = forward(hand, hand.mid_range()).contacts()[0]
    line = pads[1] - pads[0]
    length = float(np.linalg.norm(line))
    return line / length if length > 1e-9 else None


def build_model(
    hand: Hand,
    obj: ImplicitObject,
    task: TaskModel,
    settings: GraspSettings,
    bounds: SearchBounds = SearchBounds(),
    regularisation: Regularisation = Regularisation(),
    torque_axes: int | None = None,
    held_axis: tuple[np.ndarray, np.ndarray] | None = None,
) -> GraspNLP:
    """The NLP for ``hand``'s grasping fingers on ``obj`` for ``task``: :data:`EQUATIONS` in order, its forces
    searched within ``bounds``, its objective eq. 12 plus the small terms of ``regularisation``.

    ``torque_axes``: eq. 10 for the task's that many longest axes only (None: all of them, the paper's model).
    Eq. 10's blocks are half of the model's variables, and at an optimum only a few of them bind; a grasp that
    needs the others is caught by the verifier, which checks every axis
    (:class:`~grasptask.synthesis.context.SolverContext`).

    ``held_axis``: the object's axis of revolution (direction, point) about which the grasp's turn is held at
    each start's (:func:`held_axis_rotation`); None leaves it free, as the paper does."""
    grasping = hand.grasping_hand()
    n_axes = len(task.weights)
    builder = NLPBuilder(
        pyo.ConcreteModel(name="task_oriented_grasp"),
        grasping,
        surface_for(obj),
        task,
        settings,
        bounds,
        regularisation,
        range(n_axes if torque_axes is None else min(torque_axes, n_axes)),
        held_axis,
        _pair_line(grasping) if regularisation.pair_turn > 0 else None,
        contact_offsets=grasping.contact_offsets(settings.rolling_contacts),
    )
    builder.surface.attach(builder.model, builder.definitions)
    for equation in EQUATIONS:
        equation(builder)
    surrogate = builder.surface if isinstance(builder.surface, GridSurface) else None
    twists = frozenset((j, e) for j, e in builder.cells if e >= settings.cone_edges)
    return GraspNLP(builder.model, grasping, builder.definitions, surrogate, twists, builder.twist_coefficient)
