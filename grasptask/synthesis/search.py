"""The search of route search (SPEC section 12) as the workers run it: a batch of starts placed, searched together
(:mod:`grasptask.synthesis.batch_search`) and each end point judged by the force problem's QPs.

A batch is fixed by the round's starts and the solver config's ``search.batch_size`` alone (never by the
workers), so a start's end point is the same with any number of workers and on Dask.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from grasptask.synthesis.starts import Start

if TYPE_CHECKING:  # the solver stack loads in the workers
    from grasptask.synthesis.force_problem import ForceSolution


@dataclass(frozen=True)
class EndGrasp:
    """The grasp where a search ended: palm pose, joints, contacts and outward normals (the NLP's, at that pose)."""

    palm_rotation: np.ndarray
    palm_position: np.ndarray
    joint_angles: np.ndarray
    contacts: np.ndarray
    normals: np.ndarray


@dataclass(frozen=True)
class SearchEnd:
    """Where a start's search ended: ``converged`` (every contact on the surface, no collision, the pads facing
    it: the end point is grouped and may be polished), or why not; its share of the batch's seconds; where it
    converged, the grasp there and the force problem's solution at it."""

    start_id: int
    status: str
    iterations: int
    seconds: float
    attempts: int
    message: str
    grasp: EndGrasp | None = None
    forces: ForceSolution | None = None

    @property
    def converged(self) -> bool:
        return self.grasp is not None and self.forces is not None


@dataclass(frozen=True)
class SearchBatch:
    """A worker's job: search ``starts`` as one batch. It answers for its first start where a row must name one
    (a worker that crashed on it)."""

    starts: tuple[Start, ...]

    @property
    def start_id(self) -> int:
        return self.starts[0].start_id

    @property
    def orientation(self) -> int:
        return self.starts[0].orientation

    @property
    def position_name(self) -> str:
        return self.starts[0].position_name


def batches(starts: list[Start], size: int) -> list[SearchBatch]:
    """``starts`` in batches of ``size``, in their order."""
    return [SearchBatch(tuple(starts[k : k + size])) for k in range(0, len(starts), size)]
