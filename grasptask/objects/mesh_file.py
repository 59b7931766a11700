"""Reading a user's object: a triangle mesh (any format trimesh reads) or a point cloud with normals, in metres.

Every check a hand-sized object must pass is made here, once, and each failure is one line naming the file:
an unreadable file or one without triangles, faces that are all degenerate, a mesh with a hole too wide to fill
or that MeshFix cannot close (a scan's seams, small holes and non-manifold edges are repaired, and said so), a
point cloud without normals, and a size no hand could grasp, which is nearly always a file in millimetres read
as metres (the message suggests ``--unit`` or the ``unit`` field).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from grasptask.errors import BadInputError
from grasptask.io.csv_format import sniff

MESH_SUFFIXES = (".stl", ".obj", ".ply", ".glb", ".gltf", ".off")
CLOUD_SUFFIXES = (".csv", ".ply")
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
#: the largest extent (m) of anything a hand holds, and the smallest it can take between its fingers
LARGEST_M, SMALLEST_M = 0.6, 0.005
POINT_COLUMNS = ("x", "y", "z", "nx", "ny", "nz")
#: holes up to this fraction of the object's largest extent are filled; a wider one is refused, not guessed at
#: (the Stanford bunny scan's widest, under its base, is 0.29)
HOLE_FRACTION = 1 / 3


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
    advice = f"; if the file is in {hint}, give --unit {hint} (or unit: {hint} in the object's YAML)" if hint else ""
    size = "too large" if extent_m > LARGEST_M else "too small"
    raise BadInputError(path, f"is {extent_m:.3g} m across ({unit}), {size} for a hand to grasp{advice}")


def open_edges(mesh: trimesh.Trimesh) -> int:
    """Edges used by one face only: the boundary of the mesh's holes."""
    return len(trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1))


def non_manifold_edges(mesh: trimesh.Trimesh) -> int:
    """Edges shared by more than two faces: where a surface has fins or sheets that touch."""
    _, counts = np.unique(mesh.edges_sorted, axis=0, return_counts=True)
    return int((counts > 2).sum())


def holes(mesh: trimesh.Trimesh) -> list[float]:
    """The diameter of each hole (each closed loop of open edges), largest first, in the mesh's units."""
    edges = mesh.edges_sorted[trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1)]
    if len(edges) == 0:
        return []
    n = len(mesh.vertices)
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    on_edge, degree = np.unique(edges, return_counts=True)
    sizes = []
    for loop in np.unique(label[on_edge]):
        member = label[on_edge] == loop
        # a hole's border is a closed loop; open edges that end on a non-manifold edge (a fin) are not a hole
        if member.sum() < 3 or (degree[member] % 2).any():
            continue
        points = mesh.vertices[on_edge[member]]
        sizes.append(float(np.linalg.norm(points[:, None] - points[None], axis=2).max()))
    return sorted(sizes, reverse=True)


def read_mesh(path: Path, unit: str = "m", say: Callable[[str], Any] = print) -> trimesh.Trimesh:
    """A closed triangle mesh in metres, from any file trimesh reads (a scene's nodes joined with their
    transforms), repaired as a scan needs and the repair said in one line (``say``):

    - vertices split along texture seams or normal creases are merged (a textured OBJ is split at every seam);
    - degenerate and duplicate faces are dropped;
    - a mesh still not closed, or with non-manifold edges, is repaired by MeshFix (``pymeshfix``): its holes
      filled, its non-manifold parts and loose pieces removed. On the Stanford bunny scan, trimesh's own repair
      left it open and manifold3d refuses a non-manifold input (docs/design/objects.md).

    A hole wider than ``HOLE_FRACTION`` of the object is not guessed at: it is refused with its size, as is a mesh
    MeshFix cannot close."""
    scale = unit_scale(unit, path)
    try:  # unprocessed first: trimesh's processing drops vertices that are not finite without a word
        loaded = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:  # noqa: BLE001 - trimesh's loaders raise many kinds for a broken file
        raise BadInputError(path, f"not a mesh that trimesh can read ({type(exc).__name__})") from exc
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise BadInputError(path, "holds no triangles")
    mesh, done = loaded, []
    dropped = _drop_non_finite(mesh, path)
    if dropped:
        done.append(dropped)
    mesh.process()
    split = open_edges(mesh)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    seams = split - open_edges(mesh)
    if seams > 0:
        done.append(f"merged the vertices split along {seams} seam edges")
    good = mesh.nondegenerate_faces()
    if not good.any():
        raise BadInputError(path, f"all {len(mesh.faces)} faces are degenerate (zero area)")
    unique = np.zeros(len(mesh.faces), dtype=bool)
    unique[mesh.unique_faces()] = True
    if not (good & unique).all():
        done.append(f"dropped {int((~(good & unique)).sum())} degenerate or duplicate faces")
        mesh.update_faces(good & unique)
        mesh.remove_unreferenced_vertices()
    check_size(float(mesh.extents.max()) * scale, path, unit)
    if not mesh.is_watertight or not mesh.is_winding_consistent:
        mesh, repair = _meshfix(mesh, path, scale)
        done.append(repair)
    elif mesh.volume < 0:
        mesh.invert()
        done.append("turned its faces outward")
    mesh.apply_scale(scale)
    if done:
        say(f"{path}: repaired the mesh: {'; '.join(done)}")
    return mesh


def _drop_non_finite(mesh: trimesh.Trimesh, path: Path) -> str:
    """The faces on vertices that are not finite numbers dropped (a scan's failed points), and what was done;
    a mesh with none left is refused with the count."""
    bad: np.ndarray = ~np.isfinite(np.asarray(mesh.vertices)).all(axis=1)
    if not bad.any():
        return ""
    keep = ~bad[mesh.faces].any(axis=1)
    if not keep.any():
        raise BadInputError(path, f"every face uses one of its {int(bad.sum())} vertices that are not finite numbers")
    mesh.update_faces(keep)
    mesh.remove_unreferenced_vertices()
    return f"dropped {int((~keep).sum())} faces on {int(bad.sum())} vertices that are not finite numbers (NaN or inf)"


def _meshfix(mesh: trimesh.Trimesh, path: Path, scale: float) -> tuple[trimesh.Trimesh, str]:
    """MeshFix's repair of a mesh that is open or not manifold, and what it did; a hole too wide to guess and a
    mesh it cannot close are one line each."""
    import pymeshfix  # deferred: only to repair a scan

    gaps, fins = holes(mesh), non_manifold_edges(mesh)
    extent = float(mesh.extents.max())
    if gaps and gaps[0] > HOLE_FRACTION * extent:
        raise BadInputError(
            path,
            f"has a hole {_mm(gaps[0] * scale)} across ({len(gaps)} in all), too wide to fill: a repair fills "
            f"holes up to {HOLE_FRACTION:.2g} of the object's {_mm(extent * scale)}; close it in a mesh editor",
        )
    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
    faces = np.ascontiguousarray(mesh.faces, dtype=np.int32)
    with _quiet():  # MeshFix prints to the process's own stdout
        fixed_vertices, fixed_faces = pymeshfix.clean_from_arrays(vertices, faces)
    fixed = trimesh.Trimesh(fixed_vertices, fixed_faces, process=True)
    if len(fixed.faces) == 0 or not fixed.is_watertight or not fixed.is_winding_consistent:
        what = f"{fins} non-manifold edges" if fins else f"{open_edges(mesh)} open edges in {len(gaps)} holes"
        raise BadInputError(path, f"is not a closed surface ({what}) and MeshFix could not repair it")
    if fixed.volume < 0:
        fixed.invert()
    parts = []
    if gaps:
        parts.append(f"filled {len(gaps)} holes (the widest {_mm(gaps[0] * scale)})")
    if fins:
        parts.append(f"removed {fins} non-manifold edges")
    lost = 1.0 - fixed.area / max(mesh.area, 1e-30)
    if lost > 0.01:
        parts.append(f"dropped loose pieces, {lost:.0%} of the surface")
    return fixed, " and ".join(parts or ["made its faces consistent"]) + " (MeshFix)"


def _mm(metres: float) -> str:
    return f"{metres * 1e3:.0f} mm" if metres >= 0.01 else f"{metres * 1e3:.1f} mm"


@contextmanager
def _quiet() -> Iterator[None]:
    """File descriptors 1 and 2 sent to /dev/null for the duration: a C library's prints, kept off the CLI."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
        os.dup2(null.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)


def _cloud_columns(path: Path) -> dict[str, np.ndarray]:
    if path.suffix.lower() == ".ply":
        try:
            loaded = trimesh.load(path)
        except Exception as exc:  # noqa: BLE001
            raise BadInputError(path, f"not a point cloud that trimesh can read ({type(exc).__name__})") from exc
        raw = (getattr(loaded, "metadata", {}) or {}).get("_ply_raw", {}).get("vertex", {}).get("data", {})
        return {k: np.asarray(v, dtype=float).ravel() for k, v in raw.items()}
    try:
        frame = pd.read_csv(path, **sniff(path).read_csv_options())
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
