"""A link's mesh the right way out: some exporters write a closed mesh's faces inward, and a cover, a pad and the
verifier's "outside the tip" all read the faces' normals."""

from __future__ import annotations

import numpy as np


def outward(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A closed mesh whose faces point inward (as some exporters write them) turned outward; others as given."""
    import trimesh  # deferred: trimesh, only for mesh links

    mesh = trimesh.Trimesh(vertices, faces, process=False)
    with np.errstate(invalid="ignore", divide="ignore"):  # a flat closed mesh has no volume to divide by
        inward = mesh.is_watertight and mesh.is_winding_consistent and mesh.volume < 0
    if inward:
        return vertices, faces[:, ::-1].copy()
    return vertices, faces
