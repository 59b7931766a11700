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

from grasptask.hand.hand_model import Hand
from grasptask.physics.scene import Scene
from grasptask.physics.sensing import hand_contacts, point_jacobian

#: the depth a seated grasp may keep (m), and the Gauss-Newton steps it may take
SEATED_DEPTH_M, SEATING_STEPS = 5e-5, 60
#: the Gauss-Newton step's damping (m: a joint's lever, below which it barely moves a point) and its largest size
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
    joint motion (least squares on MuJoCo's own contact depths and Jacobians). Not seated when a body no joint
    moves (the palm) is deeper, or the steps run out."""
    data = mujoco.MjData(scene.model)
    start = np.asarray(joints, dtype=float)
    q, first = start.copy(), None
    for _ in range(SEATING_STEPS):
        data.qpos[scene.hand_qpos] = q
        mujoco.mj_forward(scene.model, data)
        contacts = hand_contacts(scene, data)
        if first is None:
            first = float(contacts.depths.max(initial=0.0))
        deep = contacts.depths > SEATED_DEPTH_M
        if not deep.any():
            return Seating(q, first, float(np.degrees(np.abs(q - start).max(initial=0.0))))
        if (scene.finger_of_body[contacts.bodies[deep]] < 0).any():
            break
        rows = np.array(
            [frame[0] @ point_jacobian(scene, data, p, int(b))
             for frame, p, b in zip(contacts.frames[deep], contacts.points[deep], contacts.bodies[deep], strict=True)]
        )  # fmt: skip
        wanted = -(contacts.depths[deep] - 0.2 * SEATED_DEPTH_M)  # into the object is +normal: back out
        # damped: a joint that barely moves a deep point (a finger's abduction, on a mesh hull's contact) would
        # otherwise take a step across its whole range, and did (54 degrees, the LEAP-like hand's base joints)
        step = np.linalg.solve(rows.T @ rows + DAMPING**2 * np.eye(rows.shape[1]), rows.T @ wanted)
        step *= min(1.0, MAX_STEP_RAD / max(float(np.abs(step).max()), 1e-12))
        q = scene.from_hand(hand.apply_coupling(np.clip(scene.to_hand(q + step), hand.lower, hand.upper)))
    return Seating(None, float(first or 0.0), float("nan"))
