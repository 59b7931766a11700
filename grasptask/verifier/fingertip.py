"""How far a contact lies from its fingertip's own collision mesh: the NLP rolls a mesh fingertip's contact over
a sphere fitted to its pad, and the verifier checks the contact against the triangles themselves (numpy only)."""

from __future__ import annotations

import numpy as np


def point_triangle_distance(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """``(p,)``: each point's distance to the nearest of ``triangles`` ``(t, 3, 3)``, by the closest point on each
    triangle (its face, an edge or a corner: the regions of Ericson's Real-Time Collision Detection, 5.1.5)."""
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
    distance = np.linalg.norm(p - closest, axis=-1)
    return np.nan_to_num(distance, nan=np.inf).min(axis=1)


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return (u * v).sum(axis=-1)
