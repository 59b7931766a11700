"""A grasp's physics scene as files MuJoCo loads as they are, anywhere (``grasptask export --mujoco``):

- ``scene.xml``: the scene the physics check built (the hand as its file describes it, converted as the check
  converts it; the object a free body ``object`` of convex parts, with its mesh for show; the palm welded at the
  grasp's pose; the actuators), in the object's task frame, with two keyframes: ``grasp`` (the seated posture,
  the controls that held it) and ``settled`` (where the hand had settled the object, the state every test
  starts from);
- ``meshes/``: every mesh it names, by relative path, so the folder can be moved or zipped;
- ``wrenches.csv`` and ``controls.csv``: what the check applied at every control step of every phase, to replay
  it open loop; ``check.json``: its verdict, thresholds and timing, to compare the replay with."""

from __future__ import annotations

import io
import json
import re
from typing import Any

import mujoco
import numpy as np
import pandas as pd
import trimesh

from grasptask.physics.physics_settings import PhysicsSettings
from grasptask.physics.protocol import PhysicsResult
from grasptask.physics.scene import Scene

SCENE_FILE = "scene.xml"
#: the object's mesh for show: seen, never touched, no mass
SHOW_MESH, SHOW_RGBA = "object/show", [0.85, 0.65, 0.35, 0.5]


def _file_name(name: str, extension: str) -> str:
    return "meshes/" + re.sub(r"[^A-Za-z0-9_.-]+", "_", name) + extension


def _mesh_files(spec: mujoco.MjSpec) -> dict[str, bytes]:
    """Every mesh the scene holds as vertices (the check's convex hulls) moved to a binary STL file beside it:
    MuJoCo keeps mesh vertices in single precision, as STL does."""
    files: dict[str, bytes] = {}
    for mesh in spec.meshes:
        vertices = np.asarray(mesh.uservert, dtype=float).reshape(-1, 3)
        if not len(vertices):
            continue
        name = _file_name(mesh.name, ".stl")
        faces = np.asarray(mesh.userface, dtype=np.int64).reshape(-1, 3)
        files[name] = trimesh.exchange.stl.export_stl(trimesh.Trimesh(vertices, faces, process=False))
        mesh.file, mesh.uservert, mesh.userface = name, [], []
    return files


def _add_show(spec: mujoco.MjSpec, show: trimesh.Trimesh) -> dict[str, bytes]:
    """The object's own mesh on its body, for the eye only (group 1, no contact, no mass)."""
    name = _file_name(SHOW_MESH, ".obj")
    spec.add_mesh(name=SHOW_MESH, file=name)
    spec.body("object").add_geom(
        type=mujoco.mjtGeom.mjGEOM_MESH, meshname=SHOW_MESH, contype=0, conaffinity=0, group=1, mass=0.0,
        rgba=SHOW_RGBA,
    )  # fmt: skip
    return {name: trimesh.exchange.obj.export_obj(show, include_normals=False, include_texture=False).encode()}


def _portable(spec: mujoco.MjSpec) -> None:
    """No path that points outside the folder: textures (a hand file's, for its visuals, which the check
    drops) go, and mesh paths are relative to the scene file."""
    for material in spec.materials:
        material.textures = [""] * len(material.textures)
    for texture in list(spec.textures):
        spec.delete(texture)
    spec.meshdir = spec.texturedir = ""


def _stated_inertia(spec: mujoco.MjSpec, model: mujoco.MjModel) -> None:
    """A stated mass and inertia whose frame the compiler placed (at the body's geoms) written with that frame:
    MuJoCo writes a stated inertia only where its position is stated too."""
    for body in spec.bodies:
        if body.name and body.explicitinertial and np.isnan(body.ipos[0]):
            compiled = model.body(body.name)
            body.ipos, body.iquat, body.inertia = compiled.ipos, compiled.iquat, compiled.inertia


def scene_files(
    scene: Scene, result: PhysicsResult, show: trimesh.Trimesh, settings: PhysicsSettings
) -> dict[str, bytes]:
    """The folder's files by relative path. ``result`` is ``scene``'s check run with ``trace=True``."""
    assert scene.spec is not None and result.settled_state, "the scene's check must keep its trace"
    spec = scene.spec.copy()
    spec.modelname = "grasptask_grasp"
    _portable(spec)
    _stated_inertia(spec, scene.model)
    files = _mesh_files(spec)
    files.update(_add_show(spec, show))
    start, settled = result.start_state, result.settled_state
    spec.add_key(name="grasp", qpos=start["qpos"], qvel=np.zeros_like(start["qvel"]), ctrl=settled["ctrl"])
    spec.add_key(name="settled", qpos=settled["qpos"], qvel=settled["qvel"], ctrl=settled["ctrl"])
    spec.assets = files
    files[SCENE_FILE] = _full_precision(spec.to_xml(), spec.compile())
    actuators = [spec.actuators[k].name for k in range(len(spec.actuators))]
    files["wrenches.csv"], files["controls.csv"] = _timelines(result, actuators)
    files["check.json"] = json.dumps(_check(result, settings), indent=2).encode() + b"\n"
    return files


def _numbers(values: np.ndarray) -> str:
    return " ".join(format(float(v), ".17g") for v in np.ravel(values))


def _full_precision(xml: str, model: mujoco.MjModel) -> bytes:
    """MuJoCo writes six significant digits, a micrometre at a hand's scale, and a replay starts from the
    keyframes: they, the named bodies' poses and the named joints' ranges are written again from ``model`` at a
    double's 17 (the other numbers are the files' own, or sizes)."""
    from lxml import etree  # deferred: only for exported scenes

    root = etree.fromstring(xml.encode())
    for element in root.iter("body"):
        name = element.get("name")
        if name is None:
            continue
        body = model.body(name)
        for attribute, values in (("pos", body.pos), ("quat", body.quat)):
            if element.get(attribute) is not None:
                element.set(attribute, _numbers(values))
    for element in root.iter("joint"):
        name = element.get("name")
        if name is not None and element.get("range") is not None:
            element.set("range", _numbers(model.joint(name).range))
    for element in root.iter("key"):
        key = model.key(element.get("name"))
        for attribute, values in (("qpos", key.qpos), ("qvel", key.qvel), ("ctrl", key.ctrl)):
            if element.get(attribute) is not None:
                element.set(attribute, _numbers(values))
    return etree.tostring(root, encoding="utf-8", xml_declaration=False) + b"\n"


def _timelines(result: PhysicsResult, actuators: list[str]) -> tuple[bytes, bytes]:
    """Per phase and control step: the wrench on the object and the actuators' controls over the step."""
    wrenches, controls = [], []
    for phase, trace in result.traces.items():
        head = {"phase": phase, "time_s": trace.time_s}
        axes = {f"{kind}_{axis}": values[:, k] for kind, values in (("force", trace.force), ("torque", trace.torque))
                for k, axis in enumerate("xyz")}  # fmt: skip
        wrenches.append(pd.DataFrame({**head, **axes}))
        controls.append(pd.DataFrame({**head, **dict(zip(actuators, trace.controls.T, strict=True))}))

    def csv(frames: list[pd.DataFrame]) -> bytes:
        text = io.StringIO()
        pd.concat(frames, ignore_index=True).to_csv(text, index=False, float_format="%.17g")
        return text.getvalue().encode()

    return csv(wrenches), csv(controls)


def _check(result: PhysicsResult, settings: PhysicsSettings) -> dict[str, Any]:
    """What the replay compares with: the verdicts, each phase's worst motion, the thresholds and the step."""
    phases = {"settle": result.settle, **result.tests}
    return {
        "held": result.passed,
        "dexgraspbench_held": result.benchmark_passed,
        "failed_wrench": result.failed_test,
        "phases": {
            name: {"translation_m": m.translation_m, "rotation_deg": m.rotation_deg} for name, m in phases.items()
        },
        "thresholds": {
            "max_translation_m": settings.max_translation_m,
            "max_rotation_deg": settings.max_rotation_deg,
            "benchmark_translation_m": settings.benchmark_translation_m,
            "benchmark_rotation_deg": settings.benchmark_rotation_deg,
        },
        "timestep_s": settings.timestep_s,
        "steps_per_control": max(1, int(round(settings.control_period_s / settings.timestep_s))),
        "mujoco": mujoco.__version__,
    }
