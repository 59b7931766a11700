"""A mesh link covered by spheres fitted to it, each poking out of the mesh by at most :data:`BOUND_M`.

A sphere centred ``d`` inside the surface (``d`` its distance to the nearest surface point) with radius
``d + b`` pokes out by at most ``b``: any point of it outside the mesh lies past a surface point at least ``d``
from the centre. So candidate centres are surface samples moved inward along their normals, kept where the
nearest surface is still as far as they moved (the inside of the link, not through its far side), and a greedy
set cover picks among them until every surface sample and vertex lies in a sphere. The mesh's oriented bounding
box, covered as a box, wrapped the LEAP Hand's fingers in blobs that hid the object.

Meshes as hand files ship them are often open or self-intersecting, so nothing here needs an inside test."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.sparse import csr_matrix
from scipy.spatial import cKDTree

from grasptask.errors import BadInputError
from grasptask.hand import skin
from grasptask.hand.mesh_orientation import outward
from grasptask.hand.spheres import mesh_box
from grasptask.hand.tree import Shape

#: the most a sphere of the cover reaches outside its mesh (m); a box cover's bulge off a 1 cm thick link is 2.2
BOUND_M = 0.0025
#: a link's cover holds at most this many spheres; the greedy's bound climbs a ladder of GROWTH steps to MAX_BOUND_M
MAX_SPHERES, GROWTH, MAX_BOUND_M = 24, 1.25, 0.016
#: a box-shaped link's box cover is kept with up to this many spheres (a palm's takes 30)
MAX_BOX_SPHERES = 64
#: how far inside the surface candidate centres are placed (multiples of the bound)
DEPTHS = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 13.0, 16.0, 24.0)
#: at most this many candidate centres per depth
MAX_CANDIDATES = 600
#: at most this many surface samples per mesh (a palm's area at the spacing would give tens of thousands)
MAX_SAMPLES = 40000


def surface_samples(vertices: np.ndarray, faces: np.ndarray, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Points spread over the faces about ``spacing`` apart, with the vertices, and the outward normal at each
    (area-weighted vertex normals for the vertices)."""
    import trimesh  # deferred: trimesh, only for mesh links

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    count = int(np.clip(np.ceil(mesh.area / spacing**2), 1, MAX_SAMPLES))
    points, index = trimesh.sample.sample_surface(mesh, count, seed=0)
    normals = np.vstack([mesh.face_normals[index], mesh.vertex_normals])
    return np.vstack([points, mesh.vertices]), normals


def mesh_spheres(
    vertices: np.ndarray, faces: np.ndarray, transform: np.ndarray
) -> tuple[list[tuple[np.ndarray, float]], float]:
    """Spheres (centre in the frame ``transform`` places the mesh in, radius) that hold every vertex of the mesh,
    at most :data:`MAX_SPHERES` of them, and the most they reach outside it (measured).

    A box-shaped link keeps the few spheres of its oriented bounding box, covered as a box, when they reach at
    most :data:`BOUND_M` outside it. Other links get the fewest fitted spheres that reach no farther, or, where
    :data:`MAX_SPHERES` cannot (a sharp 2 x 3 x 5 cm box needs 215 at 2.5 mm, every edge and corner its own),
    the closest that so few can, or the box's spheres if they reach less far."""
    vertices, faces = outward(np.asarray(vertices, float), np.asarray(faces, int))
    points, normals = surface_samples(vertices, faces, BOUND_M / 2)
    boxed = mesh_box(vertices, np.eye(4))  # a thin plate's box takes thousands of spheres: not measured
    boxed_reach = reach(boxed, points, normals) if len(boxed) <= MAX_BOX_SPHERES else np.inf
    chosen, chosen_reach = boxed, boxed_reach
    if boxed_reach > BOUND_M:  # a box-shaped link keeps its box's few spheres
        fitted, fitted_reach = _fewest_within(vertices, faces, points, normals)
        if fitted_reach < boxed_reach - 1e-4:
            chosen, chosen_reach = fitted, fitted_reach
    placed = [(transform[:3, :3] @ c + transform[:3, 3], r) for c, r in chosen]
    # on an open mesh the normals need not point out, and the measured reach can miss a sphere's far side: the
    # stated reach is at least how far a sphere leaves the mesh's bounding box
    return placed, max(chosen_reach, box_overreach(chosen, vertices))


def box_overreach(spheres: list[tuple[np.ndarray, float]], vertices: np.ndarray) -> float:
    """How far the farthest sphere leaves the vertices' axis-aligned bounding box (0 if none does)."""
    if not spheres:
        return 0.0
    centre, radius = np.array([c for c, _ in spheres]), np.array([r for _, r in spheres])[:, None]
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    return float(max(0.0, (low - (centre - radius)).max(), ((centre + radius) - high).max()))


def _fewest_within(
    vertices: np.ndarray, faces: np.ndarray, points: np.ndarray, normals: np.ndarray
) -> tuple[list[tuple[np.ndarray, float]], float]:
    """The greedy cover at the largest of a ladder of bounds whose measured reach stays within :data:`BOUND_M`
    (the greedy reaches about 0.6 of the bound it is given, so larger bounds than BOUND_M usually still hold),
    with at most :data:`MAX_SPHERES`; if none does, the first on the ladder that takes so few spheres."""
    best: tuple[list[tuple[np.ndarray, float]], float] | None = None
    bound = BOUND_M
    while bound <= MAX_BOUND_M:
        spheres = fitted_spheres(vertices, faces, bound, MAX_SPHERES)
        if spheres is not None:
            measured = reach(spheres, points, normals)
            if measured > BOUND_M:
                return best or (spheres, measured)
            best = (spheres, measured)
        bound *= GROWTH
    if best is not None:
        return best
    spheres = fitted_spheres(vertices, faces, bound, None) or []
    return spheres, reach(spheres, points, normals)


def reach(spheres: list[tuple[np.ndarray, float]], points: np.ndarray, normals: np.ndarray) -> float:
    """How far the spheres' union reaches outside the surface sampled by ``points`` (outward ``normals``): the
    farthest point of their boundary in front of its nearest sample's tangent plane, at 200 directions per
    sphere (exact on flat faces; the samples' spacing would add up to half of it)."""
    centre = np.array([c for c, _ in spheres])
    radius = np.array([r for _, r in spheres])
    directions = skin.sphere_directions(200)
    boundary = (centre[:, None, :] + radius[:, None, None] * directions[None]).reshape(-1, 3)
    inner = np.zeros(len(boundary), dtype=bool)
    for c, r in zip(centre, radius, strict=True):
        inner |= np.linalg.norm(boundary - c, axis=1) < r - 1e-9
    exposed = boundary[~inner]
    _, which = cKDTree(points).query(exposed)
    ahead = np.einsum("ij,ij->i", exposed - points[which], normals[which])  # off the nearest sample's tangent plane
    return float(max(ahead.max(), 0.0)) if len(ahead) else 0.0


def fitted_spheres(
    vertices: np.ndarray, faces: np.ndarray, bound: float, most: int | None = None
) -> list[tuple[np.ndarray, float]] | None:
    """The greedy cover at one ``bound``: every vertex and surface sample held, nothing more than ``bound``
    outside the mesh; None if it takes more than ``most`` spheres."""
    points, normals = surface_samples(np.asarray(vertices, float), np.asarray(faces, int), bound / 2)
    usable = np.isfinite(normals).all(axis=1) & (np.linalg.norm(normals, axis=1) > 0.5)
    tree = cKDTree(points)
    centres, radii = [], []
    rng = np.random.default_rng(0)
    seeds = np.flatnonzero(usable)
    seeds = seeds if len(seeds) <= MAX_CANDIDATES else np.sort(rng.choice(seeds, MAX_CANDIDATES, replace=False))
    centres.append(points)  # each sample may be held by a sphere of its own, the bound's size at most
    radii.append(np.full(len(points), bound / 2))
    for depth in DEPTHS[1:]:
        inward = points[seeds] - normals[seeds] * depth * bound
        nearest, which = tree.query(inward)
        behind = np.einsum("ij,ij->i", inward - points[which], normals[which]) < 0
        inside = behind & (nearest >= 0.9 * depth * bound - bound / 2)  # not through the link's far side
        centres.append(inward[inside])
        radii.append(nearest[inside] + bound - bound / 2)  # the samples' spacing eats into the bound
    centre, radius = np.vstack(centres), np.concatenate(radii)
    # a candidate that leaves the bounding box by more than the bound is refused: on an open or non-manifold
    # mesh (a palm plate, a shell) "inward" can be outward, and the nearest surface far (a 354 mm sphere)
    low, high = vertices.min(axis=0) - bound, vertices.max(axis=0) + bound
    within = ((centre - radius[:, None]) >= low).all(axis=1) & ((centre + radius[:, None]) <= high).all(axis=1)
    centre, radius = centre[within], radius[within]
    chosen = _greedy_cover(points, tree, centre, radius, most)
    if chosen is None:
        return None
    return [(c, float(r)) for c, r in zip(centre[chosen], radius[chosen], strict=True)]


def _greedy_cover(
    points: np.ndarray, tree: cKDTree, centre: np.ndarray, radius: np.ndarray, most: int | None
) -> list[int] | None:
    """Candidates chosen one by one, each the one that holds the most points not yet held, until all are."""
    members = tree.query_ball_point(centre, radius)
    lengths = np.array([len(m) for m in members])
    columns = np.concatenate([np.asarray(m, dtype=int) for m in members])
    holds = csr_matrix((np.ones(len(columns)), columns, np.r_[0, np.cumsum(lengths)]), shape=(len(centre), len(points)))
    loose = np.ones(len(points))
    chosen: list[int] = []
    while loose.any():
        gain = holds @ loose
        best = int(np.argmax(gain))
        if gain[best] == 0:
            raise ValueError(f"{int(loose.sum())} surface points no candidate sphere holds")
        chosen.append(best)
        if most is not None and len(chosen) > most:
            return None
        loose[holds[best].indices] = 0.0
    return chosen


def mesh_shape(vertices: np.ndarray, faces: np.ndarray, transform: np.ndarray, link: str, path: Path) -> Shape:
    """A link's collision mesh as a shape: its fitted spheres, its surface points and its triangles, in the
    link's frame (``transform`` places the mesh there); refused with the file and the link when it is no
    surface."""
    vertices, faces = np.asarray(vertices, dtype=float), np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if not np.isfinite(vertices).all():
        raise BadInputError(path, f"link '{link}': the collision mesh has vertices that are not finite numbers")
    if len(vertices) < 4 or not len(faces) or faces.max() >= len(vertices) or faces.min() < 0:
        raise BadInputError(path, f"link '{link}': the collision mesh has no surface ({len(faces)} triangles)")
    area = np.linalg.norm(np.cross(*(vertices[faces[:, 1:]] - vertices[faces[:, :1]]).transpose(1, 0, 2)), axis=1)
    if area.sum() <= 0:
        raise BadInputError(path, f"link '{link}': the collision mesh has no area")
    spheres, reach_m = mesh_spheres(vertices, faces, transform)
    placed = vertices @ transform[:3, :3].T + transform[:3, 3]
    return Shape(spheres, skin.mesh(vertices, transform), mesh=(placed, faces), reach_m=reach_m)
