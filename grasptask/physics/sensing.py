"""What a controller and the protocol read from a running scene: the pads, and MuJoCo's own contacts between
the hand and the object (never the NLP's or the verifier's), with their forces and depths."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from grasptask.physics.scene import Scene


def pad_positions(scene: Scene, data: mujoco.MjData) -> np.ndarray:
    """``(b, 3)``: each pad's current world position."""
    rotations = data.xmat[scene.pad_bodies].reshape(-1, 3, 3)
    return data.xpos[scene.pad_bodies] + np.einsum("bij,bj->bi", rotations, scene.pad_points)


def point_jacobian(scene: Scene, data: mujoco.MjData, point: np.ndarray, body: int) -> np.ndarray:
    """``(3, hand joints)``: the velocity of the world point ``point`` fixed to ``body`` per hand joint rate."""
    jacobian = np.zeros((3, scene.model.nv))
    mujoco.mj_jac(scene.model, data, jacobian, None, point, body)
    return jacobian[:, scene.hand_dof]


def pad_jacobians(scene: Scene, data: mujoco.MjData) -> np.ndarray:
    """``(b, 3, hand joints)``: each pad's Jacobian."""
    points = pad_positions(scene, data)
    return np.array([point_jacobian(scene, data, p, int(b)) for p, b in zip(points, scene.pad_bodies, strict=True)])


@dataclass(frozen=True)
class Contacts:
    """The hand-object contacts MuJoCo holds now: their indices in ``data.contact``, points, frames whose first
    row is the normal into the object (the way the hand pushes), the hand body of each, and its depth (m)."""

    index: np.ndarray
    points: np.ndarray  # (m, 3)
    frames: np.ndarray  # (m, 3, 3): rows normal (into the object), first and second tangent
    bodies: np.ndarray  # (m,)
    depths: np.ndarray  # (m,) penetration, positive inside

    def __len__(self) -> int:
        return len(self.index)


def hand_contacts(scene: Scene, data: mujoco.MjData) -> Contacts:
    count = data.ncon
    geoms = data.contact.geom[:count]
    first, second = scene.hand_geoms[geoms[:, 0]], scene.hand_geoms[geoms[:, 1]]
    objects = scene.model.geom_bodyid[geoms] == scene.object_body
    keep = np.flatnonzero((first & objects[:, 1]) | (second & objects[:, 0]))
    frames = data.contact.frame[:count][keep].reshape(-1, 3, 3).copy()
    # MuJoCo's frame points from the first geom to the second, and its contact force in that frame acts on the
    # second: negated whole where the object's geom is first, the frame's rows map a force on the object
    frames[~first[keep]] *= -1.0
    hand_side = np.where(first[keep], geoms[keep, 0], geoms[keep, 1])
    return Contacts(
        index=keep,
        points=data.contact.pos[:count][keep].copy(),
        frames=frames,
        bodies=scene.model.geom_bodyid[hand_side],
        depths=-data.contact.dist[:count][keep].copy(),
    )


@dataclass(frozen=True)
class LinkLoad:
    """One hand link's contacts with the object, their forces summed: the normal load (N), the friction it uses
    (``|f_t| / (mu f_n)``, 1 at the cone's edge) and its load-weighted mean normal into the object (world)."""

    body: int
    load_n: float
    friction_use: float
    normal: np.ndarray


def link_loads(scene: Scene, data: mujoco.MjData, contacts: Contacts, floor_n: float = 1e-2) -> list[LinkLoad]:
    """Each loaded hand link's :class:`LinkLoad`, from MuJoCo's own contact forces (links pressing with
    ``floor_n`` or less are left out). Per link, not per contact: a fingertip pressing with its pad may graze the
    object with a second geom that slides at no load, and it is the link that slips or holds."""
    if not len(contacts):
        return []
    local = np.zeros((len(contacts), 6))
    for k, i in enumerate(contacts.index):
        mujoco.mj_contactForce(scene.model, data, int(i), local[k])
    # world forces on the object: MuJoCo's frame rows are (normal, tangents), ours point into the object
    forces = np.einsum("mj,mji->mi", local[:, :3], contacts.frames)
    loads = []
    for body in np.unique(contacts.bodies):
        mine = contacts.bodies == body
        pressing = (local[mine, 0, None] * contacts.frames[mine, 0]).sum(axis=0)
        if local[mine, 0].sum() <= floor_n or np.linalg.norm(pressing) == 0:
            continue
        normal = pressing / np.linalg.norm(pressing)
        total = forces[mine].sum(axis=0)
        along = float(total @ normal)
        if along <= floor_n:
            continue
        use = float(np.linalg.norm(total - along * normal)) / (scene.friction * along)
        loads.append(LinkLoad(int(body), along, use, normal))
    return loads


def pad_loads(scene: Scene, data: mujoco.MjData, loads: list[LinkLoad]) -> np.ndarray:
    """``(b, 5)``: each grasping finger's pad link now: its normal load (N), friction use, and MuJoCo's contact
    normal there as the object's outward normal in the object's frame; NaN where the pad presses on nothing."""
    pads = np.full((scene.finger_count, 5), np.nan)
    turn = data.xmat[scene.object_body].reshape(3, 3)  # object frame -> world
    for load in loads:
        for f in np.flatnonzero(scene.pad_bodies == load.body):
            pads[f] = [load.load_n, load.friction_use, *(-turn.T @ load.normal)]
    return pads


def penetration_m(scene: Scene, data: mujoco.MjData) -> float:
    """The deepest penetration of the hand's collision geometry into the object now (0 without contact)."""
    return float(hand_contacts(scene, data).depths.max(initial=0.0))
