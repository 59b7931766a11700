"""The MuJoCo scene of one grasp: the hand welded to the world at its palm pose, its tendons or motors as MuJoCo
actuators, and the object a free body of convex parts in the object (task) frame, which is the world frame at
the start.

A hand read from a URDF or MJCF file is simulated from that file, with its own collision geometry, joint limits
and couplings (:mod:`grasptask.physics.hand_file`). The human hand, which has no file, is built from the
project's kinematic chains and collision spheres, with a pad sphere on each fingertip touching the synthesized
contact: the soft pulp the grasp presses with."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np
import trimesh

from grasptask.grasp.grasp_pose import Grasp
from grasptask.hand.hand_model import Hand
from grasptask.hand.kinematics import forward
from grasptask.io import cache
from grasptask.objects.mesh_object import MeshObject
from grasptask.objects.surface import ImplicitObject
from grasptask.physics.hand_file import compile_spec, file_hand_spec, quaternion
from grasptask.physics.physics_settings import PhysicsSettings
from grasptask.progress import building

#: contype / conaffinity bits: hand geoms touch the object only, never each other
HAND_BIT, OBJECT_BIT = 2, 1
#: a mesh counts as convex when its hull adds less than this fraction to its volume
CONVEX_VOLUME_EXCESS = 0.02
#: triangles of a formula object's surface for MuJoCo. At 4,000 the paper's cylinder's facets were up to 11 degrees
#: off its normals, and one drawing grasp turned about the axis (a symmetry of the object) was held at 2 of 12
#: turns; at 40,000 (within 2.7 degrees) at all 12, for a quarter more time per grasp (docs/design/synthesis.md)
PICTURE_FACES = 40_000
#: the contacts' time constant (MuJoCo's solref[0]), at least twice the timestep
CONTACT_TIME_CONSTANT_S = 0.004
#: every finger link's mass and inertia in the project's model: a phalanx's order of magnitude, small beside the
#: joints' armature
LINK_MASS_KG, LINK_INERTIA_KG_M2 = 0.01, 1e-6
#: the project's model names its joints ``hand/<joint>``; a hand file's keep the file's names
PROJECT_PREFIX = "hand/"


@dataclass(frozen=True)
class ObjectBody:
    """The object as MuJoCo sees it: convex parts in the object frame, and its mass."""

    parts: tuple[trimesh.Trimesh, ...]
    mass_kg: float


@dataclass(frozen=True)
class Scene:
    """A compiled scene and where its pieces are: the hand's joint addresses, one per joint the scene simulates
    (``columns`` picks them from ``hand.joint_names``: a joint two fingers share is one joint here), the
    object's free joint, the force capability (``T tau = A a``, times the scene's strength) and ``T^T A``, the
    joint torques each actuator gives at full activation; each grasping finger's pad (a point fixed in the body
    of its last joint) and the synthesized contact it was placed at."""

    model: mujoco.MjModel
    hand_qpos: np.ndarray
    hand_dof: np.ndarray
    object_body: int
    object_qpos: int
    transmission: np.ndarray  # T (rows x joints)
    torque_map: np.ndarray  # A (rows x actuators)
    actuation: np.ndarray  # T^T A (joints x actuators)
    motors: bool  # each actuator a motor pushing both ways, as [E, -E]
    posture: np.ndarray  # the synthesized joint angles
    pad_bodies: np.ndarray  # (b,) body ids
    pad_points: np.ndarray  # (b, 3) in those bodies' frames
    contacts: np.ndarray  # (b, 3) the synthesized contacts, object frame
    normals: np.ndarray  # (b, 3) the object's outward normals there
    friction: float
    hand_geoms: np.ndarray  # (ngeom,) bool: a geom of the hand that touches the object
    finger_of_body: np.ndarray  # (nbody,) the grasping finger whose joints move the body, -1 for none
    object_geoms: np.ndarray  # the object's geom ids
    #: for each simulated joint, its column in ``hand.joint_names``; for each of those, its simulated joint
    columns: np.ndarray
    expand: np.ndarray
    #: the grasping fingers' names, in the pads' order, and the actuators' strength factor
    finger_names: tuple[str, ...]
    strength: float
    #: the bodies of the flat pads, whose contacts resist a twist about their normal (the grip controller plans
    #: it, within MuJoCo's torsional friction there)
    soft_bodies: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    #: what ``model`` was compiled from (an exported scene is written from it)
    spec: mujoco.MjSpec | None = field(default=None, compare=False)

    def to_hand(self, q: np.ndarray) -> np.ndarray:
        """Simulated joint values in ``hand.joint_names`` order (a shared joint's value in each finger)."""
        return q[..., self.expand]

    def from_hand(self, q: np.ndarray) -> np.ndarray:
        """``hand.joint_names``-ordered values for the simulated joints."""
        return q[..., self.columns]

    @property
    def finger_count(self) -> int:
        return len(self.pad_bodies)


#: CoACD's concavity threshold and seed: what shapes an object's parts (with the mesh, part of the cache's key)
COACD_THRESHOLD, COACD_SEED = 0.05, 0


def convex_parts(mesh: trimesh.Trimesh, name: str = "object") -> tuple[trimesh.Trimesh, ...]:
    """``mesh``'s hull when it is convex, else a CoACD decomposition's hulls; made once per mesh and settings and
    kept (:mod:`grasptask.io.cache`): a scan's took a minute, for ``physics`` and ``export`` alike."""
    from importlib.metadata import version

    vertices, faces = np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)
    digest = cache.key("convex", vertices, faces, CONVEX_VOLUME_EXCESS, COACD_THRESHOLD, COACD_SEED, version("coacd"))
    with building(f"{name}: its convex parts for MuJoCo (CoACD)") as notes:
        entry = cache.cached("convex", digest, lambda: _packed(_decomposed(mesh)), _check_parts)
        notes.append(f"kept in {entry.path} for later runs" if entry.path else "not kept (no cache)")
    arrays = entry.arrays
    starts = np.concatenate([[0], np.cumsum(arrays["vertex_counts"])])
    firsts = np.concatenate([[0], np.cumsum(arrays["face_counts"])])
    return tuple(
        trimesh.Trimesh(
            arrays["vertices"][starts[k] : starts[k + 1]], arrays["faces"][firsts[k] : firsts[k + 1]], process=False
        )  # fmt: skip
        for k in range(len(arrays["vertex_counts"]))
    )


def _decomposed(mesh: trimesh.Trimesh) -> tuple[trimesh.Trimesh, ...]:
    hull = mesh.convex_hull
    if hull.volume <= (1 + CONVEX_VOLUME_EXCESS) * abs(mesh.volume):
        return (hull,)
    import coacd  # heavy, and needed for non-convex objects only

    coacd.set_log_level("error")
    pieces = coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces), threshold=COACD_THRESHOLD, seed=COACD_SEED)
    return tuple(trimesh.Trimesh(v, f).convex_hull for v, f in pieces)


def _packed(parts: tuple[trimesh.Trimesh, ...]) -> dict[str, np.ndarray]:
    """The parts as four plain arrays: stacked vertices and faces (each part's faces counted from its own first
    vertex), and each part's counts."""
    return {
        "vertices": np.vstack([np.asarray(p.vertices, dtype=np.float64) for p in parts]),
        "faces": np.vstack([np.asarray(p.faces, dtype=np.int64) for p in parts]),
        "vertex_counts": np.array([len(p.vertices) for p in parts], dtype=np.int64),
        "face_counts": np.array([len(p.faces) for p in parts], dtype=np.int64),
    }


def _check_parts(arrays: dict[str, np.ndarray]) -> None:
    """Parts MuJoCo can take: finite vertices, each part's faces within its own vertices, at least one part."""
    vertices, faces = arrays["vertices"], arrays["faces"]
    counts, face_counts = arrays["vertex_counts"], arrays["face_counts"]
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError("parts of the wrong shape")
    if not len(counts) or len(counts) != len(face_counts) or counts.min() < 4 or face_counts.min() < 4:
        raise ValueError("no parts, or a part of fewer than 4 vertices or faces")
    if counts.sum() != len(vertices) or face_counts.sum() != len(faces) or not np.isfinite(vertices).all():
        raise ValueError("counts that do not add up, or vertices that are not finite")
    limit = np.repeat(counts, face_counts)
    if faces.min() < 0 or (faces.max(axis=1) >= limit).any():
        raise ValueError("a face names a vertex its part does not have")


def object_body(obj: ImplicitObject, settings: PhysicsSettings) -> ObjectBody:
    """``obj``'s convex parts and mass."""
    if isinstance(obj, MeshObject):
        mesh = obj.mesh
    else:  # marching cubes cuts inside the surface by up to its spacing: its vertices moved onto g = 0
        mesh = obj.picture(PICTURE_FACES)
        mesh = trimesh.Trimesh(obj.project(mesh.vertices), mesh.faces)
    mass = getattr(obj, "mass_kg", None) or settings.object_mass_kg
    return ObjectBody(convex_parts(mesh, getattr(obj, "name", "object")), float(mass))


def _collider(body, size: float, pos: np.ndarray, friction: list[float]) -> None:
    """A hand sphere, which touches the object only."""
    body.add_geom(
        type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[size, 0, 0], pos=pos, contype=HAND_BIT, conaffinity=OBJECT_BIT,
        condim=4, friction=friction,
    )  # fmt: skip


def pad_contacts(hand: Hand, obj: ImplicitObject, grasp: Grasp) -> tuple[np.ndarray, np.ndarray]:
    """Each grasping finger's contact, where its fingertip sphere comes nearest the object (the pad point for a
    pad without one), and the object's own outward normal there (not the NLP's)."""
    pose = forward(hand, grasp.joint_angles, grasp.palm_rotation, grasp.palm_position)
    rounded = np.array([f.pad.radius > 0 for f in hand.fingers.values()])
    centres = np.where(rounded[:, None], pose.pad_centres()[0], pose.contacts()[0])
    nearest, normals = obj.closest_point(centres, exact=True)
    contacts = np.where(rounded[:, None], nearest, pose.contacts()[0])
    return contacts, np.asarray(normals, dtype=float)


def _add_project_hand(
    spec: mujoco.MjSpec, hand: Hand, grasp: Grasp, contacts: np.ndarray, normals: np.ndarray, settings, friction
) -> None:
    """The palm welded to the world at ``(R_h, d_h)``; each finger a chain of hinge bodies, as in
    :func:`grasptask.hand.kinematics.finger_forward` (a joint's body sits at its offset, turned by its fixed
    rotation, and turns about its axis), its last link carrying a pad sphere of the finger's radius touching the
    object at the contact, its centre on the object's outward normal there. The collision spheres sample the
    links' inside; the fingertip's are shrunk by the compliance, the pulp that gives over the whole distal
    phalanx and not only at the pad. Kept whole, they sank 2 mm into a scan's flat faces, seating opened the
    fingers 1.3-4.5 degrees off their contacts, and 8-66% of the scans' verified grasps held
    (docs/design/physics.md)."""
    pose = forward(hand, grasp.joint_angles, grasp.palm_rotation, grasp.palm_position)
    palm = spec.worldbody.add_body(name="palm", pos=grasp.palm_position, quat=quaternion(grasp.palm_rotation))
    for point, radius in zip(hand.palm.points, hand.palm.radii, strict=True):
        _collider(palm, float(radius), point, friction)
    for f, (finger, placed) in enumerate(zip(hand.fingers.values(), pose.fingers.values(), strict=True)):
        parent = palm
        for k, joint in enumerate(finger.joints):
            quat = [1.0, 0, 0, 0] if joint.rotation is None else quaternion(joint.rotation)
            body = parent.add_body(name=f"link/{joint.name}", pos=joint.offset, quat=quat)
            # a phalanx's own inertia, stated rather than taken from the spheres (a link may carry none)
            body.explicitinertial, body.mass, body.inertia = True, LINK_MASS_KG, [LINK_INERTIA_KG_M2] * 3
            body.add_joint(
                name=f"{PROJECT_PREFIX}{joint.name}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=joint.axis,
                range=[joint.lower, joint.upper], armature=settings.armature_kg_m2,
                damping=settings.joint_damping_nms_per_rad,
            )  # fmt: skip
            # the fingertip's other spheres are its rigid core: the pulp over them gives by the hand's
            # compliance, as the pad's does (placed touching, its compression folded into the pose)
            pulp = hand.compliance_m if k == finger.n_joints - 1 else 0.0
            for sphere in finger.spheres:
                if sphere.link == k and sphere.radius > pulp:
                    _collider(body, sphere.radius - pulp, sphere.center, friction)
            parent = body
        rotation, origin = placed.link_rotations[0, -1], placed.joint_positions[0, finger.n_joints - 1]
        _collider(parent, finger.radius, rotation.T @ (contacts[f] + finger.radius * normals[f] - origin), friction)
    names = hand.joint_names
    for dependent, independent, ratio, offset in hand.couplings():
        spec.add_equality(
            type=mujoco.mjtEq.mjEQ_JOINT, name1=f"{PROJECT_PREFIX}{names[dependent]}",
            name2=f"{PROJECT_PREFIX}{names[independent]}", data=[offset, ratio] + [0.0] * 10,
        )  # fmt: skip


def _add_actuators(spec: mujoco.MjSpec, joints: list[str], actuation: np.ndarray) -> None:
    """One fixed tendon per actuator, its coefficients a column of ``actuation``, driven with a control in
    [0, 1] at unit gain: MuJoCo then applies exactly ``actuation @ ctrl`` to the joints."""
    for q in range(actuation.shape[1]):
        tendon = spec.add_tendon(name=f"actuator/{q}")
        for k in np.flatnonzero(actuation[:, q]):
            tendon.wrap_joint(joints[k], float(actuation[k, q]))
        spec.add_actuator(
            name=f"actuator/{q}", trntype=mujoco.mjtTrn.mjTRN_TENDON, target=f"actuator/{q}", ctrlrange=[0, 1]
        )


def _add_object(spec: mujoco.MjSpec, body: ObjectBody, friction: list[float]) -> None:
    target = spec.worldbody.add_body(name="object")
    target.add_freejoint(name="object")
    volumes = np.array([part.volume for part in body.parts])
    for k, part in enumerate(body.parts):
        spec.add_mesh(name=f"object/part/{k}", uservert=part.vertices.ravel(), userface=part.faces.ravel())
        target.add_geom(
            type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"object/part/{k}", contype=OBJECT_BIT, conaffinity=HAND_BIT,
            condim=4, friction=friction, mass=body.mass_kg * volumes[k] / volumes.sum(),
        )  # fmt: skip


def _configure(spec: mujoco.MjSpec, settings: PhysicsSettings) -> mujoco.MjSpec:
    spec.modelname = "grasp"
    spec.compiler.degree = False  # joint ranges in radians, as the hand model has them
    spec.option.timestep = settings.timestep_s
    spec.option.gravity = [0.0, 0.0, 0.0]
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    # contacts stiffer than MuJoCo's default (20 ms, about 1 mm of penetration per newton here): a fingertip
    # pad yields a fraction of a millimetre, and the grip the controller adds must reach the contact
    spec.default.geom.solref = [CONTACT_TIME_CONSTANT_S, 1.0]
    return spec


def _fingers_of_bodies(model: mujoco.MjModel, first_joints: list[int]) -> np.ndarray:
    """Each body's grasping finger: the one whose first joint's body it hangs from (-1: the palm, the object)."""
    owner = np.full(model.nbody, -1)
    roots = {int(model.jnt_bodyid[j]): f for f, j in enumerate(first_joints)}
    for b in range(1, model.nbody):  # parents come before their children
        owner[b] = roots.get(b, owner[model.body_parentid[b]])
    return owner


def build_scene(
    hand: Hand,
    obj: ImplicitObject,
    body: ObjectBody,
    grasp: Grasp,
    friction: float,
    settings: PhysicsSettings,
    strength: float = 1.0,
    pad_torsion: float = 0.0,
) -> Scene:
    """The scene of ``grasp`` by ``hand`` (its grasping fingers only, as the NLP sees it) on ``obj``, the hand's
    actuators ``strength`` times as strong as the hand model's, its flat pads twisting with ``pad_torsion`` (m,
    the grasp config's soft-finger coefficient, where more than the scene's: MuJoCo takes the larger)."""
    contact = [friction, settings.torsional_friction_m, 0.0]
    contacts, normals = pad_contacts(hand, obj, grasp)
    spec, source, prefix = _hand_spec(hand, grasp, settings, contact, contacts, normals, pad_torsion)
    _add_object(spec, body, contact)
    unique, columns, expand = _scene_joints(hand.file_joint_names if source is not None else hand.joint_names)
    capability = hand.capability
    transmission, torque_map = capability.transmission[:, columns], strength * capability.torque_map
    actuation = np.linalg.pinv(transmission) @ torque_map  # least-norm tau with T tau = A a (mimic pairs: not T^T)
    joints = [prefix + name for name in unique]
    _add_actuators(spec, joints, actuation)
    model = compile_spec(spec, source or "physics scene")
    ids = [model.joint(name).id for name in joints]
    posture = np.asarray(grasp.joint_angles, dtype=float)[columns]
    data = mujoco.MjData(model)
    data.qpos[model.jnt_qposadr[ids]] = posture
    mujoco.mj_kinematics(model, data)
    last, first = _finger_joint_ids(model, hand, prefix, source is not None)
    pad_bodies = model.jnt_bodyid[last].copy()
    pad_points = np.einsum("bji,bj->bi", data.xmat[pad_bodies].reshape(-1, 3, 3), contacts - data.xpos[pad_bodies])
    object_id = model.body("object").id
    hand_geoms = (model.geom_bodyid != object_id) & ((model.geom_contype | model.geom_conaffinity) != 0)
    return Scene(
        model=model,
        hand_qpos=model.jnt_qposadr[ids].copy(),
        hand_dof=model.jnt_dofadr[ids].copy(),
        object_body=object_id,
        object_qpos=int(model.jnt_qposadr[model.joint("object").id]),
        transmission=transmission,
        torque_map=torque_map,
        actuation=actuation,
        motors=capability.independent_motors,
        posture=posture,
        pad_bodies=pad_bodies,
        pad_points=pad_points,
        contacts=contacts,
        normals=normals,
        friction=friction,
        hand_geoms=hand_geoms,
        finger_of_body=_fingers_of_bodies(model, first),
        object_geoms=np.flatnonzero(model.geom_bodyid == object_id),
        columns=columns,
        expand=expand,
        finger_names=tuple(hand.fingers),
        strength=strength,
        soft_bodies=pad_bodies[[f.pad.flat for f in hand.fingers.values()]],
        spec=spec,
    )


def _scene_joints(names: list[str]) -> tuple[list[str], np.ndarray, np.ndarray]:
    """The scene's joints, and the hand's columns each takes and each column's joint: a hand file's joint two
    fingers share is one joint in MuJoCo, so its copies' columns go (T's columns for a copy and its original
    are equal, so T tau stays the joint's whole torque)."""
    unique = list(dict.fromkeys(names))
    return unique, np.array([names.index(n) for n in unique]), np.array([unique.index(n) for n in names])


def _soft_pads(spec: mujoco.MjSpec, hand: Hand, contact: list[float]) -> None:
    """The collision geoms of each flat-padded fingertip link of a hand file, given ``contact``'s friction."""
    links = {hand.fingertip_links.get(name, name) for name, f in hand.fingers.items() if f.pad.flat}
    for geom in spec.geoms:
        if geom.parent.name in links and (geom.contype or geom.conaffinity):
            geom.friction = contact


def _hand_spec(
    hand: Hand,
    grasp: Grasp,
    settings: PhysicsSettings,
    contact: list[float],
    contacts: np.ndarray,
    normals: np.ndarray,
    pad_torsion: float = 0.0,
) -> tuple[mujoco.MjSpec, Path | None, str]:
    """The scene's spec with the hand in it: a hand file's own bodies (its source file, no prefix; its flat pads
    twisting with ``pad_torsion``), or the project's hand built from its model (no file, its joints prefixed)."""
    if hand.model_file is not None:
        solref = [CONTACT_TIME_CONSTANT_S, 1.0]
        spec = _configure(file_hand_spec(hand, grasp, settings, contact, solref, (HAND_BIT, OBJECT_BIT)), settings)
        _soft_pads(spec, hand, [contact[0], max(contact[1], pad_torsion), 0.0])
        return spec, hand.model_file, ""
    spec = _configure(mujoco.MjSpec(), settings)
    _add_project_hand(spec, hand, grasp, contacts, normals, settings, contact)
    return spec, None, PROJECT_PREFIX


def _finger_joint_ids(model: mujoco.MjModel, hand: Hand, prefix: str, from_file: bool) -> tuple[list[int], list[int]]:
    """Each finger's last joint in ``model``, and its own first one: a link that a shared joint moves belongs to
    no one finger, passive as the palm. A hand file's joints go by the file's names."""
    name = (lambda j: j.file_name) if from_file else (lambda j: j.name)
    last = [model.joint(prefix + name(f.joints[-1])).id for f in hand.fingers.values()]
    shared = hand.shared_joints()
    own = [next((j for j in f.joints if j.file_name not in shared), f.joints[-1]) for f in hand.fingers.values()]
    return last, [model.joint(prefix + name(j)).id for j in own]
