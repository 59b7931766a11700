"""One grasp as meshes in the object frame: each finger's collision spheres as one body, the palm's, the
object's surface, the fingertip pads and the contacts. The report's interactive views and the GLB export both
draw from it, so the two show the same thing."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from grasptask.grasp.grasp_pose import Grasp
from grasptask.hand.hand_model import Hand
from grasptask.hand.kinematics import forward

FINGER_COLOURS = {"thumb": "#d95f02", "index": "#1b9e77", "middle": "#7570b3", "ring": "#e7298a", "little": "#66a61e"}
#: for fingers by other names (a robot hand's), in order
OTHER_COLOURS = ("#d95f02", "#1b9e77", "#7570b3", "#e7298a", "#66a61e", "#e6ab02")
PALM_COLOUR = "#8c6d31"
OBJECT_COLOUR = "#a0a0a0"
CONTACT_COLOUR = "#d62728"


#: the colours' names, for captions
COLOUR_NAMES = {"#d95f02": "orange", "#1b9e77": "green", "#7570b3": "purple", "#e7298a": "pink",
                "#66a61e": "olive", "#e6ab02": "yellow"}  # fmt: skip


def finger_colour(name: str, index: int) -> str:
    """The colour of finger ``name``, the ``index``-th of its hand: the human fingers' own, else in turn."""
    return FINGER_COLOURS.get(name, OTHER_COLOURS[index % len(OTHER_COLOURS)])


def colour_legend(fingers: list[str]) -> str:
    """``thumb orange, index green, middle purple``: a hand's own fingers by the colours the views give them."""
    return ", ".join(f"{name} {COLOUR_NAMES[finger_colour(name, k)]}" for k, name in enumerate(fingers))


@dataclass(frozen=True)
class FingerBody:
    name: str
    colour: str
    mesh: trimesh.Trimesh  # its collision spheres and its fingertip's sphere, merged
    chain: np.ndarray  # (n+1, 3): the joints' origins, then the fingertip's end
    pad: np.ndarray  # (3,): the pad's home point on the fingertip
    pad_normal: np.ndarray  # (3,): outward from the pad
    tip_centre: np.ndarray  # (3,): the centre of the fingertip's sphere, over which the contact rolls
    tip_radius: float  # its radius (0: the pad is a point)


@dataclass(frozen=True)
class GraspScene:
    """A grasp's geometry in the object frame (m); ``contacts`` are where the fingers touch, ``normals`` the
    object's outward normals there, ``mu`` the friction coefficient of the cones."""

    fingers: tuple[FingerBody, ...]
    palm: trimesh.Trimesh
    object_mesh: trimesh.Trimesh
    contacts: np.ndarray
    normals: np.ndarray
    mu: float


def icosphere_copies(linear: np.ndarray, offsets: np.ndarray, subdivisions: int = 1) -> trimesh.Trimesh:
    """Copies of the unit icosphere as one mesh, copy ``k`` mapped by ``x -> linear[k] @ x + offsets[k]`` (not
    unioned: the bodies are for looking at, not for volumes)."""
    unit = trimesh.creation.icosphere(subdivisions=subdivisions)
    vertices = np.einsum("kij,vj->kvi", np.asarray(linear, dtype=float), unit.vertices)
    vertices = (vertices + np.asarray(offsets, dtype=float)[:, None, :]).reshape(-1, 3)
    faces = (unit.faces[None] + len(unit.vertices) * np.arange(len(offsets))[:, None, None]).reshape(-1, 3)
    return trimesh.Trimesh(vertices, faces, process=False)


def spheres_mesh(centres: np.ndarray, radii: np.ndarray, subdivisions: int = 1) -> trimesh.Trimesh:
    """Spheres of ``radii`` at ``centres`` as one mesh."""
    radii = np.asarray(radii, dtype=float)
    return icosphere_copies(radii[:, None, None] * np.eye(3), np.asarray(centres).reshape(-1, 3), subdivisions)


def grasp_scene(
    hand: Hand,
    object_mesh: trimesh.Trimesh,
    grasp: Grasp,
    contacts: np.ndarray,
    normals: np.ndarray,
    mu: float,
    subdivisions: int = 1,
) -> GraspScene:
    """The scene of ``grasp`` by ``hand`` (its grasping fingers, as the solutions hold them) on the object
    pictured by ``object_mesh``, touching it at ``contacts`` (the verifier's), with the object's outward
    ``normals`` there."""
    pose = forward(hand, grasp.joint_angles, grasp.palm_rotation, grasp.palm_position)
    bodies = []
    for k, (name, finger) in enumerate(pose.fingers.items()):
        radius = hand.fingers[name].pad.radius
        centres, radii = finger.samples[0], finger.radii
        if radius > 0:  # the fingertip's own sphere, which the contact rolls over
            centres, radii = np.vstack([centres, finger.pad_centre]), np.append(radii, radius)
        mesh = spheres_mesh(centres, radii, subdivisions)
        chain, pad, normal = finger.joint_positions[0], finger.contact[0], finger.pad_normal[0]
        bodies.append(FingerBody(name, finger_colour(name, k), mesh, chain, pad, normal, finger.pad_centre[0], radius))
    palm = spheres_mesh(pose.palm_samples[0], pose.palm_radii, subdivisions)
    contacts = np.asarray(contacts, dtype=float)
    return GraspScene(tuple(bodies), palm, object_mesh, contacts, np.asarray(normals, dtype=float), mu)
