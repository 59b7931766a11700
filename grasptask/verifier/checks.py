"""The verifier's checks, one small class each, in the style of mink's limits: each reads the grasp as
:class:`Inspection` measured it once, and returns whether it passes and the figures a table records. Their order
is the order failures are listed in."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from functools import cached_property
from typing import Any, ClassVar

import numpy as np

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand.hand_model import Hand
from grasptask.hand.kinematics import HandPose
from grasptask.objects.surface import ImplicitObject
from grasptask.task.task_model import TaskModel
from grasptask.verifier.epsilon import ferrari_canny
from grasptask.verifier.fingertip import outside_distance
from grasptask.verifier.loads_lp import contact_forces, load_block, normal_rows, solve_loads
from grasptask.verifier.mechanics import (
    friction_cone_edges,
    grasp_matrix,
    hand_jacobian,
    internal_forces,
    primitive_wrenches,
    task_quality,
)
from grasptask.verifier.soft_contacts import Twists
from grasptask.verifier.verification import Tolerances, WrenchLoad

#: a point further than this (m) outside the object's bounds, or out along its nearest sample's normal, is not in
NEAR_M = 2e-3


@dataclass(frozen=True)
class Inspection:
    """A grasp as the checks read it, measured once: the hand's pose at its joint angles, and where each contact
    meets the object. A rolling contact is where its fingertip sphere meets the object: the surface point nearest
    the sphere's centre, one offset (radius minus compliance) away; a fixed one is the pad point itself."""

    hand: Hand  # the grasping fingers only
    obj: ImplicitObject
    task: TaskModel
    settings: GraspSettings
    tolerances: Tolerances
    q: np.ndarray
    palm_rotation: np.ndarray
    pose: HandPose
    offsets: np.ndarray  # per finger: the fingertip sphere's centre to the surface (0: a fixed contact)
    reference: np.ndarray  # per finger: the sphere's centre (rolling) or the pad point (fixed)
    contacts: np.ndarray  # the surface points nearest ``reference``
    outward: np.ndarray  # the surface's outward normals there

    @property
    def rolling(self) -> np.ndarray:
        return self.offsets > 0

    @property
    def inward(self) -> np.ndarray:
        return -self.outward

    @cached_property
    def jacobians(self) -> list[np.ndarray]:
        """Each finger's Jacobian at its contact, the point of the distal link that touches the object."""
        on_finger = np.where(self.rolling[:, None], self.contacts, self.pose.contacts()[0])
        return [jacobian[0] for jacobian in self.pose.jacobians_at(on_finger[None])]

    @cached_property
    def grasp_matrix(self) -> np.ndarray:
        return grasp_matrix(self.contacts)

    @cached_property
    def hand_jacobian(self) -> np.ndarray:
        return hand_jacobian(self.jacobians)

    @cached_property
    def tangents(self) -> np.ndarray:
        """Each pad's own tangent (the distal phalanx's axis for a human finger), which orients its friction cone
        as eq. 24 attaches it to the finger frame."""
        return self.pose.pad_tangents()[0]

    def cone_edges(self, friction_scale: float = 1.0) -> np.ndarray:
        mu = friction_scale * self.settings.friction_coefficient
        return friction_cone_edges(self.inward, mu, self.settings.cone_edges, self.tangents)

    def twists(self, friction_scale: float = 1.0) -> Twists:
        """The flat pads' soft contacts (the grasp config's torsional friction, times ``friction_scale`` as
        the cones' mu); every other contact a point contact."""
        flat = np.array([f.pad.flat for f in self.hand.fingers.values()], dtype=bool)
        coefficients = np.where(flat, friction_scale * self.settings.torsional_friction_m, 0.0)
        return Twists(self.inward, coefficients, [t[0] for t in self.pose.turn_jacobians()])


Figures = dict[str, Any]


class Check(ABC):
    """One acceptance test of the verifier."""

    name: ClassVar[str]

    @abstractmethod
    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        """Whether ``s`` passes, and the figures a table records (the fields of a Verification)."""


class ContactDistance(Check):
    """Each contact lies on the surface: its distance from it (a sphere's centre: minus its offset)."""

    name = "contact_distance"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        sign = np.sign(s.obj.g(s.reference))
        distance = sign * np.linalg.norm(s.reference - s.contacts, axis=1) - s.offsets
        return bool(np.abs(distance).max() <= s.tolerances.contact_distance_m), {"contact_distance_m": distance}


def _sliding(hand: Hand) -> np.ndarray:
    """Which joints slide (a jaw's, in metres), in ``hand.joint_names`` order."""
    return np.array([j.sliding for f in hand.fingers.values() for j in f.joints], dtype=bool)


def _in_degrees(values: np.ndarray, turning: np.ndarray, worst: Any) -> float:
    """The worst of the turning joints' ``values`` in degrees (a sliding joint's are metres; nan: none turns)."""
    return float(np.degrees(worst(values[turning]))) if turning.any() else float("nan")


class JointLimits(Check):
    """Each joint within its limits (a turning joint's in radians, a sliding joint's in metres)."""

    name = "joint_limits"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        sliding = _sliding(s.hand)
        margin = np.minimum(s.q - s.hand.lower, s.hand.upper - s.q)
        tolerance = np.where(sliding, s.tolerances.joint_limit_m, s.tolerances.joint_limit_rad)
        figure = _in_degrees(margin, ~sliding, np.min)
        return bool((margin >= -tolerance).all()), {"joint_limit_margin_deg": figure}


class Coupling(Check):
    """Coupled joints keep their ratio: ``|theta_DIP - k theta_PIP - offset|`` (a jaw's mimic in metres)."""

    name = "coupling"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        q, sliding = s.q, _sliding(s.hand)
        pairs = s.hand.couplings()
        errors = np.array([abs(q[d] - r * q[i] - o) for d, i, r, o in pairs])
        slides = np.array([sliding[d] for d, _, _, _ in pairs], dtype=bool)
        tolerance = np.where(slides, s.tolerances.coupling_m, s.tolerances.coupling_rad)
        figure = _in_degrees(errors, ~slides, np.max) if pairs else 0.0
        return bool((errors <= tolerance).all()), {"coupling_error_deg": figure}


class PalmRotation(Check):
    """The palm's rotation is one: ``|R^T R - I|`` and ``|det R - 1|``."""

    name = "palm_rotation"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        r = s.palm_rotation
        error = max(np.abs(r.T @ r - np.eye(3)).max(), abs(np.linalg.det(r) - 1.0))
        return bool(error <= s.tolerances.rotation), {"rotation_error": float(error)}


class Clearance(Check):
    """Every collision sphere clears the object; a rolling fingertip sinks by the compliance, and so may the rest
    of its distal link's skin."""

    name = "clearance"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        spheres, radii = s.pose.collision_spheres()
        sunk = [
            float(s.rolling[j]) * s.hand.compliance_m * np.array([p.link == f.n_joints - 1 for p in f.spheres], float)
            for j, f in enumerate(s.hand.fingers.values())
        ]
        allowance = np.concatenate([*sunk, np.zeros(len(s.hand.palm.radii))])
        clearance = float((s.obj.signed_distance(spheres[0]) - radii + allowance).min())
        return bool(clearance >= s.tolerances.clearance_m), {"min_clearance_m": clearance}


class Penetration(Check):
    """The hand's true collision geometry (every link, the fingertips included) sinks into the object by the
    fingertip's compliance at most: a real fingertip gives by that and no more (the paper's fixed pad point may
    sink further)."""

    name = "penetration"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        depth = _penetration(s.pose.skin()[0], s.obj)
        passed = not s.settings.rolling_contacts or depth <= s.hand.compliance_m + s.tolerances.penetration_m
        return bool(passed), {"penetration_m": depth}


class PadAngle(Check):
    """Each pad faces the object: the angle between its normal and the surface's inward one."""

    name = "pad_angle"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        cosine = np.clip((s.pose.pad_normals()[0] * s.inward).sum(axis=1), -1.0, 1.0)
        angle = np.degrees(np.arccos(cosine))
        bound = s.settings.pad_angle_max_deg + s.tolerances.pad_angle_slack_deg
        return bool(angle.max() <= bound), {"pad_angle_deg": angle}


class FingertipContact(Check):
    """A mesh or box fingertip's contact lies on the real tip, not in the air beside it, where only the sphere
    fitted to its pad reaches, or off its flat face (a contact inside the tip is the tip pressing deeper: the
    penetration check's)."""

    name = "fingertip_contact"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        gaps = np.full(len(s.offsets), np.nan)
        if s.settings.rolling_contacts:
            gaps = _fingertip_gaps(s.hand, s.pose, s.contacts)
        passed = bool(np.all(np.nan_to_num(gaps, nan=-np.inf) <= s.tolerances.fingertip_m))
        return passed, {"fingertip_gap_m": gaps}


class ForceClosure(Check):
    """The Ferrari-Canny epsilon of the contacts' friction cones (torques over the characteristic length)."""

    name = "force_closure"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        centre, length = s.obj.centre, s.obj.characteristic_length
        wrenches = primitive_wrenches(s.contacts, s.cone_edges(), centre, length).reshape(-1, 6)
        twists = s.twists().wrenches(s.contacts, centre, length).reshape(-1, 6)
        epsilon = ferrari_canny(np.vstack([wrenches, twists]))
        return bool(epsilon > s.tolerances.epsilon_min), {"epsilon": epsilon}


class RankCondition(Check):
    """Eq. 9: the fingers can squeeze in every internal-force direction, ``rank(J^T A)`` full. Over the contact
    forces only: a soft contact's twist is friction, which the fingers hold as they hold a tangential force, and a
    gripper's sliding jaws could not squeeze a twist at all."""

    name = "rank_condition"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        A = internal_forces(s.grasp_matrix)
        singular = np.linalg.svd(s.hand_jacobian.T @ A, compute_uv=False) if A.size else np.zeros(0)
        rank = int((singular > s.tolerances.rank_rtol * max(1.0, singular.max(initial=0.0))).sum())
        passed = A.size > 0 and rank == A.shape[1]
        return bool(passed), {"internal_force_rank": rank, "internal_force_dim": int(A.shape[1])}


class TorqueFeasibility(Check):
    """Every task wrench held in cones of ``friction_scale`` mu, with activations within the margin's cap and
    each contact pressing with at least the minimum normal force."""

    name = "torque_feasibility"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        scale = s.settings.friction_scale
        effort, loads = torque_effort(
            s.cone_edges(scale), s.contacts, s.jacobians, s.hand, s.task, s.inward, s.settings.min_normal_force_n,
            s.twists(scale),
        )  # fmt: skip
        passed = effort <= s.settings.activation_cap(s.hand.capability.kind) + s.tolerances.effort_slack
        return bool(passed), {"torque_effort": effort, "loads": loads}


class Quality(Check):
    """Q, recomputed from the contact geometry, is a number. A soft contact's twist about its normal is one more
    force the contacts may apply, and its joint torques count in Q."""

    name = "quality"

    def judge(self, s: Inspection) -> tuple[bool, Figures]:
        twists = s.twists()
        G = np.hstack([s.grasp_matrix, twists.grasp_columns()])
        J = np.vstack([s.hand_jacobian, twists.torque_rows([f.n_joints for f in s.hand.fingers.values()])])
        Q, _ = task_quality(G, J, s.task.axes, s.task.weights)
        return bool(np.isfinite(Q)), {"Q": float(Q)}


#: every check, in the order failures are listed
CHECKS: tuple[Check, ...] = (
    ContactDistance(),
    JointLimits(),
    Coupling(),
    PalmRotation(),
    Clearance(),
    Penetration(),
    PadAngle(),
    FingertipContact(),
    ForceClosure(),
    RankCondition(),
    TorqueFeasibility(),
    Quality(),
)


def task_targets(task: TaskModel) -> list[np.ndarray]:
    """The task's wrenches ``+-gamma_i u_i`` (eq. 10's 12 blocks)."""
    return [s * g * u for g, u in zip(task.lengths, task.axes, strict=True) for s in (1.0, -1.0)]


def torque_effort(
    edges: np.ndarray,
    points: np.ndarray,
    jacobians: list[np.ndarray],
    hand: Hand,
    task: TaskModel,
    inward: np.ndarray | None = None,
    minimum_normal: float = 0.0,
    twists: Twists | None = None,
) -> tuple[float, list[WrenchLoad]]:
    """Smallest ``t`` such that, for every task axis and both signs, contact forces inside the friction cones
    apply ``+-gamma_i u_i`` to the object with joint torques ``T J^T f = A a``, ``0 <= a <= t`` (eq. 1, 10;
    ``T`` and ``A`` are the hand's :class:`~grasptask.hand.hand_model.Capability`: tendons or motors), and each
    contact at least ``minimum_normal`` of normal force; a soft contact may twist too (``twists``).

    One LP over all twelve wrenches (each with its own forces and activations, sharing ``t``); infinite, with
    no loads, when some wrench cannot be applied at all."""
    block = load_block(edges, points, jacobians, hand, twists)
    targets = task_targets(task)
    floor = (normal_rows(edges, inward, block), minimum_normal) if minimum_normal > 0 and inward is not None else None
    result = solve_loads(block, targets, scale_wrenches=False, activation_max=None, minimum_normal=floor)
    if result.status != 0:
        return float("inf"), []
    loads = []
    for i, w in enumerate(targets):
        x = result.x[i * block.width : (i + 1) * block.width]
        forces = contact_forces(edges, block, x)
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
