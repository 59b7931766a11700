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

Paths are relative to the config file. An optional ``symmetry`` entry, ``{rotation_axis: z, flip_axis: z}``
(or ``rotation_axis: any`` for a sphere), describes the object's symmetry for clustering grasps; the loaded
object carries it.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import trimesh
from scipy.spatial.transform import Rotation

from grasptask.errors import BadInputError
from grasptask.io.config import load_yaml, number, numbers, reject_unknown, require, whole
from grasptask.objects.gp import GPImplicitSurface
from grasptask.objects.superquadric import Superquadric
from grasptask.objects.surface import ImplicitObject, Symmetry
from grasptask.paths import DEFAULT_OBJECT

#: the largest half-size of an object, in metres: a hand grasps nothing bigger
MAX_SIZE_M = 2.0
POINT_COLUMNS = ["x", "y", "z", "nx", "ny", "nz"]


def load_object(path: str | Path = DEFAULT_OBJECT) -> ImplicitObject:
    """An object from its YAML config, every field checked: a one-line error names the field at fault."""
    path = Path(path)
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
        pose = data.get("pose") or {}
        if not isinstance(pose, dict):
            raise BadInputError(path, f"field 'pose' must be a mapping, got {pose!r}")
        reject_unknown(pose, {"position_m", "rotation_rpy_deg"}, path, "pose.")
        rpy = numbers(pose.get("rotation_rpy_deg", [0, 0, 0]), path, "pose.rotation_rpy_deg", 3)
        position = numbers(pose.get("position_m", [0, 0, 0]), path, "pose.position_m", 3)
        if np.abs(position).max() > MAX_SIZE_M:
            raise BadInputError(path, f"field 'pose.position_m' must lie within {MAX_SIZE_M:g} m of the origin")
        rotation = Rotation.from_euler("xyz", rpy, degrees=True).as_matrix()
        return Superquadric(size, float(e1), float(e2), rotation, position, name, symmetry)
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
    raise BadInputError(path, f"unknown object type '{kind}' (known: superquadric, gp)")


def object_files(path: str | Path) -> list[Path]:
    """The object config and the mesh or point file it names: what a sweep on it depends on."""
    path = Path(path)
    data = load_yaml(path)
    named = [path.parent / str(data[key]) for key in ("mesh", "points_csv") if key in data]
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
        try:
            mesh: trimesh.Trimesh = trimesh.load(mesh_path, force="mesh")  # type: ignore[assignment]
        except Exception as exc:  # noqa: BLE001 - trimesh's loaders raise many kinds for a broken file
            raise BadInputError(mesh_path, f"not a mesh that trimesh can read ({type(exc).__name__})") from exc
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise BadInputError(mesh_path, "holds no triangles")
        if not mesh.is_watertight:
            raise BadInputError(mesh_path, "mesh is not closed (watertight), so inside and outside are undefined")
        count = whole(data.get("n_samples", 6000), path, "n_samples", minimum=100)
        points, faces = trimesh.sample.sample_surface_even(mesh, count, seed=0)
        return np.asarray(points), np.asarray(mesh.face_normals[faces])
    if "points_csv" in data:
        csv = path.parent / str(data["points_csv"])
        if not csv.is_file():
            raise BadInputError(path, f"point file not found: {csv}")
        try:
            frame = pd.read_csv(csv)
        except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
            raise BadInputError(csv, f"not a readable CSV ({type(exc).__name__})") from exc
        for column in POINT_COLUMNS:
            if column not in frame.columns:
                raise BadInputError(csv, "missing column", column=column)
        for column in POINT_COLUMNS:
            values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
            if not np.isfinite(values).all():
                row = int(np.argwhere(~np.isfinite(values))[0, 0]) + 1
                raise BadInputError(csv, "not a finite number", row=row, column=column)
        values = frame[POINT_COLUMNS].to_numpy(dtype=float)
        if len(values) < 10:
            raise BadInputError(csv, f"only {len(values)} points; a surface needs at least 10")
        return values[:, :3], values[:, 3:]
    raise BadInputError(path, "a gp object needs 'mesh' or 'points_csv'")
