"""Collision geometry as spheres: every link's primitive (sphere, capsule, cylinder, box) or mesh covered by a
few spheres, which is what the NLP's eq. 14 and the verifier's clearance check take.

The covers are conservative where it matters: a capsule is exact at its spine; a cylinder and a box are swept by
spheres of their smallest half-width, spaced no further apart than that radius, so that the gaps between
neighbouring spheres stay shallow; a mesh becomes its oriented bounding box."""

from __future__ import annotations

import numpy as np

#: spheres along a segment are at most this fraction of their radius apart
SPACING = 1.0


def along_segment(a: np.ndarray, b: np.ndarray, radius: float) -> list[tuple[np.ndarray, float]]:
    """Spheres of ``radius`` centred on the segment ``a``-``b``, ends included."""
    length = float(np.linalg.norm(b - a))
    count = max(1, int(np.ceil(length / (SPACING * radius)))) + 1 if length > 0 else 1
    return [(a + (b - a) * t, radius) for t in np.linspace(0.0, 1.0, count)]


def capsule(radius: float, half_length: float, transform: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """A capsule along the local z axis of ``transform`` (4 x 4), as MJCF defines it."""
    axis, centre = transform[:3, 2], transform[:3, 3]
    return along_segment(centre - half_length * axis, centre + half_length * axis, radius)


def cylinder(radius: float, length: float, transform: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """A cylinder along the local z axis: spheres of its radius whose caps reach its two end faces, or, for a
    cylinder shorter than it is wide, one sphere that encloses it."""
    if length < 2 * radius:
        return [(transform[:3, 3].copy(), float(np.hypot(radius, length / 2)))]
    return capsule(radius, length / 2 - radius, transform)


def box(half_sizes: np.ndarray, transform: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """A box of ``half_sizes``: spheres of its smallest half-width on a grid over its mid-plane."""
    half = np.asarray(half_sizes, dtype=float)
    thin = int(np.argmin(half))
    radius = float(half[thin])
    grids = []
    for k in range(3):
        if k == thin:
            grids.append(np.zeros(1))
            continue
        reach = max(half[k] - radius, 0.0)
        count = max(1, int(np.ceil(2 * reach / (SPACING * radius)))) + 1 if reach > 0 else 1
        grids.append(np.linspace(-reach, reach, count))
    points = np.stack(np.meshgrid(*grids, indexing="ij"), axis=-1).reshape(-1, 3)
    world = points @ transform[:3, :3].T + transform[:3, 3]
    return [(p, radius) for p in world]


def mesh_box(vertices: np.ndarray, transform: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """A mesh's oriented bounding box (principal axes of its vertices), covered as a box."""
    points = np.asarray(vertices, dtype=float)
    centre = points.mean(axis=0)
    _, _, axes = np.linalg.svd(points - centre, full_matrices=False)
    local = (points - centre) @ axes.T
    low, high = local.min(axis=0), local.max(axis=0)
    frame = np.eye(4)
    frame[:3, :3] = axes.T
    frame[:3, 3] = centre + axes.T @ ((low + high) / 2)
    return box(np.maximum((high - low) / 2, 1e-4), transform @ frame)
