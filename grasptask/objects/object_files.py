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
                                      # in the file's frame (metres); or centre, or origin (the default here)
    task_frame_outside: false         # true: allow a task frame outside the object or within 5 mm of it
    pose: {position_m: [0, 0, 0], rotation_rpy_deg: [0, 0, 0]}  # the file's frame in the world (kept)
    mass_kg: 0.08
    grid_spacing_m: 0.0025            # the synthesis surrogate's grid; finer for blades and thin shafts

A mesh or point-cloud file can also be given directly (``--object thing.obj``), with ``--unit``, ``--mass`` and
``--task-frame`` for what a bare file cannot say (the same fields of a mesh object's YAML, which they override).
A bare file's task frame is its ``centre``: the centre of volume (of the points, for a cloud), z along the
longest principal axis (or a symmetric object's symmetry axis: :mod:`grasptask.objects.principal_frame`), x along
the next; this is where the paper's frame sits on its tool. ``origin`` keeps the
file's own frame. A mesh or cloud object lives in its task frame, so grasps are reported in it. A frame
given or ``origin`` outside the object, or within 5 mm of its surface, is refused unless ``task_frame_outside:
true`` (``--task-frame-outside``): the task's torques act about it, and a frame on the base of a scan (where
YCB's origins are) makes a different task. The ``centre`` is always taken, and said where it lies outside the
solid (a mug's, in its cavity) or within 5 mm of its surface (a thin rod's).

Paths are relative to the config file. An optional ``symmetry`` entry, ``{rotation_axis: z, flip_axis: z}``
(or ``rotation_axis: any`` for a sphere), describes the object's symmetry for clustering grasps; the loaded
object carries it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from grasptask.errors import BadInputError, existing_file
from grasptask.io.config_schema import load_yaml
from grasptask.objects.gp import GPImplicitSurface
from grasptask.objects.mesh_file import CLOUD_SUFFIXES, MESH_SUFFIXES, read_cloud, read_mesh
from grasptask.objects.mesh_object import MeshObject, PointCloudObject
from grasptask.objects.object_config import GPConfig, MeshConfig, SuperquadricConfig, SymmetryConfig, object_schema
from grasptask.objects.principal_frame import PrincipalFrame, principal_frame
from grasptask.objects.superquadric import Superquadric
from grasptask.objects.surface import ImplicitObject, Symmetry
from grasptask.paths import DEFAULT_OBJECT

#: a task frame's origin at least this deep inside the object (m), unless the YAML allows it outside
FRAME_DEPTH_M = 0.005
#: what --unit, --mass and --task-frame set, as fields of a mesh object's YAML
OVERRIDES = ("unit", "mass_kg", "task_frame", "task_frame_outside")
#: file and folder names that say nothing of the object: YCB's ``025_mug/google_16k/textured.obj``, ShapeNet's
#: ``model_normalized.obj``, a scanner's ``mesh.stl``; such a file is named after the first folder above it that
#: says more
GENERIC_NAMES = frozenset(
    {"textured", "nontextured", "textured_simple", "model", "model_normalized", "mesh", "meshes", "object", "scan",
     "poisson", "tsdf", "google_16k", "google_64k", "google_512k", "collision", "visual", "models", "untitled"}
)  # fmt: skip


@dataclass(frozen=True, kw_only=True)
class BareObjectFacts:
    """What a bare mesh or point cloud cannot say, as ``--unit``, ``--mass``, ``--task-frame`` and
    ``--task-frame-outside`` give it (a mesh YAML's fields); None: the file's or the YAML's own. The options of
    the stages that load an object start from these."""

    unit: str | None = None
    mass_kg: float | None = None
    task_frame: str | None = None
    task_frame_outside: bool | None = None

    @property
    def object_overrides(self) -> dict[str, Any]:
        """Those given, as :func:`load_object` takes them."""
        given = {name: getattr(self, name) for name in OVERRIDES}
        return {k: v for k, v in given.items() if v is not None}


def load_object(
    path: str | Path = DEFAULT_OBJECT, say: Callable[[str], Any] = print, **overrides: Any
) -> ImplicitObject:
    """An object from its YAML config, or a mesh or point-cloud file itself, every field checked: a one-line
    error names the file and the field at fault. ``say`` reports a repaired mesh. ``overrides`` (``unit``,
    ``mass_kg``, ``task_frame``; None: not given) are a mesh object's fields, as ``--unit``, ``--mass`` and
    ``--task-frame`` give them."""
    path = Path(path)
    config = object_config(path, **overrides)
    if config is not None:
        return object_from_config(config, path, say)
    if path.suffix.lower() in MESH_SUFFIXES + CLOUD_SUFFIXES:
        source = existing_file(path, "object file")
        bare = (
            MeshConfig(type="mesh", points=str(source))
            if _is_cloud(source)
            else MeshConfig(type="mesh", mesh=str(source))
        )
        return mesh_object(source, bare, path, say)
    return object_from_config(load_yaml(_config_file(path)), path, say)


#: an object config's suffixes; any other that is not a mesh's or a point cloud's is refused with the kinds
CONFIG_SUFFIXES = (".yaml", ".yml")


def _config_file(path: Path) -> Path:
    """``path`` if it names an object config by its suffix: a file of another kind is not read as YAML."""
    if path.suffix.lower() not in CONFIG_SUFFIXES:
        kinds = ", ".join(MESH_SUFFIXES + tuple(s for s in CLOUD_SUFFIXES if s not in MESH_SUFFIXES))
        raise BadInputError(
            path,
            f"unknown object file type '{path.suffix or path.name}': give an object YAML (.yaml), a mesh or a "
            f"point cloud ({kinds})",
        )
    return path


def file_object_name(path: str | Path) -> str:
    """What the records call an object read from ``path`` without a ``name:``: the file's own name, or, when it
    is generic (``textured.obj``), that of the nearest folder above it whose name is not."""
    path = Path(path).resolve()
    for part in (path.stem, *(p.name for p in path.parents)):
        if part and part.lower() not in GENERIC_NAMES:
            return part
    return path.stem


def object_config(path: str | Path, **overrides: Any) -> dict[str, Any] | None:
    """The YAML config of ``path`` with ``overrides`` in place (None: there are none), its files named by
    absolute paths so that it can be written anywhere: what a sweep run with --unit, --mass or --task-frame
    records as its object."""
    path = Path(path)
    unknown = set(overrides) - set(OVERRIDES)
    if unknown:
        raise TypeError(f"unknown object overrides: {', '.join(sorted(unknown))}")
    given = {k: v for k, v in overrides.items() if v is not None}
    if not given:
        return None
    if path.suffix.lower() in MESH_SUFFIXES + CLOUD_SUFFIXES:
        source = existing_file(path, "object file").resolve()
        key = "points" if _is_cloud(path) else "mesh"
        return {"type": "mesh", "name": file_object_name(path), key: str(source), "task_frame": "centre", **given}
    data = load_yaml(_config_file(path))
    if data.get("type") != "mesh":
        flags = ", ".join("--" + k.replace("_kg", "").replace("_", "-") for k in given)
        raise BadInputError(path, f"{flags}: for a mesh or point-cloud object; this is a {data.get('type')!r} object")
    for key in ("mesh", "points"):
        if key in data:
            data[key] = str((path.parent / str(data[key])).resolve())
    return {**data, **given}


def object_from_config(data: dict[str, Any], path: Path, say: Callable[[str], Any] = print) -> ImplicitObject:
    """An object from a config's mapping; ``path`` is the config's file, which relative paths start from and
    messages name."""
    config = object_schema(data, path)
    symmetry = _symmetry(config.symmetry)
    name = config.name or file_object_name(path)
    if isinstance(config, SuperquadricConfig):
        pose = config.pose.matrix()
        e1, e2 = config.exponents
        return Superquadric(np.array(config.size_m), e1, e2, pose[:3, :3], pose[:3, 3], name, symmetry)
    if isinstance(config, GPConfig):
        points, normals = _surface_samples(path, config)
        gp = GPImplicitSurface.fit(
            points,
            normals,
            n_support=config.n_support,
            max_support=config.max_support,
            tolerance=config.tolerance_m,
            seed=config.seed,
            name=name,
        )
        return replace(gp, symmetry=symmetry)
    key = "mesh" if config.mesh is not None else "points"
    source = path.parent / str(getattr(config, key))
    if not source.is_file():
        raise BadInputError(path, f"field '{key}': file not found: {source}")
    return mesh_object(source, config, path, say)


def mesh_object(source: Path, config: MeshConfig, path: Path, say: Callable[[str], Any] = print) -> ImplicitObject:
    """A mesh or point cloud in its task frame (``task_frame`` in the file's own frame, after ``unit``; by
    default, ``centre`` for a bare file and ``origin`` for a YAML's), checked to lie inside the object."""
    unit, mass, spacing = config.unit, config.mass_kg, config.grid_spacing_m
    pose = config.pose.matrix()
    name = config.name or file_object_name(source)
    symmetry = _symmetry(config.symmetry)
    rule = config.task_frame if config.task_frame is not None else ("centre" if path == source else "origin")
    found: ImplicitObject
    repairs: list[str] = []  # said once the object is known to be good: a refused file gets one line
    if config.points is not None:
        points = read_cloud(source, unit)
        found = PointCloudObject(points.points, points.normals, name, symmetry, mass, None, spacing)
    else:
        found = MeshObject(read_mesh(source, unit, repairs.append), name, symmetry, mass, None, spacing)
    axes = ""
    if rule == "centre":
        principal = _principal_frame(found)
        task_frame, axes = principal.matrix, principal.axes
    elif rule == "origin":
        task_frame = np.eye(4)
    else:
        assert not isinstance(rule, str)
        task_frame = rule.matrix()
    label = rule if isinstance(rule, str) else "given"
    depth = -float(found.signed_distance(task_frame[None, :3, 3])[0])  # < 0: outside the solid
    where = _frame_place(depth, task_frame[:3, 3], label)
    if depth < FRAME_DEPTH_M and rule != "centre" and not config.task_frame_outside:
        raise BadInputError(
            path,
            f"{where}; the task's torques act about it, so place it at least {FRAME_DEPTH_M * 1e3:.0f} mm inside "
            "(--task-frame centre, or task_frame in the object's YAML), or accept it (--task-frame-outside, or "
            "task_frame_outside: true)",
        )
    for repair in repairs:
        say(repair)
    if depth < FRAME_DEPTH_M:  # a hollow object's centre (a mug's lies in its cavity), a thin one's, or accepted
        say(f"{source}: {where}; taken: the task's torques act about it")
    into_task = np.linalg.inv(task_frame)
    rotation = into_task[:3, :3]
    if isinstance(found, PointCloudObject):
        return PointCloudObject(
            found.points @ rotation.T + into_task[:3, 3], found.normals @ rotation.T, name, symmetry, mass,
            pose @ task_frame, spacing, task_frame, label, axes,
        )  # fmt: skip
    assert isinstance(found, MeshObject)
    mesh = found.mesh
    mesh.apply_transform(into_task)
    return MeshObject(mesh, name, symmetry, mass, pose @ task_frame, spacing, task_frame, label, axes)


def object_facts(obj: ImplicitObject) -> dict[str, Any]:
    """What a run records of its object: its name, the task frame in the file's coordinates (metres) and how it
    was chosen (a formula object's frame is its own), and the mass (None: not given)."""
    frame = getattr(obj, "task_frame", None)
    return {
        "object_name": obj.name,
        "task_frame": {
            "rule": getattr(obj, "task_frame_rule", "object"),
            "axes": getattr(obj, "task_frame_axes", ""),
            "in_file_frame": None if frame is None else np.round(frame, 9).tolist(),
        },
        "object_mass_kg": getattr(obj, "mass_kg", None),
    }


def _principal_frame(obj: ImplicitObject) -> PrincipalFrame:
    """A mesh's or cloud's default task frame (:mod:`grasptask.objects.principal_frame`), in its file's frame."""
    if isinstance(obj, MeshObject):
        centre = np.asarray(obj.mesh.center_mass, dtype=float)
        inertia = np.asarray(obj.mesh.moment_inertia, dtype=float)
        return principal_frame(centre, inertia, obj.mesh.triangles_center - centre, obj.mesh.area_faces)
    assert isinstance(obj, PointCloudObject)
    centre = obj.points.mean(axis=0)
    spread = obj.points - centre
    second = spread.T @ spread  # as a thin shell's inertia: the least about the longest axis
    return principal_frame(centre, np.trace(second) * np.eye(3) - second, spread, np.ones(len(spread)))


def _frame_place(depth: float, origin: np.ndarray, rule: str) -> str:
    """Where the task frame lies, ``depth`` (m) inside the object's surface, as a message says it."""
    at = ", ".join(str(int(round(v * 1e3))) for v in origin)
    where = f"lies {-depth * 1e3:.1f} mm outside the solid" if depth < 0 else f"is {depth * 1e3:.1f} mm inside it"
    return f"the task frame ({rule}, at ({at}) mm in the file's frame) {where}"


def _is_cloud(source: Path) -> bool:
    """A file given directly is a point cloud: a CSV, or a PLY without faces."""
    return source.suffix.lower() == ".csv" or (source.suffix.lower() == ".ply" and not _has_faces(source))


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
    data = load_yaml(_config_file(path))
    named = [path.parent / str(data[key]) for key in ("mesh", "points", "points_csv") if key in data]
    return [path, *(p for p in named if p.is_file())]


def _symmetry(config: SymmetryConfig | None) -> Symmetry | None:
    return None if config is None else config.as_dict()


def _surface_samples(path: Path, config: GPConfig) -> tuple[np.ndarray, np.ndarray]:
    if config.mesh is not None:
        mesh_path = path.parent / config.mesh
        if not mesh_path.is_file():
            raise BadInputError(path, f"mesh file not found: {mesh_path}")
        return MeshObject(read_mesh(mesh_path)).surface_samples(config.n_samples)
    assert config.points_csv is not None
    csv = path.parent / config.points_csv
    if not csv.is_file():
        raise BadInputError(path, f"point file not found: {csv}")
    cloud = read_cloud(csv)
    return cloud.points, cloud.normals
