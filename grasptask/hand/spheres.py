"""Collision geometry as spheres: every link's primitive (sphere, capsule, cylinder, box) or mesh covered by a
few spheres, which is what the NLP's eq. 14 and the verifier's clearance check take.

The covers hold the whole shape: a capsule is exact at its spine; a cylinder and a box are swept by spheres a
little wider than their smallest half-width, spaced half that width apart, so that every edge and corner lies in
a sphere (spheres of the half-width itself left a box's edges 0.41 of it outside, and a Barrett link sank 2 mm
into the object where its spheres cleared it, docs/margins.md); they bulge out of the flat faces by 6-12% of the
half-width. A mesh becomes its oriented bounding box.

The true surfaces, for the verifier's penetration check, are :mod:`grasptask.hand.skin`."""

from __future__ import annotations

import numpy as np

#: spheres along a segment are at most this fraction of their radius apart
SPACING = 1.0
#: a box's or cylinder's spheres are this fraction of its smallest half-width apart: 1 gives about twice the
#: spheres of the old cover and bulges 22% out of the faces; 0.5 bulged 6% with five times the spheres
GRID = 1.0


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
    """A cylinder along the local z axis: spheres on its axis, the end ones half a step inside its end faces,
    wide enough that the rims of the end faces lie in them; a cylinder shorter than it is wide is one sphere that
    encloses it."""
    if length < 2 * radius:
        return [(transform[:3, 3].copy(), float(np.hypot(radius, length / 2)))]
    step = GRID * radius
    reach = length / 2 - step / 2
    count = int(np.ceil(2 * reach / step)) + 1
    axis, centre = transform[:3, 2], transform[:3, 3]
    wide = float(np.hypot(radius, step / 2))
    return [(centre + axis * t, wide) for t in np.linspace(-reach, reach, count)]


def box(half_sizes: np.ndarray, transform: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """A box of ``half_sizes``: spheres on a grid over its mid-plane across its thinnest axis, the outer ones half
    a step inside its faces, each wide enough to reach the faces and the corners between its neighbours."""
    half = np.asarray(half_sizes, dtype=float)
    thin = int(np.argmin(half))
    step = GRID * float(half[thin])
    grids, gaps = [], []
    for k in range(3):
        if k == thin:
            grids.append(np.zeros(1))
            continue
        reach = max(float(half[k]) - step / 2, 0.0)
        count = int(np.ceil(2 * reach / step)) + 1 if reach > 0 else 1
        grids.append(np.linspace(-reach, reach, count))
        gaps.append(min(float(half[k]), step / 2))  # the farthest a face point is from a centre, along this axis
    radius = float(np.sqrt(half[thin] ** 2 + sum(g**2 for g in gaps)))
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
