"""The polish (SPEC section 12): a basin's end point solved by the paper's Section 6 NLP, warm-started there.

The polish is a start of the paper's route that begins at the search's end point as it is (neither placed nor
moved by the geometric phase), with the task forces, eq. 10's cone-edge forces and activations at the force
problem's solution and eq. 4's weights at the search's: the whole of the NLP's point. A grasp the verifier
rejects is solved again from the retry postures as any start is. Every grasp the search route reports is a
polished one, a KKT point of the paper's model judged by the verifier and the physics check.
"""

from __future__ import annotations

from dataclasses import dataclass

from grasptask.synthesis.search import SearchEnd
from grasptask.synthesis.starts import Start, StartJob


@dataclass(frozen=True)
class Polish(StartJob):
    """A worker's job: polish the search's ``end`` of ``start``."""

    end: SearchEnd

    def warm_start(self) -> Start:
        """The start the polish solves: the end point's grasp, as a warm start is."""
        grasp = self.end.grasp
        assert grasp is not None, "a polish of a search that did not converge"
        start = self.start
        return Start(
            start.start_id,
            start.orientation,
            start.position_name,
            grasp.palm_rotation,
            grasp.palm_position,
            grasp.joint_angles,
        )
