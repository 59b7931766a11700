"""Starting poses (paper Section 7.3): 42 palm orientations x 3 palm positions = 126 starts.

The orientations point the palm's normal along the 42 vertices of a subdivided icosahedron (each edge split in
two; 12 + 30 vertices), so they span all directions evenly. The positions are on the diagonal of the object
frame, level with the middle of the object, and above it, each far enough that the hand starts away from the
object. Joints start at mid-range. A seeded jitter of a few degrees and millimetres separates the starts.

Besides them, a sweep may seed starts over the object's surface (:func:`surface_starts`), and a grasp library
gives warm starts (:func:`warm_starts`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import trimesh
from scipy.spatial.transform import Rotation

from grasptask.errors import BadInputError
from grasptask.records.solutions import grasp_from_row, joint_columns

N_ORIENTATIONS = 42
POSITIONS = ("diagonal", "middle", "above")


@dataclass(frozen=True)
class Start:
    start_id: int
    orientation: int
    position_name: str
    palm_rotation: np.ndarray
    palm_position: np.ndarray
    #: a warm start's joints (an optimum of a grasp library): its first attempt starts at that grasp as it was,
    #: neither placed nor moved by the geometric phase
    joints: np.ndarray | None = None
    #: where placement puts the pads' centroid (a surface seed's point); None: the anchor nearest the palm
    anchor: np.ndarray | None = None


@dataclass(frozen=True)
class StartJob:
    """A worker's job on one start (a search, a polish): it answers for the start, as a failed row names it."""

    start: Start

    @property
    def start_id(self) -> int:
        return self.start.start_id

    @property
    def orientation(self) -> int:
        return self.start.orientation

    @property
    def position_name(self) -> str:
        return self.start.position_name


#: the first id of the warm starts, apart from the 126
WARM_FIRST_ID = 1000
WARM_POSITION = "library"
#: the first id of the starts seeded over the object's surface
SURFACE_FIRST_ID = 2000
SURFACE_POSITION = "surface"
#: a surface seed's palm turns about its approach direction (Dexonomy turns each of its seeds 8 ways)
SURFACE_TURNS = 4


def palm_directions() -> np.ndarray:
    """The 42 vertices of an icosahedron whose edges are split in two, as unit vectors."""
    vertices = trimesh.creation.icosphere(subdivisions=1).vertices
    return vertices / np.linalg.norm(vertices, axis=1, keepdims=True)


def palm_rotation_towards(direction: np.ndarray) -> np.ndarray:
    """A palm frame whose normal (z) points along ``direction``, fingers (x) as close to +z of the object
    as possible (or +x when the direction is vertical)."""
    z = direction / np.linalg.norm(direction)
    reference = np.array([0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = reference - (reference @ z) * z
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def palm_positions(bounds: np.ndarray, standoff: float = 0.09) -> dict[str, np.ndarray]:
    """Palm centres away from the object: on the object frame's diagonal, beside its middle, above it."""
    half = np.abs(bounds).max(axis=0)
    radius = float(np.linalg.norm(half[:2]))
    return {
        "diagonal": (np.linalg.norm(half) + standoff) * np.ones(3) / np.sqrt(3),
        "middle": np.array([radius + standoff, 0.0, 0.0]),
        "above": np.array([0.0, 0.0, half[2] + standoff]),
    }


def make_starts(bounds: np.ndarray, seed: int = 0, jitter_deg: float = 3.0, jitter_m: float = 0.003) -> list[Start]:
    """All 126 starts, deterministic for a seed."""
    rng = np.random.default_rng(seed)
    positions = palm_positions(bounds)
    starts = []
    for p, name in enumerate(POSITIONS):
        for o, direction in enumerate(palm_directions()):
            wobble = Rotation.from_rotvec(np.radians(jitter_deg) * rng.normal(size=3)).as_matrix()
            starts.append(
                Start(
                    start_id=p * N_ORIENTATIONS + o,
                    orientation=o,
                    position_name=name,
                    palm_rotation=wobble @ palm_rotation_towards(direction),
                    palm_position=positions[name] + jitter_m * rng.normal(size=3),
                )
            )
    return starts


def surface_starts(
    points: np.ndarray, normals: np.ndarray, count: int, turns: int = SURFACE_TURNS, standoff: float = 0.09
) -> list[Start]:
    """``count`` starts seeded over the object's surface, so that a handle, a rim or a flat face is tried wherever
    it lies: seeds spread by farthest-point sampling over ``points`` (outward ``normals``), each approached along
    its inward normal with the palm turned ``turns`` ways about it, its pads placed at the seed (``anchor``).
    ``orientation`` numbers the seed and ``palm_position`` is ``standoff`` out along its normal; deterministic."""
    seeds = farthest_points(np.asarray(points, dtype=float), -(-count // turns))
    starts = []
    for k in range(min(count, turns * len(seeds))):  # an object sampled more sparsely than asked: each point once
        seed, turn = seeds[k // turns], k % turns
        normal = normals[seed] / np.linalg.norm(normals[seed])
        about = Rotation.from_rotvec(2 * np.pi * turn / turns * normal).as_matrix()
        starts.append(
            Start(
                start_id=SURFACE_FIRST_ID + k,
                orientation=k // turns,
                position_name=SURFACE_POSITION,
                palm_rotation=about @ palm_rotation_towards(-normal),
                palm_position=points[seed] + standoff * normal,
                anchor=np.array(points[seed], dtype=float),
            )
        )
    return starts


def farthest_points(points: np.ndarray, count: int) -> np.ndarray:
    """The indices of ``count`` of ``points`` spread by farthest-point sampling, from the point farthest from
    their centroid."""
    chosen = [int(np.argmax(np.linalg.norm(points - points.mean(axis=0), axis=1)))]
    nearest = np.linalg.norm(points - points[chosen[0]], axis=1)
    while len(chosen) < min(count, len(points)):
        chosen.append(int(np.argmax(nearest)))
        nearest = np.minimum(nearest, np.linalg.norm(points - points[chosen[-1]], axis=1))
    return np.array(chosen, dtype=int)


def subset(starts: list[Start], n: int | None) -> list[Start]:
    """``n`` starts spread evenly over the list (all when ``n`` is None or too large)."""
    if n is None or n >= len(starts):
        return list(starts)
    picks = np.unique(np.linspace(0, len(starts) - 1, n).round().astype(int))
    return [starts[i] for i in picks]


def warm_starts(optima: pd.DataFrame, joint_names: list[str], source: str | Path = "library") -> list[Start]:
    """A start at each of ``optima`` (a grasp library's, best first), numbered from :data:`WARM_FIRST_ID`; an
    optimum without one of the joints is one line naming ``source``."""
    missing = next((c for c in joint_columns(joint_names) if c not in optima.columns), None)
    if missing is not None:
        raise BadInputError(source, "missing column", column=missing)
    starts = []
    for k, row in enumerate(optima.to_dict("records")):
        grasp = grasp_from_row(row, joint_names)
        starts.append(
            Start(WARM_FIRST_ID + k, -1, WARM_POSITION, grasp.palm_rotation, grasp.palm_position, grasp.joint_angles)
        )
    return starts
