"""MJCF hands, compiled with ``mujoco``: bodies with their hinge joints, collision geoms, actuators (for the torque
limits), joint equalities (for coupled joints) and fixed tendons that actuators drive (a motor pulling several
joints by their coefficients: the Franka hand's two jaws, the Shadow hand's last two joints of a finger). Visual-
only geoms (``contype`` and ``conaffinity`` 0) and the assets only they use are dropped before compiling, so a
missing visual mesh does not stop loading.

MuJoCo turns a body about its joint's position inside it; the project's link frame sits on the joint, so each body's
geoms and children are shifted by that position. A joint's torque limit is the smallest of its own
``actuatorfrcrange``, an actuator's ``forcerange`` and a motor's ``ctrlrange``, times the actuator's gear; a
tendon's force limit the same, from the actuators on it and its own ``actuatorfrcrange``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from grasptask.errors import BadInputError
from grasptask.hand import skin
from grasptask.hand import spheres as cover
from grasptask.hand.mesh_cover import mesh_shape
from grasptask.hand.tree import Shape, Tree, TreeJoint, TreeLink, TreeTendon


def _frame(position: np.ndarray, quaternion: np.ndarray | None = None) -> np.ndarray:
    import mujoco  # deferred: MuJoCo, only for MJCF hands

    frame = np.eye(4)
    if quaternion is not None:
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, np.asarray(quaternion, dtype=float))
        frame[:3, :3] = rotation.reshape(3, 3)
    frame[:3, 3] = position
    return frame


def visual_free_spec(source: Path):
    """The file's ``MjSpec`` without the visual-only geoms and the assets only they need."""
    import mujoco  # deferred: MuJoCo, only for MJCF hands

    try:
        spec = mujoco.MjSpec.from_file(str(source))
    except ValueError as exc:
        raise BadInputError(source, f"not an MJCF file MuJoCo can read: {str(exc).strip()}") from exc
    used_meshes = set()
    for geom in list(spec.geoms):
        if geom.contype == 0 and geom.conaffinity == 0:
            spec.delete(geom)
        elif geom.meshname:
            used_meshes.add(geom.meshname)
    for mesh in list(spec.meshes):
        if mesh.name not in used_meshes:
            spec.delete(mesh)
    for texture in list(spec.textures):
        spec.delete(texture)
    for material in list(spec.materials):
        material.textures = [""] * len(material.textures)
    return spec


def _compile(source: Path):
    """The compiled model, without the visual-only geoms and the assets only they need."""
    try:
        return visual_free_spec(source).compile()
    except ValueError as exc:
        raise BadInputError(source, f"MuJoCo cannot compile it: {str(exc).strip()}") from exc


def _name(model, kind, index: int, fallback: str) -> str:
    import mujoco  # deferred: MuJoCo, only for MJCF hands

    return mujoco.mj_id2name(model, kind, index) or f"{fallback}{index}"


def _shape(model, g: int, shift: np.ndarray, link: str, source: Path) -> Shape:
    """One collision geom: the spheres covering it, points on its surface, and a mesh's triangles."""
    import mujoco  # deferred: MuJoCo, only for MJCF hands

    kind, size = int(model.geom_type[g]), model.geom_size[g]  # an int: numpy's does not match enums with `in`
    transform = _frame(-shift) @ _frame(model.geom_pos[g], model.geom_quat[g])
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        radius = float(size[0])
        return Shape([(transform[:3, 3].copy(), radius)], skin.sphere(transform[:3, 3], radius), rounded=True)
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        radius, spine = float(size[0]), float(size[1])
        return Shape(cover.capsule(radius, spine, transform), skin.capsule(radius, spine, transform), rounded=True)
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        radius, length = float(size[0]), 2 * float(size[1])
        return Shape(cover.cylinder(radius, length, transform), skin.cylinder(radius, length, transform))
    halves = np.asarray(size, dtype=float)
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return Shape(cover.box(halves, transform), skin.box(halves, transform), box=(halves, transform))
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        return Shape(cover.box(halves, transform), skin.ellipsoid(halves, transform))
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = model.geom_dataid[g]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        vertices = np.asarray(model.mesh_vert[start : start + count], dtype=float)
        first, faces = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
        triangles = np.asarray(model.mesh_face[first : first + faces], dtype=np.int64)
        return mesh_shape(vertices, triangles, transform, link, source)
    return Shape([], np.zeros((0, 3)))  # planes and height fields are scenery, not hand


def _actuator_limit(model, a: int) -> float | None:
    """The largest force (or torque) actuator ``a`` gives: its ``forcerange``, or a motor's ``ctrlrange`` times
    its gain, whichever is less, times its gear; None where it states neither."""
    import mujoco  # deferred: MuJoCo, only for MJCF hands

    gear = abs(float(model.actuator_gear[a, 0]))
    candidates = []
    if model.actuator_forcelimited[a]:
        candidates.append(np.abs(model.actuator_forcerange[a]).max() * gear)
    motor = model.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED and model.actuator_biastype[a] == 0
    if motor and model.actuator_ctrllimited[a]:
        candidates.append(np.abs(model.actuator_ctrlrange[a]).max() * abs(model.actuator_gainprm[a, 0]) * gear)
    return min(candidates) if candidates else None


def _efforts(model, transmission: int) -> dict[int, float]:
    """The limit of every joint (or tendon, by ``transmission``) an actuator drives (N.m, or N), with the
    joint's (tendon's) own ``actuatorfrcrange``."""
    import mujoco  # deferred: MuJoCo, only for MJCF hands

    limits: dict[int, float] = {}
    for a in range(model.nu):
        if model.actuator_trntype[a] != transmission:
            continue
        limit = _actuator_limit(model, a)
        if limit is not None:
            target = int(model.actuator_trnid[a, 0])
            limits[target] = min(limits.get(target, np.inf), limit)
    own = ("jnt_actfrclimited", "jnt_actfrcrange", model.njnt)
    if transmission == mujoco.mjtTrn.mjTRN_TENDON:
        own = ("tendon_actfrclimited", "tendon_actfrcrange", model.ntendon)
    limited, ranges, count = getattr(model, own[0]), getattr(model, own[1]), own[2]
    for j in range(count):
        if limited[j]:
            limits[j] = min(limits.get(j, np.inf), float(np.abs(ranges[j]).max()))
    return limits


def _tendons(model, joint_name: list[str], source: Path) -> list[TreeTendon]:
    """The fixed tendons that an actuator drives, each with its joints' coefficients and its force limit; a
    spatial tendon (wrapping sites or geoms) is refused, as no finger model here follows its path."""
    import mujoco  # deferred: MuJoCo, only for MJCF hands

    efforts = _efforts(model, mujoco.mjtTrn.mjTRN_TENDON)
    driven = {int(model.actuator_trnid[a, 0]) for a in range(model.nu)
              if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_TENDON}  # fmt: skip
    tendons = []
    for t in range(model.ntendon):
        name = _name(model, mujoco.mjtObj.mjOBJ_TENDON, t, "tendon")
        wraps = range(int(model.tendon_adr[t]), int(model.tendon_adr[t] + model.tendon_num[t]))
        if any(model.wrap_type[w] != mujoco.mjtWrap.mjWRAP_JOINT for w in wraps):
            raise BadInputError(
                source, f"tendon '{name}' is spatial (it wraps sites or geoms): only fixed tendons, over joints, "
                "are supported",
            )  # fmt: skip
        if t not in driven:
            continue  # a passive tendon: the physics check keeps it, no motor pulls it
        coefficients: dict[str, float] = {}
        for w in wraps:
            joint = joint_name[int(model.wrap_objid[w])]
            coefficients[joint] = coefficients.get(joint, 0.0) + float(model.wrap_prm[w])
        tendons.append(TreeTendon(name, coefficients, efforts.get(t)))
    return tendons


def _couplings(model, source: Path) -> dict[int, tuple[int, float, float]]:
    """Joint equalities: ``slave -> (master, multiplier, offset)``, linear ones only."""
    import mujoco  # deferred: MuJoCo, only for MJCF hands

    out = {}
    for e in range(model.neq):
        if model.eq_type[e] != mujoco.mjtEq.mjEQ_JOINT or not model.eq_active0[e]:
            continue
        slave, master = int(model.eq_obj1id[e]), int(model.eq_obj2id[e])
        if master < 0:
            name = _name(model, mujoco.mjtObj.mjOBJ_JOINT, slave, "joint")
            raise BadInputError(source, f"joint '{name}': its equality names no second joint")
        polynomial = model.eq_data[e, :5]
        if np.any(np.abs(polynomial[2:]) > 1e-12):
            name = _name(model, mujoco.mjtObj.mjOBJ_JOINT, slave, "joint")
            raise BadInputError(source, f"joint '{name}': only a linear joint coupling (polycoef a0 a1) is supported")
        out[slave] = (master, float(polynomial[1]), float(polynomial[0]))
    return out


def read_mjcf(source: Path) -> Tree:
    """The kinematic tree of an MJCF file."""
    import mujoco  # deferred: MuJoCo, only for MJCF hands

    model = _compile(source)
    body_name = [_name(model, mujoco.mjtObj.mjOBJ_BODY, b, "body") for b in range(model.nbody)]
    joint_name = [_name(model, mujoco.mjtObj.mjOBJ_JOINT, j, "joint") for j in range(model.njnt)]
    shifts = {0: np.zeros(3)}
    for b in range(1, model.nbody):
        count = model.body_jntnum[b]
        if count > 1:
            raise BadInputError(source, f"body '{body_name[b]}' has {count} joints; one joint per body is supported")
        shifts[b] = model.jnt_pos[model.body_jntadr[b]].copy() if count else np.zeros(3)
    efforts, couplings = _efforts(model, mujoco.mjtTrn.mjTRN_JOINT), _couplings(model, source)
    tendons = _tendons(model, joint_name, source)
    links, joints = {}, []
    for b in range(1, model.nbody):
        link = TreeLink(body_name[b])
        for g in np.flatnonzero(model.geom_bodyid == b):
            link.add(_shape(model, int(g), shifts[b], body_name[b], source))
        links[link.name] = link
        parent = int(model.body_parentid[b])
        if parent == 0:
            continue  # a child of the world: a root
        origin = _frame(-shifts[parent]) @ _frame(model.body_pos[b], model.body_quat[b]) @ _frame(shifts[b])
        tree_joint = TreeJoint(f"fixed_{body_name[b]}", "fixed", body_name[parent], body_name[b], origin)
        if model.body_jntnum[b]:
            j = int(model.body_jntadr[b])
            limited = bool(model.jnt_limited[j])
            if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
                kind = "revolute" if limited else "continuous"
            else:
                kind = "prismatic" if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE else "floating"
            tree_joint = TreeJoint(
                name=joint_name[j],
                kind=kind,
                parent=body_name[parent],
                child=body_name[b],
                origin=origin,
                axis=np.asarray(model.jnt_axis[j], dtype=float),
                lower=float(model.jnt_range[j, 0]) if limited else None,
                upper=float(model.jnt_range[j, 1]) if limited else None,
                effort=efforts.get(j),
                mimic=None if j not in couplings else (joint_name[couplings[j][0]], *couplings[j][1:]),
            )
        joints.append(tree_joint)
    return Tree(links, joints, tendons=tendons)
