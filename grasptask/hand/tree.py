"""A hand file's kinematic tree, and the hand it describes.

The URDF and MJCF loaders only parse: each gives a :class:`Tree` of links (with their collision spheres) and
joints (with their origins, axes, limits, efforts and mimic relations). :func:`hand_from_tree` then makes the
project's :class:`~grasptask.hand.hand_model.Hand` from it, the same way for both formats:

- the palm is the root link (or ``palm_link``); links fixed to it are the palm's collision geometry;
- fingertips are the last link of each chain from the palm that carries collision geometry, behind at least
  one revolute or prismatic joint (or the named ``fingertips``); each finger is the chain of those joints from
  the palm to its tip, fixed joints folded into the next joint's origin; a prismatic joint slides its link (a
  gripper's jaw), and its effort is a force;
- the pad is on the tip's sphere (for a mesh tip, a sphere fitted to the surface that faces the way the
  finger closes: :mod:`grasptask.hand.pad_fit`), facing the way the tip moves as the last joint closes the
  finger, and the first friction-cone edge follows the distal link, from its joint to the tip; the sphere that
  holds the pad is the contact surface, over which the contact rolls, not a collision sphere; a box tip's pad,
  and a mesh tip's whose pad is flat, is its flat face, which lies on the surface; a sliding jaw's pad faces the
  other jaws;
- the approach direction for the starts runs from the palm's origin to the pads' centroid at mid-range;
- each motor limits ``|tau| <= effort``; a joint that mimics another shares its motor and its limit;
- a joint on the way to two fingertips (a spread, a palm arch) is in each of their chains, repeated as
  ``<joint>@<finger>`` and coupled one to one: one angle, one motor, one torque limit.

Choices where the files allow more than the NLP can take: planar and floating joints are refused;
a continuous joint is a revolute joint over one turn, [-pi, pi]; links behind a movable joint that leads to no
fingertip are left out.
"""

from __future__ import annotations

import fnmatch
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from grasptask.errors import BadInputError
from grasptask.hand.hand_model import DEFAULT_COMPLIANCE_M, Capability, Finger, Hand, Joint, Pad, Palm, Skin, Sphere
from grasptask.hand.kinematics import forward
from grasptask.hand.mesh_orientation import outward
from grasptask.hand.pad_fit import NoPadError, box_pad, boxes_mesh, fit_pad, flat_face, motion, roll_limit_deg
from grasptask.hand.palm import MOVING, branching_link, fixed_links, fixed_to_palm, held_joints

#: how far over a mesh tip's pad sphere the contact may roll from the pad's home point (the pad-angle limit)
PAD_ROLL_DEG = 45.0
#: how far outside a mesh tip's own mesh a contact on its pad sphere may lie (it sits the compliance inside where
#: the sphere fits): the triangles and the sphere fitted to them differ by their fit error (0.1-0.3 mm RMS)
PAD_FOLLOW_SLACK_M = 0.5e-3


@dataclass
class TreeLink:
    name: str
    #: collision spheres (centre in the link's frame, radius), and whether one came from a sphere or capsule
    spheres: list[tuple[np.ndarray, float]] = field(default_factory=list)
    rounded: list[tuple[np.ndarray, float]] = field(default_factory=list)
    skin: list[np.ndarray] = field(default_factory=list)  # points on each collision shape, in the link's frame
    meshes: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)  # (vertices in its frame, faces)
    cover_reach_m: float = 0.0  # how far the spheres of its meshes reach outside them
    boxes: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)  # (half sizes, 4 x 4 frame)

    def add(self, shape: Shape) -> None:
        self.spheres += shape.spheres
        self.skin.append(shape.skin)
        if shape.rounded:
            self.rounded += shape.spheres
        if shape.box is not None:
            self.boxes.append(shape.box)
        if shape.mesh is not None:
            self.meshes.append(shape.mesh)
            self.cover_reach_m = max(self.cover_reach_m, shape.reach_m)


@dataclass
class Shape:
    """One collision geometry of a link, as the loaders read it, in the link's frame."""

    spheres: list[tuple[np.ndarray, float]]
    skin: np.ndarray  # points on its surface
    rounded: bool = False  # a sphere or capsule: a fingertip's shape
    mesh: tuple[np.ndarray, np.ndarray] | None = None  # (vertices, faces) of a mesh
    reach_m: float = 0.0  # how far its spheres reach outside it
    box: tuple[np.ndarray, np.ndarray] | None = None  # a box's half sizes and its frame: a flat pad's shape


@dataclass
class TreeJoint:
    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray  # 4 x 4: the joint frame in the parent link's frame
    axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    lower: float | None = None
    upper: float | None = None
    effort: float | None = None
    mimic: tuple[str, float, float] | None = None  # (joint, multiplier, offset)
    velocity: float | None = None  # its speed limit (rad/s, m/s), where the file says it


@dataclass
class TreeTendon:
    """A fixed tendon a motor drives: its length is ``sum(c_j q_j)`` over its joints, so a force ``f`` on it
    gives joint ``j`` the torque ``c_j f``."""

    name: str
    coefficients: dict[str, float]
    effort: float | None = None  # the largest force its motor gives (N, or N.m per unit coefficient)


@dataclass
class Tree:
    links: dict[str, TreeLink]
    joints: list[TreeJoint]
    #: links whose inertia breaks A + B >= C: the physics check balances them
    unbalanced: list[str] = field(default_factory=list)
    #: the fixed tendons motors drive (an MJCF file's)
    tendons: list[TreeTendon] = field(default_factory=list)


@dataclass(frozen=True)
class HandOptions:
    """What a hand file cannot say, from the optional YAML beside it."""

    name: str | None = None
    palm_link: str | None = None
    fingertips: tuple[str, ...] | None = None
    finger_names: tuple[str, ...] | None = None
    pads: dict[str, Pad] = field(default_factory=dict)  # by fingertip link, in its own frame
    grasping: tuple[str, ...] | None = None
    approach: np.ndarray | None = None  # 3 x 3: the approach frame (z towards the object) in the palm frame
    compliance_m: float = DEFAULT_COMPLIANCE_M  # how far a fingertip gives at a contact
    #: the angle (rad) each joint before the palm (a wrist) is held at, where not the default
    held: dict[str, float] = field(default_factory=dict)
    #: efforts and velocity limits by joint name or pattern, in place of the file's (the YAML's ``efforts``)
    efforts: dict[str, float] = field(default_factory=dict)
    velocities: dict[str, float] = field(default_factory=dict)
    #: the YAML these came from: a choice of its that the model refuses is named there, by its key
    config: Path | None = None

    def fault(self, model: Path, key: str, problem: str) -> BadInputError:
        """A refusal of the option ``key``: named in the YAML that set it, else in the model file."""
        if self.config is None:
            return BadInputError(model, problem)
        return BadInputError(self.config, f"field '{key}': {problem} in {model.name}")


#: how far (m) any joint origin or collision shape of a hand may lie from its link's frame: a hand is well
#: inside this, and a file in millimetres read as metres is not
MAX_REACH_M = 10.0


def _check_values(tree: Tree, source: Path) -> None:
    """No NaN or inf anywhere in the file's numbers and no origin or shape out of a hand's reach, each named by
    the joint or link it came from: numbers like 1e30 overflow the kinematics."""
    for joint in tree.joints:
        named = {"lower limit": joint.lower, "upper limit": joint.upper, "effort": joint.effort,
                 "velocity": joint.velocity}  # fmt: skip
        if joint.mimic is not None:
            named |= {"mimic multiplier": joint.mimic[1], "mimic offset": joint.mimic[2]}
        for what, value in named.items():
            if value is not None and not np.isfinite(value):
                raise BadInputError(source, f"joint '{joint.name}': {what} {value} is not a finite number")
        if not (np.isfinite(joint.origin).all() and np.isfinite(joint.axis).all()):
            raise BadInputError(source, f"joint '{joint.name}': its origin or axis is not finite")
        for what in ("effort", "velocity"):
            value = named[what]
            if value is not None and value < 0:
                raise BadInputError(source, f"joint '{joint.name}': {what} {value:g} is negative")
        if joint.mimic is not None:
            _check_mimic(joint, source)
        reach = float(np.abs(joint.origin[:3, 3]).max())  # not its norm: 1e300 squared overflows, with a warning
        if reach > MAX_REACH_M:
            raise BadInputError(
                source,
                f"joint '{joint.name}': its origin lies {reach:.3g} m along an axis from link '{joint.parent}', "
                f"beyond a hand's {MAX_REACH_M:g} m (is the file in millimetres?)",
            )
    joints = {j.name for j in tree.joints}
    for tendon in tree.tendons:
        for name, coefficient in tendon.coefficients.items():
            if name not in joints:
                raise BadInputError(source, f"tendon '{tendon.name}': joint '{name}' is not a joint of the hand")
            if not np.isfinite(coefficient) or not MIMIC_RATIO_RANGE[0] <= abs(coefficient) <= MIMIC_RATIO_RANGE[1]:
                raise BadInputError(
                    source, f"tendon '{tendon.name}': coefficient {coefficient:g} of joint '{name}' is out of range "
                    f"({MIMIC_RATIO_RANGE[0]:g} to {MIMIC_RATIO_RANGE[1]:g} in size)",
                )  # fmt: skip
        if tendon.effort is not None and not (np.isfinite(tendon.effort) and tendon.effort >= 0):
            raise BadInputError(source, f"tendon '{tendon.name}': effort {tendon.effort} is not a force (finite, >= 0)")
    for link in tree.links.values():
        shapes = [c for c, _ in link.spheres] + [np.array([r for _, r in link.spheres])] + link.skin
        if not all(np.isfinite(v).all() for v in shapes):
            raise BadInputError(source, f"link '{link.name}': its collision geometry is not finite")
        reach = max((float(np.abs(v).max()) for v in shapes if v.size), default=0.0)
        if reach > MAX_REACH_M:
            raise BadInputError(
                source,
                f"link '{link.name}': its collision geometry reaches {reach:.3g} m from the link's frame, beyond a "
                f"hand's {MAX_REACH_M:g} m (is the file in millimetres?)",
            )


#: the largest gear ratio (and smallest, by its size) a mimic may state, and the largest offset (rad or m): a
#: hand's couplings lie well inside them, while 1e308 overflowed into NaN bounds and 0 never moves the joint
MIMIC_RATIO_RANGE = (1e-3, 1e3)
MIMIC_OFFSET_MAX = 10.0


def _check_mimic(joint: TreeJoint, source: Path) -> None:
    master, multiplier, offset = joint.mimic  # type: ignore[misc]
    low, high = MIMIC_RATIO_RANGE
    if multiplier == 0:
        raise BadInputError(
            source, f"joint '{joint.name}': mimic multiplier 0 would never move it (make it a fixed joint)"
        )
    if not low <= abs(multiplier) <= high:
        raise BadInputError(
            source,
            f"joint '{joint.name}': mimic multiplier {multiplier:g} of '{master}' is out of range "
            f"({low:g} to {high:g} in size)",
        )
    if abs(offset) > MIMIC_OFFSET_MAX:
        raise BadInputError(
            source, f"joint '{joint.name}': mimic offset {offset:g} is beyond {MIMIC_OFFSET_MAX:g} (rad, or m)"
        )


def _check(tree: Tree, source: Path) -> dict[str, TreeJoint]:
    """Every joint between known links, every link with one parent at most, no cycle: the joint into each
    child."""
    into: dict[str, TreeJoint] = {}
    for joint in tree.joints:
        for end in (joint.parent, joint.child):
            if end not in tree.links:
                raise BadInputError(source, f"joint '{joint.name}': link '{end}' is not defined")
        if joint.child in into:
            first = into[joint.child].name
            raise BadInputError(source, f"link '{joint.child}' has two parent joints ('{first}', '{joint.name}')")
        into[joint.child] = joint
    for link in tree.links:
        seen, current = set(), link
        while current in into:
            if current in seen:
                raise BadInputError(source, f"link '{link}': the joints form a cycle through '{current}'")
            seen.add(current)
            current = into[current].parent
    return into


def _root(tree: Tree, into: dict[str, TreeJoint], source: Path) -> str:
    roots = [name for name in tree.links if name not in into]
    if len(roots) != 1:
        raise BadInputError(source, f"needs one root link, found {len(roots)} ({', '.join(roots[:4])})")
    return roots[0]


def _path(into: dict[str, TreeJoint], palm: str, tip: str, source: Path) -> list[TreeJoint]:
    path, current = [], tip
    while current != palm:
        if current not in into:
            raise BadInputError(source, f"fingertip '{tip}' does not hang from the palm link '{palm}'")
        path.append(into[current])
        current = into[current].parent
    return path[::-1]


def _default_tips(tree: Tree, into: dict[str, TreeJoint], palm: str) -> list[str]:
    """From each leaf link that hangs from the palm, up to the first link with collision geometry, if a revolute
    joint lies between it and the palm: a fingertip may carry fixed, empty frames beyond it (a "tip_head")."""
    parents = {j.parent for j in tree.joints}
    tips: list[str] = []
    for leaf in tree.links:
        if leaf in parents or leaf == palm or not _hangs_from(into, leaf, palm):
            continue
        link = leaf
        while link != palm and not tree.links[link].spheres:
            link = into[link].parent
        if link != palm and link not in tips and _moves(into, link, palm):
            tips.append(link)
    # an empty frame hung off a finger's middle (a sensor's) leads to that link: the finger's own tip is deeper
    return [tip for tip in tips if not any(other != tip and _hangs_from(into, other, tip) for other in tips)]


def _moves(into: dict[str, TreeJoint], link: str, palm: str) -> bool:
    while link != palm:
        if into[link].kind in MOVING:
            return True
        link = into[link].parent
    return False


def _hangs_from(into: dict[str, TreeJoint], link: str, palm: str) -> bool:
    while link in into:
        link = into[link].parent
        if link == palm:
            return True
    return False


def _limits(joint: TreeJoint, source: Path) -> tuple[float, float]:
    if joint.kind == "continuous" and (joint.lower is None or joint.upper is None or joint.lower >= joint.upper):
        return -np.pi, np.pi
    if joint.lower is None or joint.upper is None:
        raise BadInputError(source, f"joint '{joint.name}' has no limits; a {joint.kind} joint needs them")
    if not joint.lower < joint.upper:
        raise BadInputError(source, f"joint '{joint.name}': lower limit {joint.lower} is not below {joint.upper}")
    return joint.lower, joint.upper


def _unit_axis(joint: TreeJoint, source: Path) -> np.ndarray:
    norm = np.linalg.norm(joint.axis)
    if not np.isfinite(norm) or norm < 1e-9:
        raise BadInputError(source, f"joint '{joint.name}' has no axis")
    return np.asarray(joint.axis, dtype=float) / norm


Spheres = list[tuple[np.ndarray, float]]


def _transform_spheres(spheres: Spheres, transform: np.ndarray) -> Spheres:
    return [(transform[:3, :3] @ c + transform[:3, 3], r) for c, r in spheres]


@dataclass
class _Chain:
    """One finger as it is built: its joints, the spheres per link, and the tip's frame in the last link."""

    joints: list[Joint]
    spheres: list[Sphere]
    skin: list[Skin]
    tip_frame: np.ndarray
    tip_spheres: list[tuple[np.ndarray, float]]
    tip_meshes: list[tuple[np.ndarray, np.ndarray]]  # in the last joint's link frame
    tip_boxes: list[tuple[np.ndarray, np.ndarray]]  # (half sizes, frame in the last joint's link frame)


def _skin(link: TreeLink, transform: np.ndarray) -> np.ndarray:
    """The link's collision surface points in the frame ``transform`` places it in."""
    points = np.vstack([np.zeros((0, 3)), *link.skin])
    return points @ transform[:3, :3].T + transform[:3, 3]


def _chain(tree: Tree, path: list[TreeJoint], source: Path, on_path: set[str], attached: set[str]) -> _Chain:
    """One finger's chain along ``path``; the geometry of links in ``attached`` (those on the way to an earlier
    finger too, behind a shared joint) stays with that finger, and this chain's links join ``attached``."""
    joints: list[Joint] = []
    spheres: list[Sphere] = []
    skin: list[Skin] = []
    pending = np.eye(4)  # fixed transforms since the last movable joint's link
    for tree_joint in path:
        if tree_joint.kind == "fixed":
            pending = pending @ tree_joint.origin
            if joints and _attach(tree_joint.child, attached):
                for c, r in _transform_spheres(tree.links[tree_joint.child].spheres, pending):
                    spheres.append(Sphere(len(joints) - 1, c, r))
                skin.append(Skin(len(joints) - 1, _skin(tree.links[tree_joint.child], pending)))
            continue
        if tree_joint.kind not in MOVING:
            kind = tree_joint.kind
            raise BadInputError(
                source, f"joint '{tree_joint.name}' is {kind}: only revolute and prismatic joints move fingers"
            )
        frame = pending @ tree_joint.origin
        lower, upper = _limits(tree_joint, source)
        rotation = frame[:3, :3]
        joints.append(
            Joint(
                name=tree_joint.name,
                axis=_unit_axis(tree_joint, source),
                lower=float(lower),
                upper=float(upper),
                offset=frame[:3, 3].copy(),
                rotation=None if np.allclose(rotation, np.eye(3), atol=1e-15) else rotation.copy(),
                sliding=tree_joint.kind == "prismatic",
                velocity=tree_joint.velocity,
            )
        )
        pending = np.eye(4)
        k = len(joints) - 1
        child = tree_joint.child
        if not _attach(child, attached):
            continue
        for c, r in tree.links[child].spheres:
            spheres.append(Sphere(k, c, r))
        skin.append(Skin(k, _skin(tree.links[child], np.eye(4))))
        for link, link_frame in fixed_links(tree, child, skip=on_path)[1:]:  # [0] is the child itself
            for c, r in _transform_spheres(tree.links[link].spheres, link_frame):
                spheres.append(Sphere(k, c, r))
            skin.append(Skin(k, _skin(tree.links[link], link_frame)))
    if not joints:
        raise BadInputError(source, f"fingertip '{path[-1].child}': no moving joint between it and the palm")
    tip = tree.links[path[-1].child]
    meshes = [(v @ pending[:3, :3].T + pending[:3, 3], f) for v, f in tip.meshes]
    rounded = _transform_spheres(tip.rounded, pending)
    boxes = [(half, pending @ frame) for half, frame in tip.boxes]
    return _Chain(joints, spheres, [s for s in skin if len(s.points)], pending, rounded, meshes, boxes)


def _attach(link: str, attached: set[str]) -> bool:
    """Whether ``link``'s geometry is still to be attached to a finger (and, from now on, is)."""
    if link in attached:
        return False
    attached.add(link)
    return True


def _share_joints(chains: dict[str, _Chain], file_joints: set[str]) -> dict[str, str]:
    """A joint on the way to two fingertips (a spread moving the ring and little fingers) stays in the first
    finger's chain and is repeated in each later one as ``<joint>@<finger>``, coupled to it one to one: one angle,
    and one motor whose torque sums what every finger's contacts ask of it. Returns ``copy -> original``."""
    owner: dict[str, str] = {}
    copies: dict[str, str] = {}
    for name, chain in chains.items():
        for k, joint in enumerate(chain.joints):
            if owner.setdefault(joint.name, name) != name:
                copy = f"{joint.name}@{name}"
                while copy in file_joints or copy in copies:
                    copy += "_"
                chain.joints[k] = replace(joint, name=copy, coupled_to=joint.name, shared=True)
                copies[copy] = joint.name
    return copies


def _mimic(tree: Tree, chains: dict[str, _Chain], source: Path) -> dict[str, tuple[str, float, float]]:
    """Coupled joints: ``slave -> (master, multiplier, offset)``, checked against the fingers' joints."""
    finger_joints = {j.name for chain in chains.values() for j in chain.joints}
    couplings = {}
    for joint in tree.joints:
        if joint.mimic is None or joint.name not in finger_joints:
            continue
        master, multiplier, offset = joint.mimic
        if master not in finger_joints:
            known = {j.name for j in tree.joints}
            where = "is not a joint of the hand" if master not in known else "does not move a finger"
            raise BadInputError(source, f"joint '{joint.name}' mimics '{master}', which {where}")
        couplings[joint.name] = (master, multiplier, offset)
    for name in couplings:  # a chain of mimics must end at a joint that a motor drives
        seen, current = [name], couplings[name][0]
        while current in couplings:
            if current in seen:
                loop = " -> ".join([*seen[seen.index(current) :], current])
                raise BadInputError(source, f"joints mimic each other in a loop ({loop}): one must be driven")
            seen.append(current)
            current = couplings[current][0]
    return couplings


def _capability(
    joint_names: list[str],
    efforts: dict[str, float | None],
    couplings: dict,
    tendons: list[TreeTendon],
    source: Path,
    options: HandOptions,
) -> Capability:
    """The motors' capability, by virtual work over the joints that move freely (the masters): a row of ``T`` per
    master, summing the torques of the joints that follow it times their multipliers (a jaw's force and the
    mimicking jaw's: one motor closes both); a motor on a joint pushes its row alone, a motor on a fixed tendon
    pulls every row its joints reach, by their coefficients (``G^T c``). A master that no motor moves is refused,
    naming the YAML's key that gives its effort: no strength is made up."""
    masters = [n for n in joint_names if n not in couplings]
    rows = {n: i for i, n in enumerate(masters)}
    follow = np.zeros((len(joint_names), len(masters)))  # G: each column's joint as a multiple of its master
    for column, name in enumerate(joint_names):
        master, multiplier = (couplings[name][0], couplings[name][1]) if name in couplings else (name, 1.0)
        while master in couplings:  # a chain of mimics ends at one motor
            master, multiplier = couplings[master][0], multiplier * couplings[master][1]
        follow[column, rows[master]] = multiplier
    names, directions, limits = _tendon_motors(joint_names, follow, tendons, source, options)
    pulled = np.abs(np.array(directions).reshape(-1, len(masters))).sum(axis=0) > 1e-12
    missing = [n for n in masters if not (efforts.get(n) or 0.0) > 0 and not pulled[rows[n]]]
    if missing and len(missing) == len(masters):
        raise options.fault(
            source,
            "efforts",
            f"no motor's effort is given (all {len(masters)} joints state 0 or nothing, as files exported from CAD "
            f"often do): set them in a hand YAML with model: {source.name}, e.g. efforts: {{'{_pattern(masters)}': "
            "1.0} (N.m, or N for a sliding joint)",
        )
    if missing:
        name = missing[0]
        raise options.fault(
            source,
            "efforts",
            f"joint '{name}': effort must be a positive torque (N.m), or force (N) if it slides, got "
            f"{efforts.get(name)}; set it in a hand YAML beside the file, efforts: {{{name}: ...}}",
        )
    for name in masters:  # a joint's own motor, where it has an effort
        effort = efforts.get(name)
        if effort is not None and effort > 0:
            names.append(name)
            unit = np.zeros(len(masters))
            unit[rows[name]] = 1.0
            directions.append(unit)
            limits.append(float(effort))
    transmission = follow.T
    return Capability.motors(tuple(names), np.array(limits), transmission, np.array(directions).T)


def _tendon_motors(
    joint_names: list[str], follow: np.ndarray, tendons: list[TreeTendon], source: Path, options: HandOptions
) -> tuple[list[str], list[np.ndarray], list[float]]:
    """Each tendon's motor that moves these fingers: its name, its direction ``G^T c`` over the masters' rows
    and its force limit."""
    columns = {n: k for k, n in enumerate(joint_names)}
    names, directions, limits = [], [], []
    for tendon in tendons:
        pull = np.zeros(len(joint_names))
        for joint, coefficient in tendon.coefficients.items():
            if joint in columns:
                pull[columns[joint]] += coefficient
        direction = follow.T @ pull
        if not np.any(np.abs(direction) > 1e-12):
            continue  # it moves none of these fingers' joints
        if not (tendon.effort or 0.0) > 0:
            raise options.fault(
                source,
                "efforts",
                f"tendon '{tendon.name}': its motor's force limit must be positive, got {tendon.effort}; set it in a "
                f"hand YAML beside the file, efforts: {{{tendon.name}: ...}}",
            )
        names.append(tendon.name)
        directions.append(direction)
        limits.append(float(tendon.effort))  # type: ignore[arg-type]
    return names, directions, limits


def _pattern(names: list[str]) -> str:
    """A pattern that the names share, for the example of a line (``finger_*_joint``), or ``*``."""
    prefix = os.path.commonprefix(names)
    suffix = os.path.commonprefix([n[::-1] for n in names])[::-1]
    if len(names) > 1 and len(prefix) + len(suffix) < min(len(n) for n in names):
        return f"{prefix}*{suffix}"
    return names[0] if len(names) == 1 else "*"


def _overrides(tree: Tree, options: HandOptions, source: Path) -> tuple[Tree, dict[str, str]]:
    """The file's joints with the YAML's efforts and velocities in place of the file's, and where each moving
    joint's effort comes from (the file, or the YAML's key). A pattern that matches no moving joint is refused."""
    moving = [j.name for j in tree.joints if j.kind in MOVING] + [t.name for t in tree.tendons]
    picked: dict[str, dict[str, tuple[str, float]]] = {"efforts": {}, "velocities": {}}
    for key, given in (("efforts", options.efforts), ("velocities", options.velocities)):
        for pattern, value in given.items():
            matched = [name for name in moving if fnmatch.fnmatchcase(name, pattern)]
            if not matched:
                shown = ", ".join(moving[:10]) + (f", ... ({len(moving)} in all)" if len(moving) > 10 else "")
                raise options.fault(source, f"{key}.{pattern}", f"matches no moving joint (the file has: {shown})")
            for name in matched:  # a joint's own name wins over a pattern, a later pattern over an earlier one
                if pattern == name or picked[key].get(name, ("",))[0] != name:
                    picked[key][name] = (pattern, float(value))
    sources = {}
    items: list[TreeJoint | TreeTendon] = [*tree.joints, *tree.tendons]
    for item in items:
        effort = picked["efforts"].get(item.name)
        if effort is not None:
            sources[item.name] = f"{options.config.name if options.config else 'config'} efforts['{effort[0]}']"
        elif item.effort:
            sources[item.name] = "file"
    joints = [
        replace(
            joint,
            effort=picked["efforts"].get(joint.name, (None, joint.effort))[1],
            velocity=picked["velocities"].get(joint.name, (None, joint.velocity))[1],
        )
        for joint in tree.joints
    ]
    tendons = [replace(t, effort=picked["efforts"].get(t.name, (None, t.effort))[1]) for t in tree.tendons]
    return replace(tree, joints=joints, tendons=tendons), sources


def _refuse_unmoving(tree: Tree, into: dict[str, TreeJoint], palm: str, source: Path) -> None:
    """A planar or floating joint below the palm is named: a finger moves by turning and sliding joints only (it
    was once taken for a link that no finger reaches, and said as "a hand needs at least two fingertips")."""
    for joint in tree.joints:
        if joint.kind not in (*MOVING, "fixed") and _hangs_from(into, joint.child, palm):
            raise BadInputError(
                source,
                f"joint '{joint.name}' is {joint.kind}: only revolute, continuous and prismatic joints move fingers",
            )


def _provisional(fingers: dict[str, Finger]) -> Hand:
    """The fingers alone, for their forward kinematics while the hand is being made."""
    return Hand("provisional", fingers, Palm(np.zeros((0, 3)), np.zeros(0)), tuple(fingers), Capability.combined([]))


def _pads(
    hand_fingers: dict[str, Finger], chains: dict[str, _Chain], tips: list[str], options: HandOptions, source: Path
) -> dict[str, Finger]:
    """Each pad on its tip's sphere (for a mesh tip, the sphere fitted to its pad; for a box tip or a mesh tip
    whose pad is flat, its flat face), facing the way the tip moves when the last joint closes it (the flexion
    side), unless the YAML places it; the first friction-cone edge follows the distal link."""
    out, jaws = {}, _jaw_closing(hand_fingers, chains)
    for (name, finger), tip in zip(hand_fingers.items(), tips, strict=True):
        chain, last = chains[name], finger.joints[-1]
        closing = jaws.get(name, 1.0 if last.upper + last.lower >= 0 else -1.0)  # most of its range turns it shut
        mesh = _merged(chain.tip_meshes) if chain.tip_meshes and not chain.tip_spheres else None
        flat = None
        if tip in options.pads:
            pad, frame = options.pads[tip], chain.tip_frame
            rotation = frame[:3, :3]
            pad = replace(pad, point=rotation @ pad.point + frame[:3, 3], normal=rotation @ pad.normal,
                          tangent=rotation @ pad.tangent)  # fmt: skip
            if pad.flat:  # the verifier measures its contact against the tip's own triangles, or a box's
                flat = pad
                mesh = boxes_mesh(chain.tip_boxes) if mesh is None and chain.tip_boxes else mesh
        elif chain.tip_boxes and not (chain.tip_spheres or chain.tip_meshes):
            flat = box_pad(chain.tip_boxes, last.axis, closing, last.sliding)
            mesh = boxes_mesh(chain.tip_boxes) if flat is not None else None
        elif mesh is not None:
            flat = flat_face(*mesh, last.axis, closing, options.compliance_m, last.sliding)
        if flat is not None:
            out[name] = replace(finger, spheres=_behind_the_face(finger, flat, options.compliance_m), pad=flat,
                                tip_mesh=mesh)  # fmt: skip
            continue
        if tip not in options.pads:
            pad = _rounded_pad(chain, last, closing, tip, source)
        if not all(np.isfinite(v).all() for v in (pad.point, pad.normal, pad.tangent, pad.radius)):
            raise BadInputError(source, f"fingertip '{tip}': its pad is not finite (point {pad.point})")
        spheres = _off_the_pad(finger, pad, options.compliance_m)
        if mesh is not None and pad.radius > 0:
            spheres = _flush_with_the_pad(spheres, finger.n_joints - 1, pad, mesh[0])
            # a contact sits the compliance inside the pad sphere; where the sphere leaves the mesh, so does it
            roll = roll_limit_deg(*mesh, pad.centre, pad.radius - options.compliance_m, pad.normal,
                                  PAD_FOLLOW_SLACK_M, PAD_ROLL_DEG)  # fmt: skip
            pad = replace(pad, roll_max_deg=roll)
        out[name] = replace(finger, spheres=spheres, pad=pad, tip_mesh=mesh)
    return out


def _jaw_closing(fingers: dict[str, Finger], chains: dict[str, _Chain]) -> dict[str, float]:
    """For each finger whose last joint slides (a gripper's jaw), the sign of the slide that closes it: the one
    toward the other fingertips' middle, at mid-range. A jaw's range says nothing of it: the Franka's opens from
    0, a Robotiq's closes from 0."""
    jaws = [name for name, finger in fingers.items() if finger.joints[-1].sliding]
    if not jaws or len(fingers) < 2:
        return {}
    hand = _provisional(fingers)
    pose = forward(hand, hand.mid_range())
    middles = {}
    for name, placed in pose.fingers.items():
        rotation, origin = placed.link_rotations[0, -1], placed.joint_positions[0, fingers[name].n_joints - 1]
        middles[name] = origin + rotation @ _tip_middle(chains[name])
    out = {}
    for name in jaws:
        others = np.mean([p for other, p in middles.items() if other != name], axis=0)
        axis = pose.fingers[name].joint_axes[0, -1]
        out[name] = -1.0 if float(axis @ (others - middles[name])) < 0 else 1.0
    return out


def _tip_middle(chain: _Chain) -> np.ndarray:
    """The middle of a fingertip's collision geometry in its last joint's frame (its frame's origin if none)."""
    points = [frame[:3, 3] for _, frame in chain.tip_boxes] + [c for c, _ in chain.tip_spheres]
    points += [v.mean(axis=0) for v, _ in chain.tip_meshes]
    return np.mean(points, axis=0) if points else chain.tip_frame[:3, 3]


def _rounded_pad(chain: _Chain, last: Joint, closing: float, tip: str, source: Path) -> Pad:
    """The pad on the tip's sphere (a mesh tip's fitted one), or at the tip's frame for a tip with none."""
    error = 0.0
    if chain.tip_spheres:
        centre, radius = chain.tip_spheres[-1]
    elif chain.tip_meshes:
        centre, radius, error = _mesh_pad(chain.tip_meshes, last, closing, tip, source)
    else:
        centre, radius = chain.tip_frame[:3, 3], 0.0
    if np.linalg.norm(centre) < 1e-6 and not last.sliding:  # no way from the joint to the tip: no side it closes on
        raise BadInputError(
            source,
            f"fingertip '{tip}' lies on its last joint '{last.name}' (a link of zero length): no pad can "
            "face the way it closes; place the pad under 'pads' in a hand YAML",
        )
    along = centre / max(float(np.linalg.norm(centre)), 1e-300)  # from the last joint to the tip, in its frame
    normal = motion(last.axis, closing, centre, last.sliding)
    if np.linalg.norm(normal) < 1e-9:  # a tip on the joint's axis: face away from the palm
        normal = np.cross(along, [0.0, 0.0, 1.0]) if abs(along[2]) < 0.9 else np.cross(along, [1.0, 0.0, 0.0])
    normal = normal / np.linalg.norm(normal)
    tangent = along - (along @ normal) * normal
    if np.linalg.norm(tangent) < 1e-9:  # a jaw's tip straight along its slide: any direction across it
        tangent = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    tangent = tangent / max(np.linalg.norm(tangent), 1e-12)
    return Pad(centre + radius * normal, normal, tangent, radius, fit_error_m=error)


def _merged(meshes: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """A fingertip's meshes as one: each closed one that an exporter wrote inside out turned outward (a pad is
    the faces that face the way the finger closes, and the verifier measures outside the tip by them), vertices
    stacked, faces renumbered."""
    meshes = [outward(np.asarray(v, float), np.asarray(f, int)) for v, f in meshes]
    offsets = np.cumsum([0] + [len(v) for v, _ in meshes])[:-1]
    return np.vstack([v for v, _ in meshes]), np.vstack([f + o for (_, f), o in zip(meshes, offsets, strict=True)])


def _mesh_pad(
    meshes: list[tuple[np.ndarray, np.ndarray]], last: Joint, closing: float, tip: str, source: Path
) -> tuple[np.ndarray, float, float]:
    """The centre, radius and fit error of the sphere fitted to a mesh fingertip's pad."""
    vertices, faces = _merged(meshes)
    try:
        fit = fit_pad(vertices, faces, last.axis, closing, last.sliding)
    except NoPadError as exc:
        raise BadInputError(source, f"fingertip '{tip}': {exc}; place its pad under 'pads' in a hand YAML") from exc
    return fit.centre, fit.radius, fit.error_m


def _off_the_pad(finger: Finger, pad: Pad, compliance: float) -> tuple[Sphere, ...]:
    """The finger's collision spheres without the pad's own sphere, and with the last link's spheres that hold
    the pad point shrunk to pass ``compliance`` inside it: the pad's sphere is the contact surface. Kept whole,
    eq. 14 would let them touch the object only where the pad does, with their normal the surface's, and the
    contact and clearance constraints become parallel there (IPOPT then ended locally infeasible or at the time
    limit on most starts). Dropped, the side of a tip beside its pad went unguarded, and sagged 0.05-0.12 mm past
    the compliance (the Allegro's capsules, a mesh tip's fitted cover)."""
    last = finger.n_joints - 1
    kept = []
    for s in finger.spheres:
        if s.link != last:
            kept.append(s)
            continue
        own = pad.radius > 0 and np.linalg.norm(s.center - pad.centre) < 1e-9 and abs(s.radius - pad.radius) < 1e-9
        reach = float(np.linalg.norm(pad.point - s.center))
        if own:
            continue
        radius = s.radius if reach >= s.radius - 1e-9 else reach - compliance
        inside_pad = pad.radius > 0 and np.linalg.norm(s.center - pad.centre) + radius <= pad.radius + 1e-4
        if radius > 1e-4 and not inside_pad:  # a sphere within the pad's own guards nothing it does not
            kept.append(replace(s, radius=radius))
    return tuple(kept)


def _behind_the_face(finger: Finger, pad: Pad, compliance: float) -> tuple[Sphere, ...]:
    """The finger's collision spheres, those of its last link shrunk to pass ``compliance`` behind a flat pad's
    face: a box's cover bulges out of its faces by 6-12% of its half-width, and kept so, eq. 14 would hold the
    face off the surface it is to lie on, or meet the object where the contact does (parallel constraints)."""
    last, kept = finger.n_joints - 1, []
    for s in finger.spheres:
        if s.link == last:
            radius = min(s.radius, float((pad.point - s.center) @ pad.normal) - compliance)
            if radius <= 1e-4:
                continue
            s = replace(s, radius=radius)
        kept.append(s)
    return tuple(kept)


def _flush_with_the_pad(spheres: tuple[Sphere, ...], last: int, pad: Pad, tip: np.ndarray) -> tuple[Sphere, ...]:
    """A mesh tip's spheres shrunk so that, over the part of the tip the contact rolls on (directions within
    :data:`PAD_ROLL_DEG` of the pad normal), none stands proud of both the pad sphere and the tip's own vertices.
    A fitted cover reaches up to its bound outside the mesh, and eq. 14 lets the tip sink only its compliance:
    a sphere standing 2.4 mm proud of a mesh Allegro's tip end held the contact off the pad's distal side, and
    IPOPT ended infeasible on every cutting start (the Allegro's own capsule, a sphere and a cylinder, has
    none)."""
    cone = _cone_directions(pad.normal, np.radians(PAD_ROLL_DEG))
    support = np.maximum((tip - pad.centre) @ cone.T, 0.0).max(axis=0)  # the tip's extent along each direction
    room = np.maximum(support, pad.radius)
    out = []
    for s in spheres:
        if s.link == last:
            radius = min(s.radius, float((room - (s.center - pad.centre) @ cone.T).min()))
            if radius <= 1e-4:
                continue
            s = replace(s, radius=radius)
        out.append(s)
    return tuple(out)


def _cone_directions(axis: np.ndarray, half_angle: float, count: int = 64) -> np.ndarray:
    """``count`` unit vectors spread over the cone of ``half_angle`` about ``axis``, its edge included."""
    k = np.arange(count)
    polar = half_angle * np.sqrt((k + 0.5) / count)
    polar[-8:] = half_angle
    azimuth = k * np.pi * (3.0 - np.sqrt(5.0))
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    return np.cos(polar)[:, None] * axis + np.sin(polar)[:, None] * (
        np.cos(azimuth)[:, None] * e1 + np.sin(azimuth)[:, None] * e2
    )


def _approach(fingers: dict[str, Finger], options: HandOptions) -> np.ndarray:
    """The approach frame in the palm frame: z from the palm's origin to the pads at mid-range."""
    if options.approach is not None:
        return options.approach
    hand = _provisional(fingers)
    pads = forward(hand, hand.mid_range()).contacts()[0].mean(axis=0)
    z = pads / np.linalg.norm(pads)
    reference = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = reference - (reference @ z) * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def _palm_and_tips(
    tree: Tree, into: dict[str, TreeJoint], root: str, options: HandOptions, source: Path
) -> tuple[str, list[str]]:
    """The palm link and the fingertip links: as the YAML names them, else the fingertips found below the root
    and the palm where their chains branch, found again below that palm until both settle (a link fixed to the
    palm, an IMU's, is no fingertip of a hand whose wrist moves it)."""
    palm = options.palm_link
    if palm is not None and palm not in tree.links:
        raise options.fault(source, "palm_link", f"palm link '{palm}' is not defined")
    if options.fingertips:
        tips = list(options.fingertips)
        for tip in tips:
            if tip not in tree.links:
                raise options.fault(source, "fingertips", f"unknown fingertip '{tip}' (no such link)")
        return palm or (branching_link(into, tips) if len(tips) > 1 else root), tips
    if palm is not None:
        return palm, _default_tips(tree, into, palm)
    palm, tips = root, _default_tips(tree, into, root)
    while len(tips) > 1:
        below = branching_link(into, tips)
        if below == palm:
            break
        palm, tips = below, _default_tips(tree, into, below)
    return palm, tips


def hand_from_tree(tree: Tree, source: Path, options: HandOptions = HandOptions()) -> Hand:
    """The hand a parsed file describes (see the module docstring for the rules and the defaults)."""
    _check_values(tree, source)
    tree, effort_sources = _overrides(tree, options, source)
    into = _check(tree, source)
    root = _root(tree, into, source)
    palm, tips = _palm_and_tips(tree, into, root, options, source)
    _refuse_unmoving(tree, into, palm, source)
    _check_tips(into, tips, options, source)
    names = list(options.finger_names) if options.finger_names else tips
    if len(names) != len(tips):
        raise options.fault(source, "finger_names", f"{len(names)} finger names for {len(tips)} fingertips")
    paths = {name: _path(into, palm, tip, source) for name, tip in zip(names, tips, strict=True)}
    on_path = {j.child for path in paths.values() for j in path}
    attached: set[str] = set()  # links whose geometry an earlier finger's chain carries
    chains = {name: _chain(tree, path, source, on_path, attached) for name, path in paths.items()}
    shared = _share_joints(chains, {j.name for j in tree.joints})
    couplings = _mimic(tree, chains, source)
    capability_couplings = {**couplings, **{copy: (original, 1.0, 0.0) for copy, original in shared.items()}}
    fingers = _pads(_fingers(chains, couplings), chains, tips, options, source)
    held = held_joints(into, root, palm, options, source)
    joint_names = [j.name for f in fingers.values() for j in f.joints]
    efforts = {j.name: j.effort for j in tree.joints}
    capability = _capability(joint_names, efforts, capability_couplings, tree.tendons, source, options)
    grasping = _grasping(fingers, options, source)
    return Hand(
        options.name or source.stem,
        fingers,
        _palm(tree, into, palm),
        grasping,
        capability,
        approach=_approach(fingers, options),
        model_file=source.resolve(),
        palm_link=palm,
        compliance_m=options.compliance_m,
        fingertip_links=dict(zip(names, tips, strict=True)),
        held_joints=held,
        unbalanced_inertia=tuple(tree.unbalanced),
        cover_reach_m={name: link.cover_reach_m for name, link in tree.links.items() if link.meshes},
        effort_sources={n[:-1]: effort_sources.get(n[:-1], "") for n in capability.actuators if n.endswith("+")},
    )


def _check_tips(into: dict, tips: list[str], options: HandOptions, source: Path) -> None:
    """The fingertips make a hand: the YAML's pads are on them, no two sit on one chain, and there are two."""
    for link in options.pads:
        if link not in tips:
            raise options.fault(source, f"pads.{link}", f"link '{link}' is not a fingertip ({', '.join(tips)})")
    for tip in tips:
        for other in tips:
            if other != tip and _hangs_from(into, other, tip):
                raise BadInputError(
                    source, f"fingertips '{tip}' and '{other}' sit on one chain from the palm: each needs its own"
                )
    if len(tips) < 2:
        found = ", ".join(tips) or "none"
        why = " (every link with collision geometry hangs on one chain from the palm)" if len(tips) == 1 else ""
        raise BadInputError(
            source,
            f"a hand needs at least two fingertips, found {len(tips)} ({found}){why}: name them under 'fingertips' "
            "in a hand YAML with 'model: <this file>'",
        )


def _fingers(chains: dict[str, _Chain], couplings: dict[str, tuple[str, float, float]]) -> dict[str, Finger]:
    """Each chain as a finger, its coupled joints marked, its pad not yet placed (:func:`_pads` places it)."""
    fingers = {}
    unset = Pad(np.zeros(3), np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    for name, chain in chains.items():
        joints = tuple(
            replace(
                j, coupled_to=couplings[j.name][0], ratio=couplings[j.name][1], coupling_offset=couplings[j.name][2]
            )
            if j.name in couplings
            else j
            for j in chain.joints
        )
        radius = float(np.median([s.radius for s in chain.spheres])) if chain.spheres else 0.008
        end = chain.tip_frame[:3, 3].copy()
        fingers[name] = Finger(name, joints, tuple(chain.spheres), unset, end, radius, tuple(chain.skin))
    return fingers


def _palm(tree: Tree, into: dict, palm: str) -> Palm:
    """The palm's collision spheres and skin: its own link's and those of every link fixed to it."""
    palm_spheres, palm_skin = [], [np.zeros((0, 3))]
    for link, frame in fixed_to_palm(tree, into, palm):
        palm_spheres += _transform_spheres(tree.links[link].spheres, frame)
        palm_skin.append(_skin(tree.links[link], frame))
    centres, radii = np.array([c for c, _ in palm_spheres]).reshape(-1, 3), np.array([r for _, r in palm_spheres])
    return Palm(centres, radii, np.vstack(palm_skin))


def _grasping(fingers: dict[str, Finger], options: HandOptions, source: Path) -> tuple[str, ...]:
    """The grasping fingers (the YAML's, or all), each a finger of the hand, and a compliance below every
    fingertip's radius."""
    grasping = tuple(options.grasping) if options.grasping else tuple(fingers)
    for finger in grasping:
        if finger not in fingers:
            known = ", ".join(fingers)
            raise options.fault(
                source, "grasping_fingers", f"grasping finger '{finger}' is not a finger of this hand ({known})"
            )
    rounded = [f.pad.radius for f in fingers.values() if f.pad.radius > 0]
    if rounded and options.compliance_m >= min(rounded):
        raise options.fault(
            source,
            "compliance_m",
            f"compliance {options.compliance_m} m is not below the fingertip radius {min(rounded)} m",
        )
    return grasping
