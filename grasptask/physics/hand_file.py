"""A robot hand in the physics check as its own file describes it: an MJCF compiled as it is, a URDF through
MuJoCo's URDF support, each with its own collision geometry, joint limits and couplings (mimic joints become
MuJoCo joint equalities). What the scene changes, and why:

- collision meshes are read with trimesh (any format, ``package://`` paths resolved as the hand loader does)
  and replaced by their convex hulls, which is what MuJoCo collides anyway;
- the file's own actuators, sensors and keyframes are removed: the scene drives the joints with motors at the
  hand model's effort limits, which came from the file's efforts or actuators;
- the fingers the grasp does not use are removed, as the synthesis leaves them out;
- the palm is welded to the world at the grasp's palm pose, and every collision geom touches the object only."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import mujoco
import numpy as np

from grasptask.errors import BadInputError
from grasptask.grasp.grasp_pose import Grasp
from grasptask.hand.from_mjcf import visual_free_spec
from grasptask.hand.from_urdf import resolve_mesh
from grasptask.hand.hand_model import Hand
from grasptask.physics.physics_settings import PhysicsSettings

#: the smallest mass and inertia of a moving body: a URDF link may declare none
BOUND_MASS_KG, BOUND_INERTIA_KG_M2 = 1e-3, 1e-7


def compile_spec(spec: mujoco.MjSpec, source: Path | str) -> mujoco.MjModel:
    """``spec`` compiled; MuJoCo's refusal is one line naming ``source``."""
    try:
        return spec.compile()
    except ValueError as exc:
        raise BadInputError(source, f"MuJoCo cannot compile it: {' '.join(str(exc).split())}") from exc


def _urdf_spec(source: Path) -> mujoco.MjSpec:
    """A URDF through MuJoCo's parser: visuals dropped, fixed links kept as bodies (the palm link must stay
    one), collision meshes found where the hand loader finds them."""
    from lxml import etree  # deferred: only for URDF hands

    root = etree.parse(str(source)).getroot()
    for visual in root.iter("visual"):
        visual.getparent().remove(visual)
    for mesh in root.iter("mesh"):
        found = resolve_mesh(mesh.get("filename", ""), source)
        if found is not None:
            mesh.set("filename", str(found))
    # the file's own <mujoco> element is kept, with what the scene needs set in it: a second one is refused.
    # Published inertias often break A + B >= C, which MuJoCo refuses unless it balances them
    extension = root.find("mujoco")
    extension = etree.SubElement(root, "mujoco") if extension is None else extension
    compiler = extension.find("compiler")
    compiler = etree.SubElement(extension, "compiler") if compiler is None else compiler
    for key, value in (("fusestatic", "false"), ("strippath", "false"), ("discardvisual", "true")):
        compiler.set(key, value)
    compiler.set("balanceinertia", "true")
    try:
        return mujoco.MjSpec.from_string(etree.tostring(root, encoding="unicode"))
    except ValueError as exc:
        raise BadInputError(source, f"MuJoCo cannot read it: {' '.join(str(exc).split())}") from exc


def _convex_meshes(spec: mujoco.MjSpec, source: Path) -> None:
    """Every mesh asset read with trimesh and replaced by its convex hull's vertices and faces."""
    import trimesh  # deferred: trimesh, only for mesh links

    for mesh in spec.meshes:
        if not mesh.file:
            continue
        path = Path(mesh.file)
        if not path.is_absolute():
            path = source.parent / (spec.meshdir or "") / path
        try:
            hull = trimesh.load(path, force="mesh").convex_hull  # type: ignore[attr-defined]
        except Exception as exc:  # noqa: BLE001 - trimesh raises many kinds for a broken file
            kind = type(exc).__name__
            raise BadInputError(path, f"mesh '{mesh.name}': not a mesh trimesh can read ({kind})") from exc
        mesh.file = ""
        mesh.uservert = np.asarray(hull.vertices, dtype=float).ravel()
        mesh.userface = np.asarray(hull.faces, dtype=np.int32).ravel()


@lru_cache(maxsize=8)
def _prepared(source: Path, stamp: float) -> mujoco.MjSpec:
    """The file's spec, convex and without actuators, sensors or keyframes (cached per file and mtime)."""
    spec = _urdf_spec(source) if source.suffix.lower() == ".urdf" else visual_free_spec(source)
    _convex_meshes(spec, source)
    for kind in ("actuators", "sensors", "keys"):
        for element in list(getattr(spec, kind)):
            spec.delete(element)
    spec.compiler.boundmass, spec.compiler.boundinertia = BOUND_MASS_KG, BOUND_INERTIA_KG_M2
    return spec


def _above_palm(spec: mujoco.MjSpec, palm: str) -> set[str]:
    """The palm's body and the bodies between it and the world (a forearm, a wrist)."""
    above, body = set(), spec.body(palm)
    while body is not None and body.name != "world":
        above.add(body.name)
        body = body.parent
    return above


def _weld_to_palm(spec: mujoco.MjSpec, palm: str, held: dict[str, float]) -> set[str]:
    """Remove the joints between the world and the palm (a mounted hand's free joint, an arm's, a wrist's), each
    at the angle the hand holds it at (``held``, else 0): the palm is welded where the hand model has it. Returns
    the bodies from the palm up to the world."""
    above = _above_palm(spec, palm)
    for joint in list(spec.joints):
        if joint.type == mujoco.mjtJoint.mjJNT_FREE or joint.parent.name in above:
            _hold(joint.parent, joint, held.get(joint.name, 0.0))
            spec.delete(joint)
    return above


def _hold(body: mujoco.MjsBody, joint: mujoco.MjsJoint, angle: float) -> None:
    """``body`` turned about ``joint``'s axis by ``angle``, for good: the joint held there, then removed."""
    if angle == 0.0:
        return
    axis = np.asarray(joint.axis, dtype=float) / np.linalg.norm(joint.axis)
    turn, point = np.zeros(4), np.asarray(joint.pos, dtype=float)
    mujoco.mju_axisAngle2Quat(turn, axis, angle)
    rotation, moved = np.zeros(9), np.zeros(3)
    mujoco.mju_quat2Mat(rotation, np.asarray(body.quat, dtype=float))
    mujoco.mju_rotVecQuat(moved, point, turn)
    body.pos = np.asarray(body.pos, dtype=float) + rotation.reshape(3, 3) @ (point - moved)
    quat = np.zeros(4)
    mujoco.mju_mulQuat(quat, np.asarray(body.quat, dtype=float), turn)
    body.quat = quat


def _remove_unused_fingers(spec: mujoco.MjSpec, keep: set[str], palm: str, held: dict[str, float]) -> None:
    """Delete the subtree of every body whose joint the grasp does not use. The joints between the world and
    the palm (a mounted hand's free joint, an arm's, a wrist's) are removed instead, each at the angle the hand
    holds it at, which welds the palm; the bodies before the palm collide with nothing, as in the hand model."""
    above = _weld_to_palm(spec, palm, held)
    for geom in spec.geoms:
        if geom.parent.name in above and geom.parent.name != palm:
            geom.contype, geom.conaffinity = 0, 0
    doomed = [joint.parent for joint in spec.joints if joint.name not in keep]
    removed: set[str] = set()
    for body in doomed:
        chain, ancestors = body, set()
        while chain is not None and chain.name != "world":
            ancestors.add(chain.name)
            chain = chain.parent
        if not ancestors & removed:
            removed.add(body.name)
            for equality in list(spec.equalities):  # couplings of removed joints go with them
                names = {equality.name1, equality.name2}
                if any(j.name in names for j in body.find_all(mujoco.mjtObj.mjOBJ_JOINT)):
                    spec.delete(equality)
            spec.delete(body)


def _root_of(spec: mujoco.MjSpec, palm: str, source: Path):
    body = spec.body(palm)
    if body is None:
        raise BadInputError(source, f"palm link '{palm}' is not a body MuJoCo made of the file")
    while body.parent is not None and body.parent.name != "world":
        body = body.parent
    return body


def quaternion(rotation: np.ndarray) -> np.ndarray:
    """MuJoCo's unit quaternion of a rotation matrix."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=float).reshape(9))
    return quat


def _place(body, rotation: np.ndarray, position: np.ndarray) -> None:
    body.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
    body.pos, body.quat = np.asarray(position, dtype=float), quaternion(rotation)


@lru_cache(maxsize=8)
def _palm_in_root(
    source: Path, stamp: float, palm: str, held: tuple[tuple[str, float], ...]
) -> tuple[np.ndarray, np.ndarray]:
    """The palm's rotation and position in the frame of the world's child that holds it, at the joints' zero
    and the held joints' angles."""
    spec = _prepared(source, stamp).copy()
    _weld_to_palm(spec, palm, dict(held))
    _place(_root_of(spec, palm, source), np.eye(3), np.zeros(3))
    model = compile_spec(spec, source)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    b = model.body(palm).id
    return data.xmat[b].reshape(3, 3).copy(), data.xpos[b].copy()


def file_hand_spec(
    hand: Hand,
    grasp: Grasp,
    settings: PhysicsSettings,
    friction: list[float],
    solref: list[float],
    bits: tuple[int, int],
) -> mujoco.MjSpec:
    """A new spec of ``hand``'s own file at ``grasp``'s palm pose, its collision geoms touching the object only
    (``bits``: the hand's contype and conaffinity)."""
    assert hand.model_file is not None and hand.palm_link is not None
    source = Path(hand.model_file)
    spec = _prepared(source, source.stat().st_mtime).copy()
    _remove_unused_fingers(spec, set(hand.file_joint_names), hand.palm_link, hand.held_joints)
    held = tuple(sorted(hand.held_joints.items()))
    rotation, position = _palm_in_root(source, source.stat().st_mtime, hand.palm_link, held)
    placed = grasp.palm_rotation @ rotation.T  # the root's pose that puts the palm at the grasp's
    _place(_root_of(spec, hand.palm_link, source), placed, grasp.palm_position - placed @ position)
    for geom in spec.geoms:
        if geom.contype or geom.conaffinity:
            geom.contype, geom.conaffinity, geom.condim = bits[0], bits[1], 4
            geom.friction, geom.margin, geom.gap = friction, 0.0, 0.0
            geom.solref = solref
    for joint in spec.joints:
        joint.armature = max(float(joint.armature), settings.armature_kg_m2)
        joint.damping = np.maximum(np.asarray(joint.damping, dtype=float), settings.joint_damping_nms_per_rad)
    return spec
