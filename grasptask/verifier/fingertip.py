"""How far a contact lies outside its fingertip's own collision mesh: the NLP rolls a mesh fingertip's contact
over a sphere fitted to its pad, and the verifier checks the contact against the triangles themselves (numpy
only)."""

from __future__ import annotations

import numpy as np


def outside_distance(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(p,)``: how far each point lies outside the closed mesh of ``triangles`` (negative: inside), its distance
    to the nearest triangle signed by that triangle's side, the mesh's faces turned outward first (by the sign of
    its volume)."""
    distance, nearest = _nearest(points, triangles)
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    normals = np.cross(b - a, c - a)
    if np.einsum("ij,ij->", a, np.cross(b, c)) < 0:  # six times the signed volume: faces turned inward
        normals = -normals
    side = np.einsum("ij,ij->i", points - triangles[nearest, 0], normals[nearest])
    return np.where(side < 0, -distance, distance)


def _nearest(points: np.ndarray, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each point's distance to the nearest of ``triangles`` ``(t, 3, 3)``, and which triangle that is, by the
    closest point on each (its face, an edge or a corner: the regions of Ericson's Real-Time Collision Detection,
    5.1.5)."""
    a, b, c = (triangles[None, :, k] for k in range(3))
    p = points[:, None, :]
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = _dot(ab, ap), _dot(ac, ap)
    bp, cp = p - b, p - c
    d3, d4 = _dot(ab, bp), _dot(ac, bp)
    d5, d6 = _dot(ab, cp), _dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denominator = va + vb + vc
        v, w = vb / denominator, vc / denominator
        closest = a + v[..., None] * ab + w[..., None] * ac  # inside the face
        on_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
        closest = np.where(on_ab[..., None], a + (d1 / (d1 - d3))[..., None] * ab, closest)
        on_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
        closest = np.where(on_ac[..., None], a + (d2 / (d2 - d6))[..., None] * ac, closest)
        on_bc = (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0)
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        closest = np.where(on_bc[..., None], b + t[..., None] * (c - b), closest)
    closest = np.where(((d1 <= 0) & (d2 <= 0))[..., None], a, closest)
    closest = np.where(((d3 >= 0) & (d4 <= d3))[..., None], b, closest)
    closest = np.where(((d6 >= 0) & (d5 <= d6))[..., None], c, closest)
    distance = np.nan_to_num(np.linalg.norm(p - closest, axis=-1), nan=np.inf)
    nearest = distance.argmin(axis=1)
    return distance[np.arange(len(points)), nearest], nearest


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return (u * v).sum(axis=-1)
