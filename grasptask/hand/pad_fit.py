"""The pad of a mesh fingertip: a sphere fitted to the part of its surface that faces the way the finger closes.

A fingertip given as a sphere or capsule carries its pad's surface in its shape. A mesh does not, so the pad is
fitted: the faces whose outward normal is within :data:`FACING_DEG` of the direction they move in as the last
joint closes the finger, in the distal end of the tip (within the tip's half-width of its farthest point), and a
sphere fitted to their vertices by least squares. The contact rolls over that sphere as over a sphere
fingertip's, and its RMS distance from the faces' vertices is the fit error a user is shown.

A box fingertip's pad is the face of the box that faces the way the finger closes, flat: no sphere is fitted to
it (:func:`box_pad`); so is a mesh fingertip's whose pad is flat (:func:`flat_face`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasptask.hand.hand_model import Pad

#: a face belongs to the pad when its normal is within this angle of the way it moves as the finger closes
FACING_DEG = 60.0
#: a mesh pad is flat when faces within this angle of one normal, and within the compliance of one plane, hold ...
FLAT_DEG = 5.0
#: ... at least this share of the area that faces the way the finger closes
FLAT_SHARE = 0.5


@dataclass(frozen=True)
class PadFit:
    centre: np.ndarray  # the fitted sphere's centre, in the last link's frame
    radius: float  # m
    error_m: float  # RMS distance of the pad's faces from the sphere
    faces: int  # how many faces the pad took


def box_pad(
    boxes: list[tuple[np.ndarray, np.ndarray]], axis: np.ndarray, closing: float, sliding: bool = False
) -> Pad | None:
    """The flat pad of a box fingertip: of the boxes ``(half sizes, 4 x 4 frame)`` in its last joint's frame, the
    one farthest from the joint, and its face whose outward normal is nearest the way the box's centre moves as
    the joint (about ``axis``, or along it if ``sliding``; ``closing`` its sign) closes the finger. None for a
    box centred on a turning joint's axis, which does not move as the finger closes."""
    half, frame = max(boxes, key=lambda box: float(np.linalg.norm(box[1][:3, 3])))
    centre, rotation = frame[:3, 3], frame[:3, :3]
    facing = rotation.T @ motion(axis, closing, centre, sliding)  # the motion in the box's own axes
    if np.linalg.norm(facing) < 1e-9:
        return None
    k = int(np.argmax(np.abs(facing)))
    normal = np.sign(facing[k]) * rotation[:, k]
    others = [i for i in range(3) if i != k]
    corners = np.array([[a, b] for a in (-1, 1) for b in (-1, 1)], dtype=float)
    face = centre + half[k] * normal + corners @ (half[others, None] * rotation[:, others].T)
    return _flat_pad(centre + half[k] * normal, normal, centre, face, rotation[:, others[0]])


def flat_face(
    vertices: np.ndarray, faces: np.ndarray, axis: np.ndarray, closing: float, compliance: float, sliding: bool = False
) -> Pad | None:
    """The flat pad of a mesh fingertip whose pad is a flat face (a printed box tip), else
    None: of the faces that face the way the finger closes (as for :func:`fit_pad`), those within
    :data:`FLAT_DEG` of their commonest normal and within ``compliance`` of their outermost plane, when they hold
    at least :data:`FLAT_SHARE` of those faces' area. Pressed on a flat surface, such a pad touches over all of
    it, where a sphere fitted to it would touch at one point."""
    normals, areas, centres, facing = _facing_faces(vertices, faces, axis, closing, sliding)
    if facing.sum() < 2:
        return None
    normals, areas, triangles = normals[facing], areas[facing], faces[facing]
    cosine = np.cos(np.radians(FLAT_DEG))
    around = np.concatenate(  # the area within FLAT_DEG of each face's normal, a block of faces at a time
        [(normals[k : k + 1024] @ normals.T >= cosine) @ areas for k in range(0, len(normals), 1024)]
    )
    cluster = normals @ normals[int(np.argmax(around))] >= cosine  # about the normal with the most area
    normal = areas[cluster] @ normals[cluster]
    normal = normal / np.linalg.norm(normal)
    heights = vertices[triangles] @ normal  # (faces, 3)
    outer = float(heights[cluster].max())
    coplanar = cluster & (heights.min(axis=1) >= outer - compliance)
    if areas[coplanar].sum() < FLAT_SHARE * areas.sum():
        return None
    middle = (areas[coplanar] @ centres[facing][coplanar]) / areas[coplanar].sum()
    point = middle + (outer - middle @ normal) * normal
    face = vertices[np.unique(triangles[coplanar])]
    return _flat_pad(point, normal, vertices.mean(axis=0), face, np.cross(axis, normal))


def _flat_pad(point: np.ndarray, normal: np.ndarray, body: np.ndarray, face: np.ndarray, fallback: np.ndarray) -> Pad:
    """A flat pad at ``point`` with outward ``normal``; its first cone edge along the finger (from the joint to
    ``body``, the tip's middle) in the face's plane, ``fallback``'s direction where the finger is square to it;
    its half-extents the nearer side of the ``face`` points' spread about the point, along and across."""
    along = body / max(float(np.linalg.norm(body)), 1e-300)
    tangent = along - (along @ normal) * normal
    if np.linalg.norm(tangent) < 1e-9:
        tangent = fallback - (fallback @ normal) * normal
    if np.linalg.norm(tangent) < 1e-9:  # a jaw sliding along its face's normal: any direction in the face
        tangent = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    tangent = tangent / np.linalg.norm(tangent)
    across = np.cross(normal, tangent)
    offsets = face - point
    extents = tuple(float(min((offsets @ d).max(), -(offsets @ d).min(), 1.0)) for d in (tangent, across))
    return Pad(point, normal, tangent, flat=True, half_extents=(max(extents[0], 0.0), max(extents[1], 0.0)))


def boxes_mesh(boxes: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """The boxes' triangles as one mesh (vertices, faces), for the verifier to measure a contact against."""
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    # each face as two triangles, wound outward (corner index bits: x 4, y 2, z 1)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], dtype=np.int64)
    vertices, triangles = [], []
    for n, (half, frame) in enumerate(boxes):
        vertices.append((signs * half) @ frame[:3, :3].T + frame[:3, 3])
        triangles.append(faces + 8 * n)
    return np.vstack(vertices), np.vstack(triangles)


class NoPadError(ValueError):
    """The fingertip has no surface that faces the way the finger closes."""


def fit_pad(vertices: np.ndarray, faces: np.ndarray, axis: np.ndarray, closing: float, sliding: bool = False) -> PadFit:
    """The pad sphere of a fingertip mesh whose ``vertices`` are in its last joint's frame (the joint turning
    about ``axis`` through the origin, or sliding along it; ``closing`` is +1 or -1, the sign of the motion that
    closes the finger)."""
    normals, areas, centres, facing = _facing_faces(vertices, faces, axis, closing, sliding)
    along = (areas @ centres) / max(float(areas.sum()), 1e-300)
    along = along / max(float(np.linalg.norm(along)), 1e-300)  # from the joint to the tip's middle
    tip = vertices @ along
    mid_motion = motion(axis, closing, vertices.mean(axis=0), sliding)
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


def motion(axis: np.ndarray, closing: float, points: np.ndarray, sliding: bool = False) -> np.ndarray:
    """The way ``points`` (in the last joint's frame) move as the joint closes the finger: ``closing a x p`` for
    a joint turning about ``a``, ``closing a`` for one sliding along it (a gripper's jaw)."""
    if sliding:
        return np.broadcast_to(closing * np.asarray(axis, dtype=float), np.shape(points)).copy()
    return closing * np.cross(axis, points)


def _facing_faces(
    vertices: np.ndarray, faces: np.ndarray, axis: np.ndarray, closing: float, sliding: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each face's unit normal, area and centre, and whether it faces the way it moves as the finger closes
    (within :data:`FACING_DEG`)."""
    corners = vertices[faces]
    centres = corners.mean(axis=1)
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    areas = np.linalg.norm(cross, axis=1) / 2
    normals = cross / np.maximum(2 * areas, 1e-300)[:, None]
    moving = motion(axis, closing, centres, sliding)
    speed = np.linalg.norm(moving, axis=1)
    facing = (speed > 1e-9) & (areas > 0)
    facing[facing] = np.einsum("ij,ij->i", normals[facing], moving[facing] / speed[facing, None]) >= np.cos(
        np.radians(FACING_DEG)
    )
    return normals, areas, centres, facing


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
