"""Object configs (``configs/objects/*.yaml``)::

    type: superquadric
    name: sensorized_tool
    size_m: [0.01, 0.01, 0.10]        # half-sizes a1, a2, a3
    exponents: [0.1, 1.0]             # e1, e2
    pose: {position_m: [0, 0, 0], rotation_rpy_deg: [0, 0, 0]}

    type: gp
    name: mug
    mesh: ../../data/objects/mug.stl  # or points_csv: a CSV with columns x, y, z, nx, ny, nz (outward normals)
    n_support: 250                    # surface support points to start from (spread evenly)
    max_support: 500                  # more are added where the fit misses the surface by over tolerance_m
    tolerance_m: 0.0005
    seed: 0

    type: mesh
    name: knife
    mesh: ../../data/objects/knife.stl  # or points: a point cloud with normals (CSV x,y,z,nx,ny,nz, or PLY)
    unit: mm                          # the file's length unit: m (default), cm or mm
    task_frame: {origin_m: [0, 0, 0.05], rotation_rpy_deg: [0, 0, 0]}  # where the task's wrenches act,
                                      # in the file's frame (metres); by default the file's own origin and axes
    pose: {position_m: [0, 0, 0], rotation_rpy_deg: [0, 0, 0]}  # the file's frame in the world (kept)
    mass_kg: 0.08
    grid_spacing_m: 0.0025            # the synthesis surrogate's grid; finer for blades and thin shafts

A mesh or point-cloud file can also be given directly (``--object thing.obj``): metres, its own frame as the
task frame. A mesh or cloud object lives in its task frame, so grasps are reported in it.

Paths are relative to the config file. An optional ``symmetry`` entry, ``{rotation_axis: z, flip_axis: z}``
(or ``rotation_axis: any`` for a sphere), describes the object's symmetry for clustering grasps; the loaded
object carries it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from scipy.spatial.transform import Rotation

from grasptask.errors import BadInputError, existing_file
from grasptask.io.config import load_yaml, number, numbers, reject_unknown, require, whole
from grasptask.objects.gp import GPImplicitSurface
from grasptask.objects.mesh_file import CLOUD_SUFFIXES, MESH_SUFFIXES, read_cloud, read_mesh, unit_scale
from grasptask.objects.mesh_object import GRID_SPACING_M, MeshObject, PointCloudObject
from grasptask.objects.superquadric import Superquadric
from grasptask.objects.surface import ImplicitObject, Symmetry
from grasptask.paths import DEFAULT_OBJECT

#: the largest half-size of an object, in metres: a hand grasps nothing bigger
MAX_SIZE_M = 2.0


def load_object(path: str | Path = DEFAULT_OBJECT, say: Callable[[str], Any] = print) -> ImplicitObject:
    """An object from its YAML config, or a mesh or point-cloud file itself, every field checked: a one-line
    error names the file and the field at fault. ``say`` reports a repaired mesh."""
    path = Path(path)
    if path.suffix.lower() in MESH_SUFFIXES + CLOUD_SUFFIXES:
        return mesh_object(existing_file(path, "object file"), {}, path, say)
    data = load_yaml(path)
    kind = require(data, "type", path, str)
    common = {"type", "name", "description", "symmetry"}
    symmetry = _symmetry(data.get("symmetry"), path)
    name = str(data.get("name", path.stem))
    if kind == "superquadric":
        reject_unknown(data, common | {"size_m", "exponents", "pose"}, path)
        size = numbers(data.get("size_m"), path, "size_m", 3)
        e1, e2 = numbers(data.get("exponents"), path, "exponents", 2)
        if np.any(size < 1e-3) or np.any(size > MAX_SIZE_M) or not (0.05 <= e1 <= 2 and 0.05 <= e2 <= 2):
            raise BadInputError(path, f"need 3 half-sizes in [0.001, {MAX_SIZE_M:g}] m and exponents in [0.05, 2]")
        pose = _frame(data.get("pose"), path, "pose", "position_m")
        return Superquadric(size, float(e1), float(e2), pose[:3, :3], pose[:3, 3], name, symmetry)
    if kind == "gp":
        allowed = {"mesh", "points_csv", "n_support", "max_support", "tolerance_m", "seed", "n_samples"}
        reject_unknown(data, common | allowed, path)
        n_support = whole(data.get("n_support", 250), path, "n_support", minimum=4)
        max_support = whole(data.get("max_support", 500), path, "max_support", minimum=n_support)
        tolerance = number(data.get("tolerance_m", 5e-4), path, "tolerance_m", positive=True)
        seed = whole(data.get("seed", 0), path, "seed")
        points, normals = _surface_samples(path, data)
        gp = GPImplicitSurface.fit(
            points, normals, n_support=n_support, max_support=max_support, tolerance=tolerance, seed=seed, name=name
        )
        return replace(gp, symmetry=symmetry)
    if kind == "mesh":
        fields = {"mesh", "points", "unit", "pose", "task_frame", "mass_kg", "grid_spacing_m"}
        reject_unknown(data, common | fields, path)
        keys = [k for k in ("mesh", "points") if k in data]
        if len(keys) != 1:
            raise BadInputError(path, "a mesh object needs one of 'mesh' (a triangle mesh) or 'points' (a point cloud)")
        source = path.parent / str(require(data, keys[0], path, str))
        if not source.is_file():
            raise BadInputError(path, f"field '{keys[0]}': file not found: {source}")
        return mesh_object(source, data, path, say, cloud=keys[0] == "points")
    raise BadInputError(path, f"unknown object type '{kind}' (known: superquadric, gp, mesh)")


def _frame(value: object, path: Path, name: str, position_key: str) -> np.ndarray:
    """A 4 x 4 transform from ``{position_key: [x, y, z], rotation_rpy_deg: [r, p, y]}``."""
    value = value or {}
    if not isinstance(value, dict):
        raise BadInputError(path, f"field '{name}' must be a mapping, got {value!r}")
    reject_unknown(value, {position_key, "rotation_rpy_deg"}, path, f"{name}.")
    frame = np.eye(4)
    rpy = numbers(value.get("rotation_rpy_deg", [0, 0, 0]), path, f"{name}.rotation_rpy_deg", 3)
    frame[:3, :3] = Rotation.from_euler("xyz", rpy, degrees=True).as_matrix()
    frame[:3, 3] = numbers(value.get(position_key, [0, 0, 0]), path, f"{name}.{position_key}", 3)
    if np.abs(frame[:3, 3]).max() > MAX_SIZE_M:
        raise BadInputError(path, f"field '{name}.{position_key}' must lie within {MAX_SIZE_M:g} m of the origin")
    return frame


def mesh_object(
    source: Path, data: dict, path: Path, say: Callable[[str], Any] = print, cloud: bool | None = None
) -> ImplicitObject:
    """A mesh or point cloud in its task frame (``task_frame`` in the file's own frame, after ``unit``; by
    default the file's own origin and axes)."""
    unit = str(data.get("unit", "m"))
    unit_scale(unit, path)
    task_frame = _frame(data.get("task_frame"), path, "task_frame", "origin_m")
    pose = _frame(data.get("pose"), path, "pose", "position_m")
    mass = number(data["mass_kg"], path, "mass_kg", positive=True) if "mass_kg" in data else None
    spacing = number(data.get("grid_spacing_m", GRID_SPACING_M), path, "grid_spacing_m", positive=True)
    if not 5e-4 <= spacing <= 0.01:
        raise BadInputError(path, f"field 'grid_spacing_m' must lie in [0.0005, 0.01] m, got {spacing}")
    name = str(data.get("name", source.stem))
    symmetry = _symmetry(data.get("symmetry"), path)
    if cloud is None:  # a file given directly: a CSV is a cloud, a PLY is a cloud when it has no faces
        cloud = source.suffix.lower() == ".csv" or (source.suffix.lower() == ".ply" and not _has_faces(source))
    into_task = np.linalg.inv(task_frame)
    if cloud:
        points = read_cloud(source, unit)
        rotation = into_task[:3, :3]
        return PointCloudObject(
            points.points @ rotation.T + into_task[:3, 3], points.normals @ rotation.T, name, symmetry, mass,
            pose @ task_frame, spacing,
        )  # fmt: skip
    mesh = read_mesh(source, unit, say)
    mesh.apply_transform(into_task)
    return MeshObject(mesh, name, symmetry, mass, pose @ task_frame, spacing)


def _has_faces(source: Path) -> bool:
    try:
        return len(getattr(trimesh.load(source), "faces", ())) > 0
    except Exception:  # noqa: BLE001 - read_mesh or read_cloud says what is wrong with it
        return False


def object_files(path: str | Path) -> list[Path]:
    """The object config and the mesh or point file it names: what a sweep on it depends on."""
    path = Path(path)
    if path.suffix.lower() in MESH_SUFFIXES + CLOUD_SUFFIXES:
        return [path]
    data = load_yaml(path)
    named = [path.parent / str(data[key]) for key in ("mesh", "points", "points_csv") if key in data]
    return [path, *(p for p in named if p.is_file())]


SYMMETRY_AXES = {"rotation_axis": ("z", "any"), "flip_axis": ("z",)}


def _symmetry(value: object, path: Path) -> Symmetry | None:
    if value is None:
        return None
    if not isinstance(value, dict):
        raise BadInputError(path, f"field 'symmetry' must be a mapping, got {value!r}")
    reject_unknown(value, set(SYMMETRY_AXES), path, "symmetry.")
    for key, allowed in SYMMETRY_AXES.items():
        if key in value and value[key] not in allowed:
            raise BadInputError(path, f"field 'symmetry.{key}' must be one of {', '.join(allowed)}, got {value[key]!r}")
    return {str(k): str(v) for k, v in value.items()}


def _surface_samples(path: Path, data: dict) -> tuple[np.ndarray, np.ndarray]:
    if "mesh" in data:
        mesh_path = path.parent / str(data["mesh"])
        if not mesh_path.is_file():
            raise BadInputError(path, f"mesh file not found: {mesh_path}")
        count = whole(data.get("n_samples", 6000), path, "n_samples", minimum=100)
        return MeshObject(read_mesh(mesh_path)).surface_samples(count)
    if "points_csv" in data:
        csv = path.parent / str(data["points_csv"])
        if not csv.is_file():
            raise BadInputError(path, f"point file not found: {csv}")
        cloud = read_cloud(csv)
        return cloud.points, cloud.normals
    raise BadInputError(path, "a gp object needs 'mesh' or 'points_csv'")
