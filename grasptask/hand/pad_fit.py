"""The pad of a mesh fingertip: a sphere fitted to the part of its surface that faces the way the finger closes.

A fingertip given as a sphere or capsule carries its pad's surface in its shape. A mesh does not, so the pad is
fitted: the faces whose outward normal is within :data:`FACING_DEG` of the direction they move in as the last
joint closes the finger, in the distal end of the tip (within the tip's half-width of its farthest point), and a
sphere fitted to their vertices by least squares. The contact rolls over that sphere as over a sphere
fingertip's, and its RMS distance from the faces' vertices is the fit error a user is shown."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: a face belongs to the pad when its normal is within this angle of the way it moves as the finger closes
FACING_DEG = 60.0


@dataclass(frozen=True)
class PadFit:
    centre: np.ndarray  # the fitted sphere's centre, in the last link's frame
    radius: float  # m
    error_m: float  # RMS distance of the pad's faces from the sphere
    faces: int  # how many faces the pad took


class NoPadError(ValueError):
    """The fingertip has no surface that faces the way the finger closes."""


def fit_pad(vertices: np.ndarray, faces: np.ndarray, axis: np.ndarray, closing: float) -> PadFit:
    """The pad sphere of a fingertip mesh whose ``vertices`` are in its last joint's frame (the joint turning
    about ``axis`` through the origin; ``closing`` is +1 or -1, the sign of the turn that closes the finger)."""
    corners = vertices[faces]
    centres = corners.mean(axis=1)
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    areas = np.linalg.norm(cross, axis=1) / 2
    normals = cross / np.maximum(2 * areas, 1e-300)[:, None]
    motion = closing * np.cross(axis, centres)
    speed = np.linalg.norm(motion, axis=1)
    facing = (speed > 1e-9) & (areas > 0)
    facing[facing] = np.einsum("ij,ij->i", normals[facing], motion[facing] / speed[facing, None]) >= np.cos(
        np.radians(FACING_DEG)
    )
    along = (areas @ centres) / max(float(areas.sum()), 1e-300)
    along = along / max(float(np.linalg.norm(along)), 1e-300)  # from the joint to the tip's middle
    tip = vertices @ along
    mid_motion = closing * np.cross(axis, vertices.mean(axis=0))
    across = mid_motion / max(float(np.linalg.norm(mid_motion)), 1e-300)
    half_width = float(np.ptp(vertices @ across)) / 2
    pad = facing & (centres @ along >= tip.max() - half_width)
    if pad.sum() < 4:
        raise NoPadError(f"no surface faces the way the finger closes ({int(facing.sum())} faces do, none distal)")
    # the pad's vertices, each weighted by a third of its faces' area: they lie on the surface, where a face's
    # centre lies inside a curved one by its chord's sag
    used = faces[pad].ravel()
    share = np.bincount(used, weights=np.repeat(areas[pad] / 3, 3), minlength=len(vertices))
    keep = np.flatnonzero(share > 0)
    points, area_weights = vertices[keep], share[keep]
    weights = np.sqrt(area_weights)
    # |x|^2 = 2 c.x + k, with k = R^2 - |c|^2: linear in (c, k)
    system = np.column_stack([2 * points, np.ones(len(points))]) * weights[:, None]
    solution, *_ = np.linalg.lstsq(system, (points**2).sum(axis=1) * weights, rcond=None)
    centre, k = solution[:3], solution[3]
    squared = k + centre @ centre
    if not np.isfinite(squared) or squared <= 0:
        raise NoPadError("the faces that face the way the finger closes fit no sphere")
    radius = float(np.sqrt(squared))
    residual = np.linalg.norm(points - centre, axis=1) - radius
    error = float(np.sqrt(np.average(residual**2, weights=area_weights)))
    return PadFit(centre, radius, error, int(pad.sum()))


def roll_limit_deg(
    vertices: np.ndarray,
    faces: np.ndarray,
    centre: np.ndarray,
    radius: float,
    normal: np.ndarray,
    allowed_m: float,
    cap_deg: float = 90.0,
    step_deg: float = 2.5,
) -> float:
    """How far from ``normal`` (deg, in steps of ``step_deg`` up to ``cap_deg``) a contact on the sphere of
    ``radius`` about ``centre`` stays within ``allowed_m`` outside the fingertip's own mesh, in every direction
    around it: beyond, a contact rolled there would lie off the real fingertip, in the air beside it (a sphere
    fitted to a LEAP Hand's pad left it by 1-6.7 mm at 45 degrees). A contact inside the mesh is the real tip
    pressing further into the object, which the penetration check judges. 0 when even the pad's home point lies
    farther out."""
    import trimesh  # deferred: trimesh's proximity queries, only for mesh fingertips

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(normal, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    azimuth = np.linspace(0.0, 2 * np.pi, 24, endpoint=False)
    reached = 0.0
    for degrees in np.arange(0.0, cap_deg + 1e-9, step_deg):
        angle = np.radians(degrees)
        ring = np.cos(angle) * normal + np.sin(angle) * (np.cos(azimuth)[:, None] * e1 + np.sin(azimuth)[:, None] * e2)
        outside = -trimesh.proximity.signed_distance(mesh, centre + radius * ring)  # trimesh: inside positive
        if outside.max() > allowed_m:
            break
        reached = float(degrees)
    return reached
