"""A signed-distance grid around an object, the data of the NLP's surrogate for a mesh or point cloud.

The NLP evaluates the grid through a B-spline that interpolates it (:mod:`grasptask.synthesis.spline`). A
distance field is nearly linear away from the surface's curvature, so the zero set stays within a fraction of a
millimetre of the surface at a few millimetres' spacing.

Distances come from dense samples of the surface: the distance to the nearest sample's tangent plane near the
surface, to the sample itself farther out. The sign comes from the mesh's own inside test (ray casting), or for
a point cloud from the nearest point's normal. None of this is the verifier's code: the verifier measures
against the triangles (:mod:`grasptask.objects.mesh_object`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from grasptask.io import cache
from grasptask.progress import building

#: grid points farther than this from the surface take their distance from a sparse subset of the samples
FAR_M, COARSE_SAMPLES = 0.02, 5000


@dataclass(frozen=True)
class DistanceGrid:
    origin: np.ndarray  # (3,) the first grid point (m)
    spacing: float  # m
    values: np.ndarray  # (nx, ny, nz) signed distances (m), negative inside

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.values.shape

    @property
    def axes(self) -> list[np.ndarray]:
        return [self.origin[i] + self.spacing * np.arange(n) for i, n in enumerate(self.shape)]

    @property
    def upper(self) -> np.ndarray:
        return self.origin + self.spacing * (np.array(self.shape) - 1)

    def points_inside(self, depth: float) -> np.ndarray:
        """``(n, 3)``: the grid points at least ``depth`` (m) inside the surface."""
        index = np.argwhere(self.values <= -depth)
        return self.origin + self.spacing * index


def kept_grid(name: str, made_from: tuple, make: Callable[[], DistanceGrid]) -> DistanceGrid:
    """The grid ``make`` gives, made once for ``made_from`` (the arrays and settings it is made of) and kept
    (:mod:`grasptask.io.cache`): a scan's took 2-4 s, in every worker of every sweep."""
    import trimesh  # its sampling makes the points

    digest = cache.key("distance_grid", *made_from, FAR_M, COARSE_SAMPLES, trimesh.__version__)

    def arrays() -> dict[str, np.ndarray]:
        grid = make()
        return {"origin": grid.origin, "spacing": np.array(grid.spacing), "values": grid.values}

    with building(f"{name}: its signed-distance grid for the synthesis") as notes:
        entry = cache.cached("distance_grid", digest, arrays, _check_grid)
        notes.append(f"kept in {entry.path} for later runs" if entry.path else "not kept (no cache)")
    found = entry.arrays
    return DistanceGrid(np.asarray(found["origin"], dtype=float), float(found["spacing"]), found["values"])


def _check_grid(arrays: dict[str, np.ndarray]) -> None:
    origin, spacing, values = arrays["origin"], arrays["spacing"], arrays["values"]
    if origin.shape != (3,) or spacing.shape != () or values.ndim != 3 or min(values.shape) < 2:
        raise ValueError("a grid of the wrong shape")
    if not (np.isfinite(origin).all() and np.isfinite(values).all() and float(spacing) > 0):
        raise ValueError("a grid that is not finite")


def distance_grid(
    points: np.ndarray,
    normals: np.ndarray,
    bounds: np.ndarray,
    spacing: float = 0.0025,
    margin: float = 0.03,
    inside: Callable[[np.ndarray], np.ndarray] | None = None,
) -> DistanceGrid:
    """The signed distance to the surface sampled by ``points`` (with outward ``normals``), on a grid of
    ``spacing`` over ``bounds`` grown by ``margin``; ``inside`` (points -> bool) gives the sign where it can."""
    low = np.asarray(bounds[0], float) - margin
    counts = np.ceil((np.asarray(bounds[1], float) + margin - low) / spacing).astype(int) + 1
    axes = [low[i] + spacing * np.arange(counts[i]) for i in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    tree = cKDTree(points)
    # a nearest-neighbour search from far away visits much of a dense tree: first a sparse subset of the
    # samples, whose error falls as the square of its spacing over the distance, then the dense tree for the
    # grid points near the surface
    coarse = points[np.random.default_rng(0).permutation(len(points))[:COARSE_SAMPLES]]
    # the queries on every core (the grid is built once, before any solver starts): the same values, sooner
    distance, nearest_coarse = cKDTree(coarse).query(grid, workers=-1)
    index = np.zeros(len(grid), dtype=int)
    close = distance < FAR_M
    distance[close], index[close] = tree.query(grid[close], workers=-1)
    if inside is None:  # the sign far away from the coarse sample's normal
        index[~close] = tree.query(coarse[nearest_coarse[~close]], workers=-1)[1]
    along = ((grid - points[index]) * normals[index]).sum(axis=1)
    sample_spacing = float(np.median(tree.query(points[:2000], k=2)[0][:, 1]))
    near = distance < 2 * spacing + sample_spacing
    sign = np.where(inside(grid), -1.0, 1.0) if inside is not None else np.sign(along)
    values = np.where(near, np.abs(along), distance) * sign
    return DistanceGrid(low, float(spacing), values.reshape(tuple(counts)))
