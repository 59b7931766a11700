"""A grasp's fingers at rest on the object: the least joint motion that leaves no hand geometry deeper than
:data:`SEATED_DEPTH_M` inside it.

A synthesized grasp presses each fingertip into the object by the hand's compliance (the pad's rubber or pulp,
compressed). MuJoCo's geoms are rigid: started there, the overlap is resolved as an impulse in the first
milliseconds, which threw or spun the object before the controller could act (8 of the Allegro's 126 drawing
grasps turned 11-24 degrees while closing, at ten times its strength). A real hand closes onto the object from its
rest shape, so the scene starts there, and the grip controller presses the fingertips in (docs/design/physics.md)."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.optimize import lsq_linear

from grasptask.hand.hand_model import Hand
from grasptask.physics.scene import Scene
from grasptask.physics.sensing import Contacts, hand_contacts, point_jacobian

#: the depth a seated grasp may keep (m), and the steps seating may take
SEATED_DEPTH_M, SEATING_STEPS = 5e-5, 60
#: how many times a step that leaves the hand deeper is halved before seating gives up
HALVINGS = 8
#: the least-squares step's damping (m: a joint's lever, below which it barely moves a point) and its largest size
DAMPING, MAX_STEP_RAD = 1e-3, np.radians(2.0)


@dataclass(frozen=True)
class Seating:
    #: the seated joint angles (None: the grasp could not be seated, and is held as synthesized)
    joints: np.ndarray | None
    #: the deepest penetration of the hand's geometry at the synthesized joints (m)
    synthesized_depth_m: float
    #: the largest joint motion seating took (degrees; 0 when nothing sank deeper than SEATED_DEPTH_M)
    moved_deg: float


def seat(scene: Scene, hand: Hand, joints: np.ndarray) -> Seating:
    """``joints`` opened until no hand geometry sinks deeper than :data:`SEATED_DEPTH_M` into the object: each
    step moves the deep points back out along their contact normals, to a fifth of that depth, by the least
    joint motion (least squares on MuJoCo's own contact depths and Jacobians), halved until the depths beyond
    :data:`SEATED_DEPTH_M` shrink. Not seated when a body no joint moves (the palm) is deeper, no halving
    helps, or the steps run out."""
    data = mujoco.MjData(scene.model)
    start = np.asarray(joints, dtype=float)
    q, coupled = start.copy(), _coupling_map(scene, hand)
    lower, upper = scene.from_hand(hand.lower), scene.from_hand(hand.upper)
    contacts = _contacts_at(scene, data, q)
    first = float(contacts.depths.max(initial=0.0))
    for _ in range(SEATING_STEPS):
        deep = contacts.depths > SEATED_DEPTH_M
        if not deep.any():
            return Seating(q, first, float(np.degrees(np.abs(q - start).max(initial=0.0))))
        if (scene.finger_of_body[contacts.bodies[deep]] < 0).any():
            break
        room = np.array([lower - q, upper - q])
        step, excess = _step(scene, data, contacts, deep, coupled, room), _excess(contacts)
        # a full step can trade one contact for another (MuJoCo's contact set changes within it): halving
        # seated 2 more of the YCB mug's 32 screw-driving grasps
        for _ in range(HALVINGS):
            trial = scene.from_hand(hand.apply_coupling(np.clip(scene.to_hand(q + step), hand.lower, hand.upper)))
            tried = _contacts_at(scene, data, trial)
            if _excess(tried) < excess:
                break
            step = step / 2
        else:
            break
        q, contacts = trial, tried
    return Seating(None, first, float("nan"))


def _contacts_at(scene: Scene, data: mujoco.MjData, q: np.ndarray) -> Contacts:
    data.qpos[scene.hand_qpos] = q
    mujoco.mj_forward(scene.model, data)
    return hand_contacts(scene, data)


def _excess(contacts: Contacts) -> float:
    """How far the seating is from done: the squared depths beyond :data:`SEATED_DEPTH_M`, summed."""
    return float((np.maximum(contacts.depths - SEATED_DEPTH_M, 0.0) ** 2).sum())


def _coupling_map(scene: Scene, hand: Hand) -> np.ndarray:
    """``(n, n)``: simulated joint steps from steps of the joints no coupling drives, ``dq = C dq_free`` (a
    coupled joint's own column is zero). A step blind to the coupling is partly undone by it: the human hand's
    DIP follows its PIP, so a step that moves the DIP alone is put back when the coupling is applied."""
    coupled = np.eye(len(scene.columns))
    for dependent, independent, ratio, _ in hand.couplings():
        d, i = scene.expand[dependent], scene.expand[independent]
        coupled[d, d], coupled[d, i] = 0.0, ratio
    return coupled


def _step(
    scene: Scene, data: mujoco.MjData, contacts: Contacts, deep: np.ndarray, coupled: np.ndarray, room: np.ndarray
) -> np.ndarray:
    """The damped least-squares step of the joints no coupling drives that backs the ``deep`` contacts out to a
    fifth of the seated depth, within ``room`` (``(2, n)``: how far each joint may move down and up). Bounded,
    not clipped after: a finger at its limit (a scanned mug's middle finger, straight at PIP 0 and spread to
    15 degrees) took a step past it, clipping undid it, and the tip sank deeper."""
    free = np.flatnonzero(np.diag(coupled) > 0)
    rows = np.array(
        [frame[0] @ point_jacobian(scene, data, p, int(b))
         for frame, p, b in zip(contacts.frames[deep], contacts.points[deep], contacts.bodies[deep], strict=True)]
    ) @ coupled[:, free]  # fmt: skip
    wanted = -(contacts.depths[deep] - 0.2 * SEATED_DEPTH_M)  # into the object is +normal: back out
    # damped: a joint that barely moves a deep point (a finger's abduction, on a mesh hull's contact) would
    # otherwise take a step across its whole range, and did (54 degrees, the LEAP-like hand's base joints)
    damped = np.vstack([rows, DAMPING * np.eye(len(free))])
    low, high = np.minimum(room[0, free], 0.0), np.maximum(room[1, free], 0.0) + 1e-12  # lsq_linear: low < high
    step = lsq_linear(damped, np.concatenate([wanted, np.zeros(len(free))]), bounds=(low, high)).x
    full = coupled[:, free] @ step
    return full * min(1.0, MAX_STEP_RAD / max(float(np.abs(full).max()), 1e-12))
