"""The Ferrari-Canny epsilon metric: the radius of the largest origin-centred ball inside the convex hull of
the primitive contact wrenches (the L1 grasp wrench space), computed with qhull through scipy."""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError


def ferrari_canny(wrenches: np.ndarray) -> float:
    """Epsilon of ``(..., 6)`` primitive wrenches (torques already divided by a characteristic length).

    0 when the origin is not strictly inside the hull, which includes every grasp whose wrenches do not span
    all six dimensions (e.g. two antipodal point contacts without torsional friction): no force closure.
    """
    points = np.asarray(wrenches, dtype=float).reshape(-1, 6)
    if len(points) < 7 or np.linalg.matrix_rank(points, tol=1e-9 * np.abs(points).max()) < 6:
        return 0.0
    try:
        hull = ConvexHull(points)
    except QhullError:
        return 0.0
    # each facet: unit normal . x + offset <= 0 inside; the origin's distance to it is -offset
    distances = -hull.equations[:, -1]
    return float(distances.min()) if distances.min() > 0 else 0.0
