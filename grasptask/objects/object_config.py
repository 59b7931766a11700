"""An object YAML's schema, one per ``type`` (superquadric, gp, mesh): every key, default and check declared
once. :func:`object_schema` reads the mapping of a config file; the loaders turn it into an object."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, Strict
from pydantic.dataclasses import dataclass
from scipy.spatial.transform import Rotation

from grasptask.errors import BadInputError
from grasptask.io.config_schema import SCHEMA, Count, Flag, Positive, Text, Vector, validated
from grasptask.objects.mesh_file import UNITS
from grasptask.objects.mesh_object import GRID_SPACING_M

#: the largest half-size of an object, in metres: a hand grasps nothing bigger
MAX_SIZE_M = 2.0
#: a GP surface's support points: each iteration of a solve evaluates the kernel at every one
MAX_SUPPORT = 2000

#: a half-size of a superquadric (m)
HalfSize = Annotated[float, Strict(), Field(ge=1e-3, le=MAX_SIZE_M)]
#: a coordinate of a point of the object or its task frame (m)
Coordinate = Annotated[float, Strict(), Field(ge=-MAX_SIZE_M, le=MAX_SIZE_M)]
Position = tuple[Coordinate, Coordinate, Coordinate]
#: a superquadric's exponent: 0.05 is nearly a box, 1 an ellipsoid, 2 a diamond
Exponent = Annotated[float, Strict(), Field(ge=0.05, le=2)]


@dataclass(frozen=True, config=SCHEMA)
class Pose:
    """A frame in the file's or the world's coordinates: a position (m) and roll, pitch, yaw about fixed x, y, z."""

    position_m: Position = (0.0, 0.0, 0.0)
    rotation_rpy_deg: Vector = (0.0, 0.0, 0.0)

    def matrix(self) -> np.ndarray:
        frame = np.eye(4)
        frame[:3, :3] = Rotation.from_euler("xyz", self.rotation_rpy_deg, degrees=True).as_matrix()
        frame[:3, 3] = self.position_m
        return frame


@dataclass(frozen=True, config=SCHEMA)
class TaskFrame:
    """Where the task's wrenches act, in the file's frame after ``unit``."""

    origin_m: Position = (0.0, 0.0, 0.0)
    rotation_rpy_deg: Vector = (0.0, 0.0, 0.0)

    def matrix(self) -> np.ndarray:
        return Pose(self.origin_m, self.rotation_rpy_deg).matrix()


@dataclass(frozen=True, config=SCHEMA)
class SymmetryConfig:
    """The object's symmetry, for clustering grasps: turns about z (or any axis, a sphere's), a flip of z."""

    rotation_axis: Literal["z", "any"] | None = None
    flip_axis: Literal["z"] | None = None

    def as_dict(self) -> dict[str, str]:
        return {k: v for k, v in (("rotation_axis", self.rotation_axis), ("flip_axis", self.flip_axis)) if v}


@dataclass(frozen=True, config=SCHEMA)
class SuperquadricConfig:
    """``type: superquadric``: the paper's object model, e.g. its 20 x 2 cm tool."""

    #: superquadric
    type: Literal["superquadric"]
    #: half-sizes a1, a2, a3 (m)
    size_m: tuple[HalfSize, HalfSize, HalfSize]
    #: e1, e2
    exponents: tuple[Exponent, Exponent]
    #: the superquadric's frame in the object frame
    pose: Pose = Pose()
    #: what the report and the records call the object (default: the file's name)
    name: Text | None = None
    description: str = ""
    #: the object's symmetry, for clustering grasps: {rotation_axis: z or any, flip_axis: z}
    symmetry: SymmetryConfig | None = None


@dataclass(frozen=True, config=SCHEMA)
class GPConfig:
    """``type: gp``: a Gaussian-process implicit surface fitted to a mesh's or a point file's samples."""

    #: gp
    type: Literal["gp"]
    #: a triangle mesh to sample (relative to the config file) ...
    mesh: Text | None = None
    #: ... or a CSV with columns x, y, z, nx, ny, nz (outward normals)
    points_csv: Text | None = None
    #: surface support points to start from (spread evenly)
    n_support: Annotated[int, Strict(), Field(ge=4, le=MAX_SUPPORT)] = 250
    #: more are added where the fit misses the surface by over tolerance_m
    max_support: Annotated[int, Strict(), Field(ge=0, le=MAX_SUPPORT)] = 500
    tolerance_m: Positive = 5e-4
    seed: Count = 0
    #: surface samples drawn from the mesh
    n_samples: Annotated[int, Strict(), Field(ge=100, le=200_000)] = 6000
    #: what the report and the records call the object (default: the file's name)
    name: Text | None = None
    description: str = ""
    #: the object's symmetry, for clustering grasps: {rotation_axis: z or any, flip_axis: z}
    symmetry: SymmetryConfig | None = None

    def __post_init__(self) -> None:
        if self.max_support < self.n_support:
            raise ValueError("field 'max_support': must be at least n_support")
        if (self.mesh is None) == (self.points_csv is None):
            raise ValueError("a gp object needs one of 'mesh' or 'points_csv'")


@dataclass(frozen=True, config=SCHEMA)
class MeshConfig:
    """``type: mesh``: a triangle mesh or a point cloud with normals, as it was downloaded or scanned."""

    #: mesh
    type: Literal["mesh"]
    #: a triangle mesh (relative to the config file) ...
    mesh: Text | None = None
    #: ... or a point cloud with outward normals (CSV x, y, z, nx, ny, nz, or PLY)
    points: Text | None = None
    #: the file's length unit: m, cm or mm
    unit: Text = "m"
    #: the file's frame in the world (kept for the record)
    pose: Pose = Pose()
    #: where the task's wrenches act, in the file's frame: a frame, or centre (the centre of volume and principal
    #: axes) or origin (the file's own); a YAML's default is origin, a bare file's centre
    task_frame: Literal["centre", "origin"] | TaskFrame | None = None
    #: allow a task frame outside the object or within 5 mm of its surface
    task_frame_outside: Flag = False
    #: the object's mass (kg), for the physics check
    mass_kg: Positive | None = None
    #: the synthesis surrogate's grid (m); finer for blades and thin shafts
    grid_spacing_m: Annotated[float, Strict(), Field(ge=5e-4, le=0.01)] = GRID_SPACING_M
    #: what the report and the records call the object (default: the file's name)
    name: Text | None = None
    description: str = ""
    #: the object's symmetry, for clustering grasps: {rotation_axis: z or any, flip_axis: z}
    symmetry: SymmetryConfig | None = None

    def __post_init__(self) -> None:
        if self.unit not in UNITS:
            raise ValueError(f"field 'unit': must be one of {', '.join(UNITS)}, got {self.unit!r}")
        if (self.mesh is None) == (self.points is None):
            raise ValueError("a mesh object needs one of 'mesh' (a triangle mesh) or 'points' (a point cloud)")


ObjectConfig = SuperquadricConfig | GPConfig | MeshConfig
SCHEMAS: dict[str, type] = {"superquadric": SuperquadricConfig, "gp": GPConfig, "mesh": MeshConfig}


def object_schema(data: dict[str, Any], path: Path) -> ObjectConfig:
    """A config file's mapping checked against its type's schema, or one line naming the file and the key."""
    kind = data.get("type")
    if kind is None:
        raise BadInputError(path, "missing field 'type'")
    if kind not in SCHEMAS:
        raise BadInputError(path, f"unknown object type {kind!r} (known: {', '.join(SCHEMAS)})")
    return validated(SCHEMAS[kind], data, path)
