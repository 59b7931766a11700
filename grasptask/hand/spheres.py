"""Collision geometry as spheres: every link's primitive (sphere, capsule, cylinder, box) or mesh covered by a
few spheres, which is what the NLP's eq. 14 and the verifier's clearance check take.

The covers hold the whole shape. A capsule keeps its two end spheres exact (a fingertip's pad sits on the last),
with spheres a little wider than it between them, so that its side does not sag between spheres (spheres of its
own radius one radius apart left 13% of it outside, and the Allegro's tips sank 0.85 mm where eq. 14 allowed
0.5); a cylinder and a box are swept by spheres a little wider than their smallest half-width, spaced half that
width apart, so that every edge and corner lies in a sphere (spheres of the half-width itself left a box's edges
0.41 of it outside, and a Barrett link sank 2 mm into the object where its spheres cleared it, docs/design/margins.md);
they bulge out of the flat faces by 6-12% of the half-width. A mesh becomes its oriented bounding box.

The true surfaces, for the verifier's penetration check, are :mod:`grasptask.hand.skin`."""

from __future__ import annotations

import numpy as np

#: a capsule's inner spheres are this fraction of its radius apart: they bulge 3% of the radius out of its side
CAPSULE_STEP = 0.5
#: a box's or cylinder's spheres are this fraction of its smallest half-width apart: 1 gives about twice the
#: spheres of the old cover and bulges 22% out of the faces; 0.5 bulged 6% with five times the spheres
GRID = 1.0


def capsule(radius: float, half_length: float, transform: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """A capsule along the local z axis of ``transform`` (4 x 4), as MJCF defines it: its end spheres, exact, first
    and last, and between them spheres at most ``CAPSULE_STEP`` radii apart, each wide enough to hold the side of
    the capsule half a step either way, the outer ones half a step inside the ends."""
    axis, centre = transform[:3, 2], transform[:3, 3]
    ends = [(centre - half_length * axis, radius), (centre + half_length * axis, radius)]
    if half_length <= 0:
        return ends[:1]
    step = CAPSULE_STEP * radius
    count = max(1, int(np.ceil(2 * half_length / step)))
    reach = half_length - half_length / count  # count spheres, each holding 2 half_length / count of the side
    wide = float(np.hypot(radius, half_length / count))
    inner = [(centre + axis * t, wide) for t in np.linspace(-reach, reach, count)]
    return [ends[0], *inner, ends[1]]


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
