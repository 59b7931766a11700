"""The MuJoCo scene of one grasp: the hand welded to the world at its palm pose, built with ``MjSpec`` from the
project's own kinematic chains and collision spheres, its tendons or motors as MuJoCo actuators, and the object
a free body of convex parts in the object (task) frame, which is the world frame at the start."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import trimesh

from grasptask.grasp.grasp import Grasp
from grasptask.hand.kinematics import forward
from grasptask.hand.model import Hand
from grasptask.objects.mesh_object import MeshObject
from grasptask.objects.surface import ImplicitObject
from grasptask.physics.settings import PhysicsSettings

#: contype / conaffinity bits: hand geoms touch the object only, never each other
_HAND, _OBJECT = 2, 1
#: a mesh counts as convex when its hull adds less than this fraction to its volume
CONVEX_VOLUME_EXCESS = 0.02
#: triangles of a formula object's surface for MuJoCo. At 4,000 the paper's cylinder's facets were up to 11 degrees
#: off its normals, and one drawing grasp turned about the axis (a symmetry of the object) was held at 2 of 12
#: turns; at 40,000 (within 2.7 degrees) at all 12, for a quarter more time per grasp (docs/synthesis-notes.md)
PICTURE_FACES = 40_000
#: the contacts' time constant (MuJoCo's solref[0]), at least twice the timestep
CONTACT_TIME_CONSTANT_S = 0.004
#: every finger link's mass and inertia: a phalanx's order of magnitude, small beside the joints' armature
LINK_MASS_KG, LINK_INERTIA_KG_M2 = 0.01, 1e-6


@dataclass(frozen=True)
class ObjectBody:
    """The object as MuJoCo sees it: convex parts in the object frame, and its mass."""

    parts: tuple[trimesh.Trimesh, ...]
    mass_kg: float


@dataclass(frozen=True)
class Scene:
    """A compiled scene and where its pieces are: the hand's joint addresses in ``hand.joint_names`` order,
    the object's free joint, and the joint torques each actuator gives at full activation (``T^T A``)."""

    model: mujoco.MjModel
    hand_qpos: np.ndarray
    hand_dof: np.ndarray
    object_body: int
    object_qpos: int
    actuation: np.ndarray  # (joints, actuators)
    posture: np.ndarray  # the synthesized joint angles
    pad_sites: np.ndarray  # a site at each pad's contact point
    contacts: np.ndarray  # (b, 3) the synthesized contacts, object frame
    normals: np.ndarray  # (b, 3) the object's outward normals there
    friction: float


def object_body(obj: ImplicitObject, settings: PhysicsSettings) -> ObjectBody:
    """``obj``'s convex parts: its hull when it is convex, else a CoACD decomposition of its mesh."""
    if isinstance(obj, MeshObject):
        mesh = obj.mesh
    else:  # marching cubes cuts inside the surface by up to its spacing: its vertices moved onto g = 0
        mesh = obj.picture(PICTURE_FACES)
        mesh = trimesh.Trimesh(obj.project(mesh.vertices), mesh.faces)
    hull = mesh.convex_hull
    if hull.volume <= (1 + CONVEX_VOLUME_EXCESS) * abs(mesh.volume):
        parts: tuple[trimesh.Trimesh, ...] = (hull,)
    else:
        import coacd

        coacd.set_log_level("error")
        pieces = coacd.run_coacd(coacd.Mesh(mesh.vertices, mesh.faces), threshold=0.05, seed=0)
        parts = tuple(trimesh.Trimesh(v, f).convex_hull for v, f in pieces)
    mass = getattr(obj, "mass_kg", None) or settings.object_mass_kg
    return ObjectBody(parts, float(mass))


def _quaternion(rotation: np.ndarray) -> np.ndarray:
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=float).reshape(9))
    return quat


def _collider(body, size: float, pos: np.ndarray, friction: list[float]) -> None:
    """A hand sphere, which touches the object only."""
    body.add_geom(
        type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[size, 0, 0], pos=pos, contype=_HAND, conaffinity=_OBJECT,
        condim=4, friction=friction,
    )  # fmt: skip


@dataclass(frozen=True)
class Pad:
    """A fingertip pad at the synthesized grasp: a sphere of the finger's radius touching the object at the
    contact, its centre on the object's outward normal there, and the contact point, both in the last link's
    frame; and the contact and outward normal in the object frame. The hand's collision spheres sample the
    links' inside and stop millimetres short of the pad, which is the skin the grasp presses with."""

    centre: np.ndarray
    point: np.ndarray
    contact: np.ndarray
    normal: np.ndarray


def pads(hand: Hand, obj: ImplicitObject, grasp: Grasp) -> dict[str, Pad]:
    """Each grasping finger's :class:`Pad`, from the hand's kinematics and the object's own normals (not the
    NLP's)."""
    pose = forward(hand, grasp.joint_angles, grasp.palm_rotation, grasp.palm_position)
    out = {}
    for (name, finger), placed in zip(hand.fingers.items(), pose.fingers.values(), strict=True):
        contact = placed.contact[0]
        _, normal = obj.closest_point(contact)
        rotation, origin = placed.link_rotations[0, -1], placed.joint_positions[0, finger.n_joints - 1]
        centre = rotation.T @ (contact + finger.radius * normal[0] - origin)
        out[name] = Pad(centre, rotation.T @ (contact - origin), contact, normal[0])
    return out


def _add_hand(
    spec: mujoco.MjSpec, hand: Hand, grasp: Grasp, pads: dict[str, Pad], settings: PhysicsSettings, friction: list
) -> None:
    """The palm welded to the world at ``(R_h, d_h)``; each finger a chain of hinge bodies, as in
    :func:`grasptask.hand.kinematics.finger_forward` (a joint's body sits at its offset, turned by its fixed
    rotation, and turns about its axis), its last link carrying the pad."""
    palm = spec.worldbody.add_body(name="palm", pos=grasp.palm_position, quat=_quaternion(grasp.palm_rotation))
    for point, radius in zip(hand.palm.points, hand.palm.radii, strict=True):
        _collider(palm, float(radius), point, friction)
    for name, finger in hand.fingers.items():
        parent = palm
        for k, joint in enumerate(finger.joints):
            quat = [1.0, 0, 0, 0] if joint.rotation is None else _quaternion(joint.rotation)
            body = parent.add_body(name=f"link/{joint.name}", pos=joint.offset, quat=quat)
            # a phalanx's own inertia, stated rather than taken from the spheres (a link may carry none)
            body.explicitinertial, body.mass, body.inertia = True, LINK_MASS_KG, [LINK_INERTIA_KG_M2] * 3
            body.add_joint(
                name=f"hand/{joint.name}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=joint.axis,
                range=[joint.lower, joint.upper], armature=settings.armature_kg_m2,
            )  # fmt: skip
            for sphere in finger.spheres:
                if sphere.link == k:
                    _collider(body, sphere.radius, sphere.center, friction)
            parent = body
        _collider(parent, finger.radius, pads[name].centre, friction)
        parent.add_site(name=f"pad/{name}", pos=pads[name].point)
    names = hand.joint_names
    for dependent, independent, ratio, offset in hand.couplings():
        spec.add_equality(
            type=mujoco.mjtEq.mjEQ_JOINT, name1=f"hand/{names[dependent]}", name2=f"hand/{names[independent]}",
            data=[offset, ratio] + [0.0] * 10,
        )  # fmt: skip


def actuation_matrix(hand: Hand) -> np.ndarray:
    """The joint torques of each actuator at full activation, ``T^T A`` of :class:`Capability` (``T tau = A a``):
    a tendon's moment arms times its maximal force, a motor's effort on the joints its transmission drives."""
    capability = hand.capability
    return capability.transmission.T @ capability.torque_map


def _add_actuators(spec: mujoco.MjSpec, hand: Hand, actuation: np.ndarray) -> None:
    """One fixed tendon per actuator, its coefficients a column of ``actuation``, driven with a control in
    [0, 1] at unit gain: MuJoCo then applies exactly ``actuation @ ctrl`` to the joints."""
    names = hand.joint_names
    for q in range(actuation.shape[1]):
        tendon = spec.add_tendon(name=f"actuator/{q}")
        for k in np.flatnonzero(actuation[:, q]):
            tendon.wrap_joint(f"hand/{names[k]}", float(actuation[k, q]))
        spec.add_actuator(
            name=f"actuator/{q}", trntype=mujoco.mjtTrn.mjTRN_TENDON, target=f"actuator/{q}", ctrlrange=[0, 1]
        )


def build_scene(
    hand: Hand, obj: ImplicitObject, body: ObjectBody, grasp: Grasp, friction: float, settings: PhysicsSettings
) -> Scene:
    """The scene of ``grasp`` by ``hand`` (its grasping fingers only, as the NLP sees it) on ``obj``."""
    spec = mujoco.MjSpec()
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
    contact = [friction, settings.torsional_friction_m, 0.0]
    target = spec.worldbody.add_body(name="object")
    target.add_freejoint(name="object")
    volumes = np.array([part.volume for part in body.parts])
    for k, part in enumerate(body.parts):
        spec.add_mesh(name=f"part/{k}", uservert=part.vertices.ravel(), userface=part.faces.ravel())
        target.add_geom(
            type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"part/{k}", contype=_OBJECT, conaffinity=_HAND, condim=4,
            friction=contact, mass=body.mass_kg * volumes[k] / volumes.sum(),
        )  # fmt: skip
    placed = pads(hand, obj, grasp)
    _add_hand(spec, hand, grasp, placed, settings, contact)
    actuation = actuation_matrix(hand)
    _add_actuators(spec, hand, actuation)
    model = spec.compile()
    joints = [model.joint(f"hand/{name}").id for name in hand.joint_names]
    free = model.joint("object").id
    return Scene(
        model=model,
        hand_qpos=model.jnt_qposadr[joints].copy(),
        hand_dof=model.jnt_dofadr[joints].copy(),
        object_body=model.body("object").id,
        object_qpos=int(model.jnt_qposadr[free]),
        actuation=actuation,
        posture=np.asarray(grasp.joint_angles, dtype=float),
        pad_sites=np.array([model.site(f"pad/{name}").id for name in hand.fingers]),
        contacts=np.array([p.contact for p in placed.values()]),
        normals=np.array([p.normal for p in placed.values()]),
        friction=friction,
    )
