"""Starting poses (paper Section 7.3): 42 palm orientations x 3 palm positions = 126 starts.

The orientations point the palm's normal along the 42 vertices of a subdivided icosahedron (each edge split in
two; 12 + 30 vertices), so they span all directions evenly. The positions are on the diagonal of the object
frame, level with the middle of the object, and above it, each far enough that the hand starts away from the
object. Joints start at mid-range. A seeded jitter of a few degrees and millimetres separates the starts.
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
