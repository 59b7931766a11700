"""Basins (SPEC section 12): the search's end points grouped so that each group is polished once.

Two end points share a basin only if their descriptors (contacts, palm centre and normal, brought to a canonical
pose under the object's symmetry: :func:`grasptask.synthesis.clustering.descriptor`) lie within the clustering
threshold of distinct optima and their force-problem Q within :data:`VALUE_SPREAD` of each other (Q, not the
value with its slack penalties: those measure how far eq. 10 is from holding there, which the polish settles). The
grouping is complete linkage: every pair in a basin meets both bounds, so a chain of near neighbours never merges
two distinct optima, at the price of sometimes splitting one optimum into two basins (each polished, then merged
by the clustering of verified optima). The grouping reads only the end points, in start order, so it is the same
with any number of workers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.cluster.hierarchy import fcluster, linkage
from scipy.spatial.distance import pdist

from grasptask.synthesis.clustering import THRESHOLD

#: two end points whose force-problem Q differ by more than this share of the larger are in different basins
VALUE_SPREAD = 0.05


@dataclass(frozen=True)
class EndPoint:
    """What the grouping reads of a search's end point: its start, descriptor and force-problem Q."""

    start_id: int
    descriptor: np.ndarray
    Q: float
    #: the force problem's value (Q and its slack penalties): which of a basin's end points is polished first
    value: float


def separation(a: EndPoint, b: EndPoint) -> float:
    """How far apart two end points are, in units of the bounds a basin allows (<= 1: they may share one)."""
    apart = float(np.linalg.norm(a.descriptor - b.descriptor)) / THRESHOLD
    larger = max(abs(a.Q), abs(b.Q), 1e-300)
    return max(apart, abs(a.Q - b.Q) / (VALUE_SPREAD * larger))


def group(ends: list[EndPoint]) -> list[list[EndPoint]]:
    """The basins of ``ends``, each best first (lowest value: nearest to meeting eq. 10, then lowest Q), ordered
    by their best end point, then start id."""
    if not ends:
        return []
    ordered = sorted(ends, key=lambda e: e.start_id)
    if len(ordered) == 1:
        labels = np.ones(1, dtype=int)
    else:
        distances = pdist(
            np.arange(len(ordered))[:, None], lambda i, j: separation(ordered[int(i[0])], ordered[int(j[0])])
        )
        labels = fcluster(linkage(distances, method="complete"), 1.0, criterion="distance")
    basins: dict[int, list[EndPoint]] = {}
    for label, end in zip(labels, ordered, strict=True):
        basins.setdefault(int(label), []).append(end)
    ranked = [sorted(members, key=lambda e: (e.value, e.start_id)) for members in basins.values()]
    return sorted(ranked, key=lambda members: (members[0].value, members[0].start_id))


def joins(end: EndPoint, basin: list[EndPoint]) -> bool:
    """Whether ``end`` may join an earlier round's ``basin``: within the bounds of every member."""
    return all(separation(end, member) <= 1.0 for member in basin)
