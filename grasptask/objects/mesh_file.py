"""Reading a user's object: a triangle mesh (any format trimesh reads) or a point cloud with normals, in metres.

Every check a hand-sized object must pass is made here, once, and each failure is one line naming the file:
an unreadable or empty file, faces that are all degenerate, a mesh that is not closed (repaired when trimesh
can, and said so), a point cloud without normals, and a size no hand could grasp, which is nearly always a file
in millimetres read as metres (the message suggests the ``unit`` field).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import trimesh

from grasptask.errors import BadInputError

MESH_SUFFIXES = (".stl", ".obj", ".ply", ".glb", ".gltf", ".off")
CLOUD_SUFFIXES = (".csv", ".ply")
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
#: the largest extent (m) of anything a hand holds, and the smallest it can take between its fingers
LARGEST_M, SMALLEST_M = 0.6, 0.005
POINT_COLUMNS = ("x", "y", "z", "nx", "ny", "nz")


@dataclass(frozen=True)
class PointCloud:
    points: np.ndarray  # (n, 3) in metres
    normals: np.ndarray  # (n, 3) outward unit normals


def unit_scale(unit: Any, source: str | Path) -> float:
    if unit not in UNITS:
        raise BadInputError(source, f"field 'unit' must be one of {', '.join(UNITS)}, got {unit!r}")
    return UNITS[unit]


def check_size(extent_m: float, path: Path, unit: str) -> None:
    """A hand-sized object, or one line that says which unit the file is probably in."""
    if SMALLEST_M <= extent_m <= LARGEST_M:
        return
    raw = extent_m / UNITS[unit]  # in the file's own numbers
    hint = next((u for u, s in UNITS.items() if u != unit and SMALLEST_M <= raw * s <= LARGEST_M), None)
    advice = f"; if the file is in {hint}, say 'unit: {hint}' in the object's YAML" if hint else ""
    size = "too large" if extent_m > LARGEST_M else "too small"
    raise BadInputError(path, f"is {extent_m:.3g} m across ({unit}), {size} for a hand to grasp{advice}")


def open_edges(mesh: trimesh.Trimesh) -> int:
    """Edges used by one face only: the boundary of the mesh's holes."""
    return len(trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1))


def read_mesh(path: Path, unit: str = "m", say: Callable[[str], Any] = print) -> trimesh.Trimesh:
    """A closed triangle mesh in metres, its degenerate faces dropped and its holes filled where trimesh can
    (``say`` reports a repair)."""
    scale = unit_scale(unit, path)
    try:
        loaded = trimesh.load(path, force="mesh", process=True)
    except Exception as exc:  # noqa: BLE001 - trimesh's loaders raise many kinds for a broken file
        raise BadInputError(path, f"not a mesh that trimesh can read ({type(exc).__name__})") from exc
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise BadInputError(path, "holds no triangles")
    mesh = loaded
    good = mesh.nondegenerate_faces()
    if not good.any():
        raise BadInputError(path, f"all {len(mesh.faces)} faces are degenerate (zero area)")
    if not good.all():
        mesh.update_faces(good)
        mesh.remove_unreferenced_vertices()
    if not mesh.is_watertight:
        holes = open_edges(mesh)
        trimesh.repair.fill_holes(mesh)
        trimesh.repair.fix_normals(mesh)
        if not mesh.is_watertight:
            raise BadInputError(
                path,
                f"is not closed: {open_edges(mesh)} open edges ({holes} before trimesh's repair), so inside "
                "and outside are undefined",
            )
        say(f"{path}: the mesh was not closed ({holes} open edges); trimesh filled its holes")
    if mesh.volume < 0:
        mesh.invert()
    mesh.apply_scale(scale)
    check_size(float(mesh.extents.max()), path, unit)
    return mesh


def _cloud_columns(path: Path) -> dict[str, np.ndarray]:
    if path.suffix.lower() == ".ply":
        try:
            loaded = trimesh.load(path)
        except Exception as exc:  # noqa: BLE001
            raise BadInputError(path, f"not a point cloud that trimesh can read ({type(exc).__name__})") from exc
        raw = (getattr(loaded, "metadata", {}) or {}).get("_ply_raw", {}).get("vertex", {}).get("data", {})
        return {k: np.asarray(v, dtype=float).ravel() for k, v in raw.items()}
    try:
        frame = pd.read_csv(path)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise BadInputError(path, f"not a readable CSV ({type(exc).__name__})") from exc
    columns = {}
    for column in frame.columns:
        values = pd.to_numeric(frame[column], errors="coerce").to_numpy(dtype=float)
        if column in POINT_COLUMNS and not np.isfinite(values).all():
            row = int(np.argwhere(~np.isfinite(values))[0, 0]) + 1
            raise BadInputError(path, "not a finite number", row=row, column=str(column))
        columns[str(column)] = values
    return columns


def read_cloud(path: Path, unit: str = "m") -> PointCloud:
    """Points with outward normals, from a CSV (columns x, y, z, nx, ny, nz) or a PLY with normals."""
    scale = unit_scale(unit, path)
    columns = _cloud_columns(path)
    for axis in ("x", "y", "z"):
        if axis not in columns:
            raise BadInputError(path, "no point coordinates", column=axis)
    missing = [c for c in ("nx", "ny", "nz") if c not in columns]
    if missing:
        raise BadInputError(
            path, f"a point cloud needs outward normals (columns nx, ny, nz); '{missing[0]}' is missing"
        )
    points = np.column_stack([columns[c] for c in ("x", "y", "z")]) * scale
    normals = np.column_stack([columns[c] for c in ("nx", "ny", "nz")])
    if len(points) < 10:
        raise BadInputError(path, f"only {len(points)} points; a surface needs at least 10")
    length = np.linalg.norm(normals, axis=1)
    if not np.isfinite(points).all() or not np.isfinite(length).all() or (length < 1e-9).any():
        row = int(np.argwhere(~np.isfinite(length) | (length < 1e-9) | ~np.isfinite(points).all(axis=1))[0, 0]) + 1
        raise BadInputError(path, "a point without a finite position and a non-zero normal", row=row)
    check_size(float(np.ptp(points, axis=0).max()), path, unit)
    return PointCloud(points, normals / length[:, None])
