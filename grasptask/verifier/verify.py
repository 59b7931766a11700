"""The independent grasp verifier: numpy and scipy only, sharing no code with the NLP (README, "Hand, objects
and the grasp verifier").

A grasp counts as found only when :func:`verify` accepts it. Distances are Euclidean, measured against a
dense sampling of the object's surface (:class:`grasptask.objects.surface.SurfaceIndex`), not the implicit
function the NLP constrains; force closure is judged by the Ferrari-Canny metric (qhull), torque feasibility by
a linear program over contact forces in the friction cones and tendon activations, and Q is recomputed from
the contact geometry.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from grasptask.grasp.grasp import Grasp
from grasptask.grasp.settings import GraspSettings
from grasptask.hand.kinematics import HandPose, forward
from grasptask.hand.model import Hand
from grasptask.objects.surface import ImplicitObject
from grasptask.task.model import TaskModel
from grasptask.verifier.epsilon import ferrari_canny
from grasptask.verifier.fingertip import outside_distance
from grasptask.verifier.loads_lp import load_block, normal_rows, solve_loads
from grasptask.verifier.margins import friction_margin, strength_margin
from grasptask.verifier.mechanics import (
    friction_cone_edges,
    grasp_matrix,
    hand_jacobian,
    internal_forces,
    primitive_wrenches,
    task_quality,
)


@dataclass(frozen=True)
class Tolerances:
    """Every acceptance threshold of the verifier, in one place."""

    contact_distance_m: float = 1e-3  # |distance from a pad point to the surface| (a sphere's centre: minus its offset)
    joint_limit_rad: float = 1e-4  # how far a joint may sit beyond a limit
    coupling_rad: float = 1e-3  # |theta_DIP - k theta_PIP|
    rotation: float = 1e-6  # |R^T R - I| and |det R - 1|
    clearance_m: float = -1e-3  # signed distance minus radius (plus a rolling fingertip's compliance), every sphere
    pad_angle_slack_deg: float = 1.0  # on top of the configured bound
    epsilon_min: float = 1e-6  # Ferrari-Canny epsilon (torques divided by the characteristic length)
    rank_rtol: float = 1e-8  # relative singular value threshold for the rank condition of eq. 9
    effort_slack: float = 1e-6  # how far the activations the task wrenches need may exceed the margin's cap
    # how far the hand's true geometry may sink beyond its compliance: a mesh's surrogate, which the NLP holds the
    # fingertips to, misses the triangles by up to half a millimetre (0.2-0.3 mm at the mug's contacts)
    penetration_m: float = 5e-4
    # how far outside a mesh fingertip's own triangles its contact may lie (where the pad sphere fits the mesh,
    # the contact lies the compliance inside it)
    fingertip_m: float = 5e-4


@dataclass(frozen=True)
class WrenchLoad:
    """How the grasp applies one task wrench in the verifier's LP (the solution of least peak activation, one
    of many): the force each contact pushes on the object with (N, object frame), the joint torques that
    balance them (N.m, the grasping joints' order) and the actuators' activations in [0, 1]."""

    wrench: np.ndarray  # (6,): force (N) and torque (N.m) on the object
    contact_forces: np.ndarray  # (b, 3)
    joint_torques: np.ndarray  # (n,)
    activations: np.ndarray  # (actuators,)


@dataclass
class Verification:
    contact_distance_m: np.ndarray
    joint_limit_margin_deg: float
    coupling_error_deg: float
    rotation_error: float
    min_clearance_m: float
    #: how deep the hand's true collision geometry (every link, the fingertips included) sinks into the object
    penetration_m: float
    pad_angle_deg: np.ndarray
    #: how far each contact lies outside its fingertip's own collision mesh, negative inside (NaN: a sphere or
    #: capsule tip)
    fingertip_gap_m: np.ndarray
    epsilon: float
    internal_force_rank: int
    internal_force_dim: int
    torque_effort: float
    Q: float
    #: the largest scale of the task's wrenches held at the hand's real strength and mu (1: at the edge)
    strength_margin: float
    #: the smallest mu that holds every task wrench at the real strength
    friction_margin: float
    contacts: np.ndarray = field(repr=False)
    normals: np.ndarray = field(repr=False)
    failures: list[str] = field(default_factory=list)
    #: the LP's solution behind ``torque_effort``, one per task wrench (empty when some wrench is infeasible)
    loads: list[WrenchLoad] = field(default_factory=list, repr=False)

    @property
    def ok(self) -> bool:
        return not self.failures

    def record(self, fingers: list[str]) -> dict:
        """Flat columns for a table (``verify_*``), one value per finger where there is one per finger."""
        out = {"verified": self.ok, "verify_failures": ";".join(self.failures)}
        for key, value in asdict(self).items():
            if key in ("contacts", "normals", "failures", "loads"):
                continue
            if isinstance(value, np.ndarray):
                for name, v in zip(fingers, value, strict=True):
                    out[f"verify_{key}_{name}"] = float(v)
            else:
                out[f"verify_{key}"] = value
        return out


def task_targets(task: TaskModel) -> list[np.ndarray]:
    """The task's wrenches ``+-gamma_i u_i`` (eq. 10's 12 blocks)."""
    return [s * g * u for g, u in zip(task.lengths, task.axes, strict=True) for s in (1.0, -1.0)]


def _torque_effort(
    edges: np.ndarray,
    points: np.ndarray,
    jacobians: list[np.ndarray],
    hand: Hand,
    task: TaskModel,
    inward: np.ndarray | None = None,
    minimum_normal: float = 0.0,
) -> tuple[float, list[WrenchLoad]]:
    """Smallest ``t`` such that, for every task axis and both signs, contact forces inside the friction cones
    apply ``+-gamma_i u_i`` to the object with joint torques ``T J^T f = A a``, ``0 <= a <= t`` (eq. 1, 10;
    ``T`` and ``A`` are the hand's :class:`~grasptask.hand.model.Capability`: tendons or motors), and each
    contact at least ``minimum_normal`` of normal force.

    One LP over all twelve wrenches (each with its own forces and activations, sharing ``t``); infinite, with
    no loads, when some wrench cannot be applied at all."""
    block = load_block(edges, points, jacobians, hand)
    targets = task_targets(task)
    floor = (normal_rows(edges, inward, block), minimum_normal) if minimum_normal > 0 and inward is not None else None
    result = solve_loads(block, targets, scale_wrenches=False, activation_max=None, minimum_normal=floor)
    if result.status != 0:
        return float("inf"), []
    b, m, _ = edges.shape
    loads = []
    for i, w in enumerate(targets):
        x = result.x[i * block.width : (i + 1) * block.width]
        forces = np.einsum("jm,jmk->jk", x[: block.forces].reshape(b, m), edges)
        loads.append(WrenchLoad(w, forces, block.edge_torques @ x[: block.forces], x[block.forces :].copy()))
    return float(result.x[-1]), loads


def _penetration(points: np.ndarray, obj: ImplicitObject) -> float:
    """How deep the deepest of ``points`` lies inside ``obj`` (m; 0 when none does). A point is measured only
    when it could be inside: within the object's bounds, and not clearly outside the nearest of its surface
    samples; for thousands of points an exact distance each (a mesh's, from its triangles) took seconds."""
    low, high = obj.bounds()
    points = points[np.all((points >= low - NEAR_M) & (points <= high + NEAR_M), axis=1)]
    if not len(points):
        return 0.0
    index = obj.surface
    _, nearest = index.tree.query(points)
    along = ((points - index.points[nearest]) * index.normals[nearest]).sum(axis=1)
    candidates = points[along < NEAR_M]
    return float(max(0.0, -obj.signed_distance(candidates).min())) if len(candidates) else 0.0


def _fingertip_gaps(hand: Hand, pose: HandPose, contacts: np.ndarray) -> np.ndarray:
    """How far each contact lies outside its fingertip's own mesh, measured in the distal link's frame (NaN for a
    fingertip without a mesh)."""
    gaps = np.full(len(contacts), np.nan)
    for j, (name, finger) in enumerate(hand.fingers.items()):
        if finger.tip_mesh is None:
            continue
        placed = pose.fingers[name]
        rotation, origin = placed.link_rotations[0, -1], placed.joint_positions[0, finger.n_joints - 1]
        vertices, faces = finger.tip_mesh
        gaps[j] = outside_distance((rotation.T @ (contacts[j] - origin))[None], vertices[faces])[0]
    return gaps


#: a point further than this (m) outside the object's bounds, or out along its nearest sample's normal, is not in
NEAR_M = 2e-3


def verify(
    grasp: Grasp,
    hand: Hand,
    obj: ImplicitObject,
    task: TaskModel,
    settings: GraspSettings = GraspSettings(),
    tolerances: Tolerances = Tolerances(),
) -> Verification:
    """Check a grasp of ``obj`` by ``hand``'s grasping fingers for ``task``."""
    tol = tolerances
    hand = hand.grasping_hand() if set(hand.fingers) != set(hand.grasping) else hand
    q = np.asarray(grasp.joint_angles, dtype=float)
    rotation, position = np.asarray(grasp.palm_rotation, float), np.asarray(grasp.palm_position, float)
    pose = forward(hand, q, rotation, position)
    # a rolling contact is where its fingertip sphere meets the object: the surface point nearest the sphere's
    # centre, one offset (radius minus compliance) away; a fixed one is the pad point itself
    offsets = hand.contact_offsets(settings.rolling_contacts)
    rolling = offsets > 0
    reference = np.where(rolling[:, None], pose.pad_centres()[0], pose.contacts()[0])
    surface_points, outward = obj.closest_point(reference, exact=True)
    distance = np.sign(obj.g(reference)) * np.linalg.norm(reference - surface_points, axis=1) - offsets
    inward = -outward
    pad_normals = pose.pad_normals()[0]
    pad_angle = np.degrees(np.arccos(np.clip((pad_normals * inward).sum(axis=1), -1.0, 1.0)))
    margin = np.minimum(q - hand.lower, hand.upper - q).min()
    coupling = max((abs(q[d] - r * q[i] - o) for d, i, r, o in hand.couplings()), default=0.0)
    rotation_error = max(np.abs(rotation.T @ rotation - np.eye(3)).max(), abs(np.linalg.det(rotation) - 1.0))
    spheres, radii = pose.collision_spheres()
    # a rolling fingertip sinks by the compliance, and so may the rest of its distal link's skin
    sunk = [
        float(rolling[j]) * hand.compliance_m * np.array([s.link == f.n_joints - 1 for s in f.spheres], dtype=float)
        for j, f in enumerate(hand.fingers.values())
    ]
    allowance = np.concatenate([*sunk, np.zeros(len(hand.palm.radii))])
    clearance = float((obj.signed_distance(spheres[0]) - radii + allowance).min())
    penetration = _penetration(pose.skin()[0], obj)
    gaps = _fingertip_gaps(hand, pose, surface_points) if settings.rolling_contacts else np.full(len(offsets), np.nan)
    # each finger's Jacobian at its contact, the point of the distal link that touches the object
    on_finger = np.where(rolling[:, None], surface_points, pose.contacts()[0])
    jacobians = [jacobian[0] for jacobian in pose.jacobians_at(on_finger[None])]
    G = grasp_matrix(surface_points)
    J = hand_jacobian(jacobians)
    A = internal_forces(G)
    singular = np.linalg.svd(J.T @ A, compute_uv=False) if A.size else np.zeros(0)
    rank = int((singular > tol.rank_rtol * max(1.0, singular.max(initial=0.0))).sum())
    # cones oriented by each pad's own tangent (the distal phalanx's axis for a human finger), as eq. 24
    # attaches them to the finger frame
    mu, tangents = settings.friction_coefficient, pose.pad_tangents()[0]
    edges = friction_cone_edges(inward, mu, settings.cone_edges, tangents)
    scale = obj.characteristic_length
    epsilon = ferrari_canny(primitive_wrenches(surface_points, edges, obj.centre, scale))
    Q, _ = task_quality(G, J, task.axes, task.weights)
    # the margin: every task wrench held in cones of k mu, with activations at most a_max and each contact
    # pressing with at least the minimum normal force
    held = friction_cone_edges(inward, settings.friction_scale * mu, settings.cone_edges, tangents)
    effort, loads = _torque_effort(held, surface_points, jacobians, hand, task, inward, settings.min_normal_force_n)
    checks = {
        "contact_distance": np.abs(distance).max() <= tol.contact_distance_m,
        "joint_limits": margin >= -tol.joint_limit_rad,
        "coupling": coupling <= tol.coupling_rad,
        "palm_rotation": rotation_error <= tol.rotation,
        "clearance": clearance >= tol.clearance_m,
        # a real fingertip gives by its compliance and no more (the paper's fixed pad point may sink further)
        "penetration": not settings.rolling_contacts or penetration <= hand.compliance_m + tol.penetration_m,
        "pad_angle": pad_angle.max() <= settings.pad_angle_max_deg + tol.pad_angle_slack_deg,
        # a mesh fingertip's contact lies on the real tip, not in the air beside it, where only the sphere fitted
        # to its pad reaches (a contact inside the tip is the tip pressing deeper: the penetration check's)
        "fingertip_contact": bool(np.all(np.nan_to_num(gaps, nan=-np.inf) <= tol.fingertip_m)),
        "force_closure": epsilon > tol.epsilon_min,
        "rank_condition": A.size > 0 and rank == A.shape[1],
        "torque_feasibility": effort <= settings.activation_cap(hand.capability.kind) + tol.effort_slack,
        "quality": bool(np.isfinite(Q)),
    }
    strength = friction = float("nan")
    if all(checks.values()):  # the margins of a grasp that holds; each costs LPs, so of those only
        targets = task_targets(task)
        strength = strength_margin(load_block(edges, surface_points, jacobians, hand), targets)
        known = settings.friction_scale * mu if effort <= 1.0 else None  # held at full strength in k mu cones
        friction = friction_margin(
            inward, tangents, surface_points, jacobians, hand, mu, settings.cone_edges, targets, known
        )

    return Verification(
        contact_distance_m=distance,
        joint_limit_margin_deg=float(np.degrees(margin)),
        coupling_error_deg=float(np.degrees(coupling)),
        rotation_error=float(rotation_error),
        min_clearance_m=clearance,
        penetration_m=penetration,
        pad_angle_deg=pad_angle,
        fingertip_gap_m=gaps,
        epsilon=epsilon,
        internal_force_rank=rank,
        internal_force_dim=int(A.shape[1]),
        torque_effort=effort,
        Q=float(Q),
        strength_margin=strength,
        friction_margin=friction,
        contacts=surface_points,
        normals=outward,
        failures=[name for name, passed in checks.items() if not passed],
        loads=loads,
    )
