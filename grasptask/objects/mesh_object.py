"""Objects given as a closed triangle mesh or a point cloud with normals, in their task frame, judged against
the mesh or the points themselves.

The verifier's distances, closest points and normals here are trimesh's exact ones on the triangles. Normals
are interpolated from each face's corner normals, so that they turn smoothly across a finely tessellated curve,
but not across a crease: a corner averages only the faces within :data:`CREASE_DEG` of its own. A box's face
then has its own normal up to its edge (averaged across the edge, it was 27 degrees off 1 mm from it). A point
whose nearest point is on a crease gets the direction from there to the point, the contact normal of a ball
that touches the edge. The NLP never sees this class's numbers: synthesis constrains a surrogate of the surface
built from the mesh.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import trimesh
from scipy.spatial import cKDTree

from grasptask.objects.distance_grid import DistanceGrid, distance_grid, kept_grid
from grasptask.objects.surface import ImplicitObject, SurfaceIndex, Symmetry, surface_mesh

#: the default spacing of the synthesis surrogate's grid (m): its zero set within 0.7 mm of the mug's triangles
GRID_SPACING_M = 0.0025
#: faces meeting at more than this angle form a crease, across which normals are not averaged (30 degrees:
#: the usual auto-smooth angle of 3D modelling tools)
CREASE_DEG = 30.0


@dataclass(eq=False)
class MeshObject(ImplicitObject):
    mesh: trimesh.Trimesh  # closed, outward faces, metres, in the task frame
    name: str = "mesh"
    symmetry: Symmetry | None = None
    mass_kg: float | None = None
    #: the task frame's pose in the world, for placing the object (not used by synthesis, which works in it)
    world_pose: np.ndarray | None = None
    grid_spacing: float = GRID_SPACING_M  # of the synthesis surrogate's distance grid (m)
    #: the task frame in the file's own coordinates (metres), how it was chosen (centre, origin or given) and, for
    #: the centre, how its axes were (:mod:`grasptask.objects.principal_frame`)
    task_frame: np.ndarray | None = None
    task_frame_rule: str = "origin"
    task_frame_axes: str = ""

    def bounds(self) -> np.ndarray:
        return np.array(self.mesh.bounds, dtype=float)

    def signed_distance(self, p: np.ndarray) -> np.ndarray:
        """Euclidean signed distance to the triangles (m), negative inside."""
        return -trimesh.proximity.signed_distance(self.mesh, np.atleast_2d(p))

    def closest_point(self, p: np.ndarray, exact: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """The closest point on the triangles, and the outward normal there (always exact): interpolated from the
        face's corner normals, or the direction to ``p`` where the nearest point is on a crease and ``p`` is off
        the surface."""
        p = np.atleast_2d(np.asarray(p, dtype=float))
        closest, distance, triangle = self.mesh.nearest.on_surface(p)
        corners = self.mesh.triangles[triangle]
        weights = trimesh.triangles.points_to_barycentric(corners, closest)
        normal = np.einsum("nk,nki->ni", weights, self.corner_normals[triangle])
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        # on a crease (a corner's weight ~0: the point is on the edge opposite it), the normal is the offset to p
        # itself, turned outward when p is inside
        on_crease = ((weights < 1e-6) & self.creases[triangle]).any(axis=1) & (distance > 1e-6)
        direction = (p - closest)[on_crease] / distance[on_crease, None]
        outward = np.sign((direction * normal[on_crease]).sum(axis=1, keepdims=True))
        normal[on_crease] = direction * np.where(outward == 0, 1.0, outward)
        return closest, normal

    @cached_property
    def creases(self) -> np.ndarray:
        """``(faces, 3)``: whether the edge opposite each face corner is a crease (its faces more than
        :data:`CREASE_DEG` apart)."""
        mesh = self.mesh
        n = len(mesh.vertices)
        sharp = np.sort(mesh.face_adjacency_edges[mesh.face_adjacency_angles > np.radians(CREASE_DEG)], axis=1)
        codes = sharp[:, 0] * n + sharp[:, 1]
        faces = mesh.faces
        opposite = np.stack([faces[:, [1, 2]], faces[:, [2, 0]], faces[:, [0, 1]]], axis=1)  # (faces, 3, 2)
        opposite = np.sort(opposite, axis=2)
        return np.isin(opposite[:, :, 0] * n + opposite[:, :, 1], codes)

    @cached_property
    def corner_normals(self) -> np.ndarray:
        """``(faces, 3, 3)``: at each face's corners, the area-weighted mean normal of the faces around that
        vertex that lie within :data:`CREASE_DEG` of this face."""
        mesh = self.mesh
        normals, areas = mesh.face_normals, mesh.area_faces
        around = mesh.vertex_faces[mesh.faces]  # (faces, 3, k), padded with -1
        cosine = np.cos(np.radians(CREASE_DEG))
        total = np.zeros((len(mesh.faces), 3, 3))
        for k in range(around.shape[2]):
            valid = around[:, :, k] >= 0
            other = np.where(valid, around[:, :, k], 0)
            n = normals[other]
            smooth = valid & ((n * normals[:, None, :]).sum(axis=2) >= cosine)
            total += (smooth * areas[other])[:, :, None] * n
        return total / np.linalg.norm(total, axis=2, keepdims=True)

    def g(self, p: np.ndarray) -> np.ndarray:
        return self.signed_distance(p)

    def gradient(self, p: np.ndarray) -> np.ndarray:
        """The gradient of the signed distance: the outward normal at the closest point."""
        return self.closest_point(p)[1]

    @property
    def characteristic_length(self) -> float:
        return float(np.linalg.norm(self.mesh.vertices - self.centre, axis=1).max())

    @cached_property
    def surface(self) -> SurfaceIndex:
        """Samples of the triangles themselves (no marching cubes: the mesh is the surface)."""
        spacing = 7e-4
        count = int(min(200_000, max(2000, self.mesh.area / spacing**2)))
        points, faces = trimesh.sample.sample_surface(self.mesh, count, seed=0)
        points = np.asarray(points)
        normals = np.asarray(self.mesh.face_normals[faces])
        return SurfaceIndex(points, normals, self.mesh, float(np.sqrt(self.mesh.area / count)), cKDTree(points))

    def picture(self, faces: int = 5000) -> trimesh.Trimesh:
        return self.mesh

    def surface_samples(self, count: int = 6000) -> tuple[np.ndarray, np.ndarray]:
        """Points spread evenly over the triangles, with their faces' outward normals."""
        points, faces = trimesh.sample.sample_surface_even(self.mesh, count, seed=0)
        return np.asarray(points), np.asarray(self.mesh.face_normals[faces])

    @cached_property
    def distance_grid(self) -> DistanceGrid:
        """The synthesis surrogate's data: samples every 0.5 mm, signs from the mesh's inside test. Made once per
        object: a worker builds two or three models on it, and the spline's coefficients are made once per grid."""
        count = int(min(400_000, max(20_000, self.mesh.area / 5e-4**2)))

        def make() -> DistanceGrid:
            points, faces = trimesh.sample.sample_surface(self.mesh, count, seed=0)
            return distance_grid(
                np.asarray(points),
                self.mesh.face_normals[faces],
                self.bounds(),
                self.grid_spacing,
                inside=self.mesh.contains,
            )

        vertices, faces = np.asarray(self.mesh.vertices, np.float64), np.asarray(self.mesh.faces, np.int64)
        return kept_grid(self.name, ("mesh", vertices, faces, count, self.grid_spacing), make)


@dataclass(eq=False)
class PointCloudObject(ImplicitObject):
    """An object given as surface points with outward normals, in its task frame. Distances are to the tangent
    plane of the nearest point near the surface (to the point itself farther out), so they are as accurate as
    the cloud is dense: about the square of the spacing over the curvature radius."""

    points: np.ndarray  # (n, 3) metres
    normals: np.ndarray  # (n, 3) outward unit normals
    name: str = "points"
    symmetry: Symmetry | None = None
    mass_kg: float | None = None
    world_pose: np.ndarray | None = None
    grid_spacing: float = GRID_SPACING_M
    task_frame: np.ndarray | None = None
    task_frame_rule: str = "origin"
    task_frame_axes: str = ""

    @cached_property
    def tree(self) -> cKDTree:
        return cKDTree(self.points)

    @cached_property
    def spacing(self) -> float:
        return float(np.median(self.tree.query(self.points, k=2)[0][:, 1]))

    def bounds(self) -> np.ndarray:
        return np.stack([self.points.min(axis=0), self.points.max(axis=0)])

    def _nearest(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p = np.atleast_2d(p)
        distance, index = self.tree.query(p)
        offset = p - self.points[index]
        along = (offset * self.normals[index]).sum(axis=1)
        near = distance < 3 * self.spacing
        signed = np.where(near, along, np.sign(along) * distance)
        return signed, index, along

    def signed_distance(self, p: np.ndarray) -> np.ndarray:
        return self._nearest(p)[0]

    def closest_point(self, p: np.ndarray, exact: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """The foot of each point on its nearest sample's tangent plane (``exact`` changes nothing)."""
        signed, index, along = self._nearest(p)
        normals = self.normals[index]
        return np.atleast_2d(p) - along[:, None] * normals, normals

    def g(self, p: np.ndarray) -> np.ndarray:
        return self.signed_distance(p)

    def gradient(self, p: np.ndarray) -> np.ndarray:
        return self.normals[self._nearest(p)[1]]

    @property
    def characteristic_length(self) -> float:
        return float(np.linalg.norm(self.points - self.centre, axis=1).max())

    @cached_property
    def surface(self) -> SurfaceIndex:
        return SurfaceIndex(self.points, self.normals, self.picture(), self.spacing, self.tree)

    @cached_property
    def distance_grid(self) -> DistanceGrid:
        """The synthesis surrogate's data, signs from the nearest point's normal; made once per object."""
        made_from = (
            "points",
            np.asarray(self.points, np.float64),
            np.asarray(self.normals, np.float64),
            self.grid_spacing,
        )
        return kept_grid(
            self.name, made_from, lambda: distance_grid(self.points, self.normals, self.bounds(), self.grid_spacing)
        )

    def picture(self, faces: int = 5000) -> trimesh.Trimesh:
        """A closed surface for drawing: marching cubes of the cloud's signed distance."""
        return surface_mesh(self, max(2 * self.spacing, float(np.ptp(self.points, axis=0).max()) / 60))
