"""A link's true collision surface as points: every primitive (sphere, capsule, cylinder, box) or mesh of a hand
file sampled about every :data:`SPACING_M`, which is what the verifier's penetration check takes.

The spheres of :mod:`grasptask.hand.spheres` are what the NLP keeps outside the object, and they may miss a
box's edges or a mesh's corners; these points are the shapes themselves, so the deepest of them inside the
object is how far the hand's real geometry sinks (to within the spacing's sag, about 0.05 mm on a 1 cm
curvature). A mesh is sampled on its convex hull, the surface MuJoCo collides with."""

from __future__ import annotations

import numpy as np

#: the points' spacing on a surface (m)
SPACING_M = 1.5e-3
#: at most this many points per shape
MAX_POINTS = 4000


def _count(area: float) -> int:
    return int(np.clip(np.ceil(area / SPACING_M**2), 8, MAX_POINTS))


def sphere_directions(count: int) -> np.ndarray:
    """``count`` unit vectors spread evenly over the sphere (a Fibonacci lattice)."""
    k = np.arange(count) + 0.5
    z = 1.0 - 2.0 * k / count
    angle = np.pi * (1.0 + 5**0.5) * k
    ring = np.sqrt(1.0 - z**2)
    return np.column_stack([ring * np.cos(angle), ring * np.sin(angle), z])


def _placed(points: np.ndarray, transform: np.ndarray) -> np.ndarray:
    return points @ transform[:3, :3].T + transform[:3, 3]


def sphere(centre: np.ndarray, radius: float) -> np.ndarray:
    return np.asarray(centre, dtype=float) + radius * sphere_directions(_count(4 * np.pi * radius**2))


def capsule(radius: float, half_length: float, transform: np.ndarray) -> np.ndarray:
    """A capsule along the local z axis of ``transform`` (4 x 4): its two caps and its side."""
    cap = sphere_directions(_count(4 * np.pi * radius**2)) * radius
    caps = np.vstack([cap[cap[:, 2] >= 0] + [0, 0, half_length], cap[cap[:, 2] < 0] - [0, 0, half_length]])
    return _placed(np.vstack([caps, _side(radius, 2 * half_length)]), transform)


def _side(radius: float, length: float) -> np.ndarray:
    rings = max(2, int(np.ceil(length / SPACING_M)) + 1)
    around = max(8, int(np.ceil(2 * np.pi * radius / SPACING_M)))
    angle = np.linspace(0.0, 2 * np.pi, around, endpoint=False)
    z = np.linspace(-length / 2, length / 2, rings)
    a, h = np.meshgrid(angle, z)
    return np.column_stack([radius * np.cos(a).ravel(), radius * np.sin(a).ravel(), h.ravel()])


def cylinder(radius: float, length: float, transform: np.ndarray) -> np.ndarray:
    """A cylinder along the local z axis: its side and its two end discs."""
    rings = max(1, int(np.ceil(radius / SPACING_M)))
    discs = []
    for r in np.linspace(0.0, radius, rings + 1):
        around = max(1, int(np.ceil(2 * np.pi * r / SPACING_M)))
        angle = np.linspace(0.0, 2 * np.pi, around, endpoint=False)
        ring = np.column_stack([r * np.cos(angle), r * np.sin(angle), np.zeros(around)])
        discs += [ring + [0, 0, length / 2], ring - [0, 0, length / 2]]
    return _placed(np.vstack([_side(radius, length), *discs]), transform)


def box(half_sizes: np.ndarray, transform: np.ndarray) -> np.ndarray:
    """A box of ``half_sizes``: a grid on each of its six faces, edges and corners included."""
    half = np.asarray(half_sizes, dtype=float)
    faces = []
    for axis in range(3):
        u, v = [k for k in range(3) if k != axis]
        grid_u = np.linspace(-half[u], half[u], max(2, int(np.ceil(2 * half[u] / SPACING_M)) + 1))
        grid_v = np.linspace(-half[v], half[v], max(2, int(np.ceil(2 * half[v] / SPACING_M)) + 1))
        gu, gv = np.meshgrid(grid_u, grid_v)
        for sign in (-1.0, 1.0):
            face = np.zeros((gu.size, 3))
            face[:, u], face[:, v], face[:, axis] = gu.ravel(), gv.ravel(), sign * half[axis]
            faces.append(face)
    return _placed(np.vstack(faces), transform)


def mesh(vertices: np.ndarray, transform: np.ndarray) -> np.ndarray:
    """A mesh's convex hull: its vertices and points spread evenly over its faces."""
    import trimesh  # deferred: trimesh, only for mesh links

    with np.errstate(invalid="ignore", divide="ignore"):  # a flat mesh's hull has no volume to divide by
        hull = trimesh.Trimesh(np.asarray(vertices, dtype=float)).convex_hull
        points, _ = trimesh.sample.sample_surface_even(hull, _count(float(hull.area)), seed=0)
    return _placed(np.vstack([hull.vertices, points]), transform)


def ellipsoid(half_sizes: np.ndarray, transform: np.ndarray) -> np.ndarray:
    half = np.asarray(half_sizes, dtype=float)
    return _placed(sphere_directions(_count(4 * np.pi * float(np.max(half)) ** 2)) * half, transform)
