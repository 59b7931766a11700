"""A grasp in the forms other tools load: a GLB scene (Blender, MeshLab, three.js) and a JSON record whose
joint angles are keyed by the hand file's own joint names, so that the grasp replays in the user's simulator.
The record's schema is ``docs/grasp_record.schema.json``."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import Any

import numpy as np
import trimesh

from grasptask.exports.scene_meshes import CONTACT_COLOUR, OBJECT_COLOUR, PALM_COLOUR, GraspScene, spheres_mesh
from grasptask.grasp.grasp_pose import Grasp
from grasptask.hand.hand_model import Hand
from grasptask.verifier.verification import Verification

RECORD_FORMAT = "grasptask.grasp/1"
#: the contacts' spheres in the GLB (m): big enough to see beside a fingertip, small enough not to hide it
CONTACT_RADIUS = 0.002


def _coloured(mesh: trimesh.Trimesh, colour: str, name: str, alpha: float = 1.0) -> trimesh.Trimesh:
    """A copy of ``mesh`` with one PBR material (glTF viewers show a material's colour, not always vertex
    colours)."""
    rgba = trimesh.visual.color.hex_to_rgba(colour)
    rgba[3] = round(255 * alpha)
    material = trimesh.visual.material.PBRMaterial(
        name=name, baseColorFactor=rgba, metallicFactor=0.0, roughnessFactor=0.8,
        alphaMode="BLEND" if alpha < 1.0 else "OPAQUE",
    )  # fmt: skip
    out = mesh.copy()
    out.visual = trimesh.visual.TextureVisuals(material=material)
    return out


def glb_scene(scene: GraspScene) -> trimesh.Scene:
    """The grasp as a glTF scene in the object frame: nodes ``object``, ``palm``, ``finger_<name>`` (the
    collision spheres, a colour per finger) and ``contact_<name>``."""
    out = trimesh.Scene()
    out.add_geometry(_coloured(scene.object_mesh, OBJECT_COLOUR, "object", 0.6), node_name="object", geom_name="object")
    out.add_geometry(_coloured(scene.palm, PALM_COLOUR, "palm"), node_name="palm", geom_name="palm")
    for finger, point in zip(scene.fingers, scene.contacts, strict=True):
        name = f"finger_{finger.name}"
        out.add_geometry(_coloured(finger.mesh, finger.colour, name), node_name=name, geom_name=name)
        name = f"contact_{finger.name}"
        ball = spheres_mesh(point[None], np.array([CONTACT_RADIUS]), subdivisions=2)
        out.add_geometry(_coloured(ball, CONTACT_COLOUR, name), node_name=name, geom_name=name)
    return out


def glb_bytes(scene: GraspScene) -> bytes:
    return glb_scene(scene).export(file_type="glb")


def palm_pose(grasp: Grasp) -> np.ndarray:
    """The palm frame in the object frame as a 4x4 homogeneous matrix."""
    pose = np.eye(4)
    pose[:3, :3], pose[:3, 3] = grasp.palm_rotation, grasp.palm_position
    return pose


def _vector(values: np.ndarray) -> list[float]:
    return [float(v) for v in np.asarray(values).ravel()]


def _figures(verification: Verification, fingers: list[str]) -> dict[str, Any]:
    """The verifier's figures, per finger where there is one per finger, without the ``verify_`` prefix."""
    flat = verification.record(fingers)
    figures = {k[len("verify_") :]: v for k, v in flat.items() if k.startswith("verify_") and k != "verify_failures"}
    return {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in figures.items()}


def _by_joint(names: list[str], values: Iterable[float], merge: Callable[[float, float], float]) -> dict[str, float]:
    """``values`` by joint name, a name given twice (a joint two fingers share) merged with ``merge``."""
    out: dict[str, float] = {}
    for name, value in zip(names, values, strict=True):
        out[name] = float(merge(out[name], value)) if name in out else float(value)
    return out


def grasp_record(
    *,
    task: str,
    row: Mapping[str, Any],
    hand: Hand,
    grasp: Grasp,
    scene: GraspScene,
    verification: Verification,
    sources: Mapping[str, str],
) -> dict[str, Any]:
    """One grasp as a JSON-ready record (``docs/grasp_record.schema.json``): ``row`` is its solutions or optima
    row, ``hand`` the grasping hand it was solved with, ``verification`` the verifier's judgement of it now
    (its LP gives the contact forces and activations per task wrench) and ``sources`` the input files."""
    fingers = list(hand.fingers)
    joints = hand.file_joint_names  # the hand file's names: a joint two fingers share is one entry, its torque summed
    optimum = row.get("optimum_id")
    wrenches = _wrench_loads(verification, fingers, joints, list(hand.capability.actuators))
    contacts = [
        {
            "finger": finger.name,
            "pad": _vector(finger.pad),
            "pad_normal": _vector(finger.pad_normal),
            "fingertip_centre": _vector(finger.tip_centre),
            "fingertip_radius": float(finger.tip_radius),
            "surface_point": _vector(surface),
            "normal": _vector(normal),
        }
        for finger, surface, normal in zip(scene.fingers, verification.contacts, scene.normals, strict=True)
    ]
    return {
        "format": RECORD_FORMAT,
        "task": task,
        "start_id": int(row["start_id"]),
        "optimum_id": None if optimum is None or optimum != optimum else int(optimum),
        "members": int(row["members"]) if "members" in row else None,
        "hand": {
            "name": hand.name,
            "file": sources.get("hand", ""),
            "fingers": fingers,
            "capability": hand.capability.kind,
        },
        "object": {"file": sources.get("object", "")},
        "units": {"length": "m", "angle": "rad", "force": "N", "torque": "N.m"},
        "frame": "object",
        "joint_angles": _by_joint(joints, grasp.joint_angles, lambda first, _: first),
        "palm_pose": palm_pose(grasp).tolist(),
        "contacts": contacts,
        "friction_coefficient": float(scene.mu),
        "wrenches": wrenches,
        "Q": float(row["Q"]),
        "verification": {
            "verified": verification.ok,
            "failures": list(verification.failures),
            "figures": _figures(verification, fingers),
        },
    }


def _wrench_loads(
    verification: Verification, fingers: list[str], joints: list[str], actuators: list[str]
) -> list[dict[str, Any]]:
    """How the grasp applies each task wrench, as the verifier's LP found it: contact forces, joint torques (a
    joint two fingers share summed) and activations."""
    return [
        {
            "axis": k // 2 + 1,
            "sign": 1 if k % 2 == 0 else -1,
            "wrench": _vector(load.wrench),
            "contact_forces": {f: _vector(v) for f, v in zip(fingers, load.contact_forces, strict=True)},
            "joint_torques": _by_joint(joints, load.joint_torques, lambda a, b: a + b),
            "activations": {a: float(v) for a, v in zip(actuators, load.activations, strict=True)},
        }
        for k, load in enumerate(verification.loads)
    ]
