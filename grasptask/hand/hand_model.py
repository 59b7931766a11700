"""A hand as plain data: fingers as serial chains of revolute (or sliding) joints from the palm, each with its collision
spheres, its fingertip pad and its force capability, whatever file it came from (YAML, URDF, MJCF)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Joint:
    """A revolute joint. Its frame sits at ``offset`` in the frame of the link before it (the palm's for a
    finger's first joint), turned by ``rotation`` (None: not turned); the joint then rotates about ``axis``
    (in its own frame), and the link after it moves with that frame. A ``sliding`` joint (a URDF's prismatic, a
    gripper's jaw) moves the link along ``axis`` instead, by its value in metres; its effort is a force (N)."""

    name: str
    axis: np.ndarray
    lower: float  # rad
    upper: float  # rad
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))  # m
    rotation: np.ndarray | None = None
    coupled_to: str | None = None
    ratio: float = 1.0
    coupling_offset: float = 0.0  # rad: q = ratio * q_coupled_to + coupling_offset
    #: this joint is ``coupled_to`` itself, repeated in a second finger: one joint of the hand file on the way to
    #: two fingertips (a spread shared by the ring and little fingers), one motor and one angle
    shared: bool = False
    sliding: bool = False
    #: its speed limit (rad/s, or m/s), where the hand file or its YAML says it; no judge uses it yet
    velocity: float | None = None

    @property
    def file_name(self) -> str:
        """The joint's name in the hand file: a shared joint's copy answers to its original."""
        return self.coupled_to if self.shared and self.coupled_to is not None else self.name


@dataclass(frozen=True)
class Sphere:
    """A collision sphere fixed to the link after joint ``link`` of its finger, ``center`` in that link's frame."""

    link: int
    center: np.ndarray
    radius: float


#: how far a fingertip gives at a contact when its file does not say (m): a rigid robot fingertip's rubber skin
DEFAULT_COMPLIANCE_M = 0.5e-3


@dataclass(frozen=True)
class Pad:
    """The fingertip pad in the frame of the finger's last link: the pad's home point, its outward normal there,
    and the direction the first friction-cone edge follows (the finger's own frame, as in eq. 24).

    ``radius`` is the fingertip's surface about the pad, a sphere centred ``radius`` behind the point along the
    normal, over which the contact rolls; 0 keeps the contact at the point (the paper's model). ``fit_error_m``
    is how far a mesh fingertip's surface lies from that sphere (RMS), 0 for a sphere or capsule tip, and
    ``roll_max_deg`` how far from the pad normal the contact may roll before the sphere leaves the fingertip's
    own mesh by more than it gives (90 for a sphere or capsule tip, which the sphere is).

    A ``flat`` pad is a flat face (a box fingertip's), ``point`` its middle: the contact stays there and the face
    lies on the surface, its normal the surface's, where a sphere fitted to it would touch at one point and tilt
    the face's edges into the object. ``half_extents`` (m) is the face's size about the point, along the tangent
    and across it."""

    point: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    radius: float = 0.0
    fit_error_m: float = 0.0
    roll_max_deg: float = 90.0
    flat: bool = False
    half_extents: tuple[float, float] = (0.0, 0.0)

    @property
    def across(self) -> np.ndarray:
        """The face's second in-plane direction, normal x tangent: with the tangent, the axes a flat pad's
        face must keep in the surface's tangent plane."""
        across = np.cross(self.normal, self.tangent)
        return across / max(float(np.linalg.norm(across)), 1e-300)

    @property
    def centre(self) -> np.ndarray:
        """The centre of the fingertip's sphere, in the last link's frame."""
        return self.point - self.radius * self.normal


@dataclass(frozen=True)
class Capability:
    """The joint torques a hand can produce (eq. 1 and 10): ``T tau = A a`` with ``0 <= a <= 1``.

    ``transmission`` ``T`` (r x joints) maps joint torques onto what the actuators carry: the identity for a
    human hand, whose tendons act on every joint, and for a robot with a motor per joint; one row for a motor
    driving a joint and the joints that mimic it, in whatever finger they are. ``torque_map`` ``A``
    (r x actuators) is what a fully active actuator gives: ``M P`` for tendons, ``[E, -E]`` for motors with
    efforts ``E`` (a motor pushes both ways, as two one-sided actuators)."""

    kind: str  # "tendons" or "motors"
    actuators: tuple[str, ...]
    torque_map: np.ndarray
    transmission: np.ndarray

    @classmethod
    def tendons(cls, names: tuple[str, ...], moment_arms: np.ndarray, max_forces: np.ndarray) -> Capability:
        """Muscles with moment arms ``M`` (joints x muscles, m) and maximal forces ``P`` (N)."""
        return cls("tendons", names, moment_arms * max_forces, np.eye(moment_arms.shape[0]))

    @classmethod
    def motors(
        cls, names: tuple[str, ...], efforts: np.ndarray, transmission: np.ndarray, directions: np.ndarray | None = None
    ) -> Capability:
        """One motor per name, each limited to ``|force| <= effort`` (N.m, or N), pushing the rows of
        ``transmission`` along its column of ``directions`` (rows x motors; the identity, a motor per row, unless
        given: a motor on a fixed tendon pulls every joint the tendon passes, by its coefficient)."""
        directions = np.eye(len(names)) if directions is None else np.asarray(directions, dtype=float)
        both = np.hstack([directions * efforts, -directions * efforts])
        return cls("motors", tuple(f"{n}+" for n in names) + tuple(f"{n}-" for n in names), both, transmission)

    @property
    def independent_motors(self) -> bool:
        """Motors each driving its own transmission row alone, pushing both ways (``A = [E, -E]``, E diagonal):
        the form whose force limits are ``|T tau| <= E`` row by row."""
        if self.kind != "motors":
            return False
        rows, count = self.torque_map.shape[0], self.torque_map.shape[1] // 2
        push = self.torque_map[:, :count]
        return rows == count and np.allclose(push, np.diag(np.diag(push)))

    @classmethod
    def combined(cls, parts: list[Capability]) -> Capability:
        """The capabilities of consecutive groups of joints (the fingers), side by side."""
        if not parts:
            return cls("none", (), np.zeros((0, 0)), np.zeros((0, 0)))
        kinds = {p.kind for p in parts}
        return cls(
            kinds.pop() if len(kinds) == 1 else "mixed",
            tuple(a for p in parts for a in p.actuators),
            _block_diagonal([p.torque_map for p in parts]),
            _block_diagonal([p.transmission for p in parts]),
        )

    def subset(self, columns: list[int]) -> Capability:
        """The capability of the joints ``columns`` only (the grasping fingers'): a transmission row that also
        drives other joints keeps its limit, for those carry no load; actuators no kept row uses are dropped."""
        transmission = self.transmission[:, columns]
        rows = np.flatnonzero(np.abs(transmission).sum(axis=1))
        used = np.flatnonzero(np.abs(self.torque_map[rows]).sum(axis=0))
        return Capability(
            self.kind,
            tuple(self.actuators[q] for q in used),
            self.torque_map[np.ix_(rows, used)],
            transmission[rows],
        )


def _block_diagonal(blocks: list[np.ndarray]) -> np.ndarray:
    rows, cols = sum(b.shape[0] for b in blocks), sum(b.shape[1] for b in blocks)
    out = np.zeros((rows, cols))
    r = c = 0
    for block in blocks:
        out[r : r + block.shape[0], c : c + block.shape[1]] = block
        r, c = r + block.shape[0], c + block.shape[1]
    return out


@dataclass(frozen=True)
class Skin:
    """Points on the true collision surface of the link after joint ``link`` of its finger, in that link's frame
    (:mod:`grasptask.hand.skin`)."""

    link: int
    points: np.ndarray


@dataclass(frozen=True)
class Finger:
    name: str
    joints: tuple[Joint, ...]
    spheres: tuple[Sphere, ...]
    pad: Pad
    tip: np.ndarray  # the fingertip's end, in the last link's frame (for drawing the chain)
    radius: float  # the links' radius, for drawing
    skin: tuple[Skin, ...] = ()
    #: a mesh fingertip's own collision mesh (vertices in the last link's frame, faces), which its pad sphere
    #: stands for: the verifier measures each contact against it
    tip_mesh: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def lower(self) -> np.ndarray:
        return np.array([j.lower for j in self.joints])

    @property
    def upper(self) -> np.ndarray:
        return np.array([j.upper for j in self.joints])


@dataclass(frozen=True)
class Palm:
    points: np.ndarray  # (k, 3) collision sphere centres in the palm frame
    radii: np.ndarray  # (k,)
    skin: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # its true collision surface, sampled


@dataclass(frozen=True)
class Hand:
    name: str
    fingers: dict[str, Finger]
    palm: Palm
    grasping: tuple[str, ...]
    #: what the joints (in :attr:`joint_names` order) can carry: one description for the NLP and the verifier
    capability: Capability
    sources: dict[str, str] = field(default_factory=dict)
    #: the approach frame in the palm frame (z towards the object, as the starts' palm normal); None: the palm's
    approach: np.ndarray | None = None
    #: the URDF or MJCF file the hand was read from, and its palm link: the physics check simulates that file's
    #: own geometry (None: the project's own model, as for the human hand)
    model_file: Path | None = None
    palm_link: str | None = None
    #: how far each fingertip may give at a contact (m): its sphere's centre sits its radius minus this from
    #: the object's surface, and no link may sink deeper than this into the object
    compliance_m: float = DEFAULT_COMPLIANCE_M
    #: each finger's fingertip link in the hand file, and how far the spheres covering each mesh link reach
    #: outside its mesh (m), by link
    fingertip_links: dict[str, str] = field(default_factory=dict)
    cover_reach_m: dict[str, float] = field(default_factory=dict)
    #: the hand file's joints before the palm (a wrist), each held at this angle (rad): the palm moves with them
    held_joints: dict[str, float] = field(default_factory=dict)
    #: links of the hand file whose inertia breaks A + B >= C, which the physics check balances
    unbalanced_inertia: tuple[str, ...] = ()
    #: where each motor's effort came from, by its joint: "file", or the hand YAML's key that set it
    effort_sources: dict[str, str] = field(default_factory=dict)

    def contact_offsets(self, rolling: bool = True) -> np.ndarray:
        """Per finger, the distance from the fingertip sphere's centre to the surface at a contact: its radius
        minus the compliance; 0 where the contact stays at the pad point (a pad without a sphere, or
        ``rolling`` off, the paper's model)."""
        radii = np.array([f.pad.radius for f in self.fingers.values()])
        return np.where(rolling & (radii > 0), radii - self.compliance_m, 0.0)

    def pad_angle_limits(self, cap_deg: float) -> np.ndarray:
        """Per finger, how far (deg) its pad may turn from the object's inward normal: ``cap_deg`` (the grasp
        settings'), or less where a mesh fingertip's pad sphere leaves the mesh sooner."""
        return np.minimum(cap_deg, [f.pad.roll_max_deg for f in self.fingers.values()])

    @property
    def joint_names(self) -> list[str]:
        return [j.name for f in self.fingers.values() for j in f.joints]

    @property
    def n_joints(self) -> int:
        return sum(f.n_joints for f in self.fingers.values())

    @property
    def file_joint_names(self) -> list[str]:
        """Each column's joint as the hand file names it: a joint shared by two fingers appears once per finger."""
        return [j.file_name for f in self.fingers.values() for j in f.joints]

    def shared_joints(self) -> dict[str, list[str]]:
        """The hand file's joints that move two or more fingers, with the fingers they move."""
        moved: dict[str, list[str]] = {}
        for finger in self.fingers.values():
            for joint in finger.joints:
                moved.setdefault(joint.file_name, []).append(finger.name)
        return {name: fingers for name, fingers in moved.items() if len(fingers) > 1}

    def slices(self) -> dict[str, slice]:
        """Each finger's columns in a joint vector ordered as :attr:`joint_names`."""
        out, start = {}, 0
        for name, finger in self.fingers.items():
            out[name] = slice(start, start + finger.n_joints)
            start += finger.n_joints
        return out

    def subset(self, names: Iterable[str]) -> Hand:
        """The same hand with only the named fingers (in the given order), e.g. the grasping fingers."""
        names = list(names)
        unknown = [n for n in names if n not in self.fingers]
        if unknown:
            raise KeyError(f"no finger '{unknown[0]}' in hand '{self.name}'")
        slices = self.slices()
        columns = [c for n in names for c in range(slices[n].start, slices[n].stop)]
        fingers = {n: self.fingers[n] for n in names}
        capability = self.capability.subset(columns)
        return replace(self, fingers=fingers, grasping=tuple(names), capability=capability)

    def with_grasping(self, names: Iterable[str]) -> Hand:
        """The same hand grasping with the fingers ``names`` (``KeyError`` naming one it does not have)."""
        names = tuple(names)
        for name in names:
            if name not in self.fingers:
                raise KeyError(name)
        return replace(self, grasping=names)

    def grasping_hand(self) -> GraspingHand:
        """The hand of its grasping fingers only, the one the NLP and the verifier work on."""
        part = self.subset(self.grasping)
        return GraspingHand(**{f.name: getattr(part, f.name) for f in fields(part)})

    @property
    def lower(self) -> np.ndarray:
        return np.concatenate([f.lower for f in self.fingers.values()])

    @property
    def upper(self) -> np.ndarray:
        return np.concatenate([f.upper for f in self.fingers.values()])

    def mid_range(self) -> np.ndarray:
        """Joint angles halfway between the limits, with the coupling applied."""
        return self.posture(0.5)

    def posture(self, fraction: float) -> np.ndarray:
        """Every joint ``fraction`` of its range from its lower limit, with the coupling applied; for hand files
        whose lower limits are the extended fingers, a small fraction is an open hand."""
        return self.apply_coupling(self.lower + fraction * (self.upper - self.lower))

    def couplings(self) -> list[tuple[int, int, float, float]]:
        """``(dependent, independent, ratio, offset)`` joint indices and values:
        ``q[dependent] = ratio * q[independent] + offset``, among the joints of these fingers."""
        index = {n: i for i, n in enumerate(self.joint_names)}
        out = []
        for finger in self.fingers.values():
            for joint in finger.joints:
                if joint.coupled_to is not None and joint.coupled_to in index:
                    out.append((index[joint.name], index[joint.coupled_to], joint.ratio, joint.coupling_offset))
        return out

    def apply_coupling(self, q: np.ndarray) -> np.ndarray:
        q = np.array(q, dtype=float, copy=True)
        for dependent, independent, ratio, offset in self.couplings():
            q[..., dependent] = ratio * q[..., independent] + offset
        return q


@dataclass(frozen=True)
class GraspingHand(Hand):
    """A hand of its grasping fingers only (:meth:`Hand.grasping_hand`): the one type the NLP's model and the
    verifier take, so that neither has to guess which fingers grasp."""

    def __post_init__(self) -> None:
        if list(self.grasping) != list(self.fingers):
            raise ValueError(f"a grasping hand grasps with all its fingers ({', '.join(self.fingers)})")

    def grasping_hand(self) -> GraspingHand:
        return self
