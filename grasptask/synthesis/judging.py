"""What a worker records of each solved point: the verifier's verdict on it, and (where configured) the physics
check's and the surrogate's error at the contacts. The judges are called here; none of their code is shared
with the NLP."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from grasptask.grasp.grasp_pose import Grasp
from grasptask.physics.judge import Holding
from grasptask.records.solutions import grasp_columns
from grasptask.synthesis.solvers import Solver, assign
from grasptask.verifier.verification import Verification
from grasptask.verifier.verify import verify

if TYPE_CHECKING:
    from grasptask.grasp.grasp_settings import GraspSettings
    from grasptask.hand.hand_model import Hand
    from grasptask.objects.surface import ImplicitObject
    from grasptask.physics.physics_settings import PhysicsSettings
    from grasptask.synthesis.backends import SolveResult
    from grasptask.synthesis.nlp import GraspNLP
    from grasptask.task.task_model import TaskModel


class Judges:
    """The verifier on every solved point; the physics check on what the verifier accepts, when a physics
    config is given; the surrogate's distance at each contact against the mesh's, on meshes and clouds."""

    def __init__(
        self,
        hand: Hand,
        obj: ImplicitObject,
        task: TaskModel,
        settings: GraspSettings,
        nlp: GraspNLP,
        physics: PhysicsSettings | None = None,
    ):
        from grasptask.synthesis.spline import distance_function  # CasADi: the solver stack, loaded in workers

        self.hand, self.obj, self.task, self.settings = hand, obj, task, settings
        # every sphere of the hand, where the NLP may carry only those near the object (a polish's)
        self.grasping = hand.grasping_hand()
        self.fingers = list(self.grasping.fingers)
        self.joint_names = self.grasping.joint_names
        # what the NLP saw of a mesh's or point cloud's surface, to record its error at each contact
        self.surrogate = distance_function(nlp.surrogate.grid) if nlp.surrogate is not None else None
        self.physics: Holding | None = None
        if physics is not None:  # MuJoCo and CoACD load here, only when asked
            self.physics = Holding.of(
                obj, settings.friction_coefficient, physics, pad_torsion=settings.torsional_friction_m
            )

    def judge(self, solver: Solver, result: SolveResult) -> tuple[dict, Verification, np.ndarray] | None:
        """IPOPT's point read back and checked by the verifier (None: no point), with the point itself."""
        if result.x is None:
            return None
        assign(solver.order, result.x)
        solution = solver.nlp.read()
        grasp = Grasp(solution["palm_rotation"], solution["palm_position"], solution["joint_angles"])
        return solution, verify(grasp, self.grasping, self.obj, self.task, self.settings), result.x

    def record(self, solution: dict, check: Verification) -> dict:
        """The columns of a solved start: Q, the grasp, the verifier's figures, and (where configured) the
        physics check and the surrogate's error at the contacts."""
        from grasptask.synthesis.spline import evaluate  # deferred: CasADi, in the workers

        row: dict[str, Any] = {"Q": float(solution["Q"])}
        grasp = Grasp(solution["palm_rotation"], solution["palm_position"], solution["joint_angles"])
        row.update(grasp_columns(grasp, self.joint_names, self.fingers, solution["contacts"], solution["normals"]))
        row.update(check.record(self.fingers))
        if self.physics is not None and check.ok:  # the second judge, on what the first accepted
            row.update(self.physics.hold(self.grasping, grasp, self.task).record())
        if self.surrogate is not None:  # the surrogate's distance at each contact minus the mesh's own
            seen = evaluate(self.surrogate, solution["contacts"])
            for name, value, truth in zip(self.fingers, seen, check.contact_distance_m, strict=True):
                row[f"surrogate_error_m_{name}"] = float(value - truth)
        return row
