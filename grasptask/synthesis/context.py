"""A worker's solver context: the model built once from a :class:`Job`, then re-solved from each start's
initial point, every solution checked by the independent verifier, and the result row of one start."""

from __future__ import annotations

import os
import time
import traceback
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from grasptask.io import solutions as schema
from grasptask.synthesis.config import SolverConfig
from grasptask.synthesis.feedback import Limits, tightened
from grasptask.synthesis.starts import Start

if TYPE_CHECKING:  # the solver stack loads in the workers, not where a Job is made
    from grasptask.grasp.verify import Verification
    from grasptask.synthesis.backends import Bounds, SolveResult

# a test hook: a start whose id is listed here makes its worker exit abruptly (to exercise crash handling)
CRASH_ENV = "GRASPTASK_CRASH_STARTS"


@dataclass(frozen=True)
class Job:
    """Everything a worker needs to rebuild the model; plain paths and values, so it pickles."""

    hand_path: str
    object_path: str
    tasks_path: str
    task: str
    backend: str = "casadi"
    solver: SolverConfig = SolverConfig()
    settings_path: str = ""
    #: the grasping fingers, when not the hand file's own choice
    fingers: tuple[str, ...] | None = None
    #: a physics config: each verified grasp is also held in MuJoCo (grasptask.physics); "": not
    physics_path: str = ""


class SolverContext:
    """A worker's model and solver, built once; ``size`` is the model's variable and constraint count."""

    def __init__(self, job: Job):
        from grasptask.grasp.settings import GraspSettings, load_grasp_settings
        from grasptask.hand import load_hand
        from grasptask.objects import load_object
        from grasptask.synthesis.backends import BACKENDS, write_nl_rows
        from grasptask.synthesis.model import build_model
        from grasptask.synthesis.placement import Anchors
        from grasptask.synthesis.spline import distance_function
        from grasptask.task.model import load_task_models

        self.job = job
        self.hand = load_hand(job.hand_path)
        if job.fingers:
            self.hand = self.hand.with_grasping(job.fingers)
        self.obj = load_object(job.object_path)
        self.task = load_task_models(job.tasks_path)[job.task]
        self.settings = load_grasp_settings(job.settings_path) if job.settings_path else GraspSettings()
        self.nlp = build_model(
            self.hand, self.obj, self.task, self.settings, job.solver.bounds, job.solver.regularisation
        )
        self.size = self.nlp.size()
        text, self.order, rows = write_nl_rows(self.nlp.model)
        self.nlp.compile()  # now, so that its one-off cost is not counted in the first start's seconds
        self.backend = BACKENDS[job.backend](text, job.solver.ipopt, self.nlp.surrogate_spec(self.order, rows))
        self.limit_positions = self.nlp.limit_positions(self.order, rows)
        self.nominal = Limits(
            1.0 - self.settings.activation_margin, np.full(len(self.nlp.hand.fingers), self.settings.pad_angle_max_deg)
        )
        # what the NLP saw of a mesh's or point cloud's surface, to record its error at each contact
        self.surrogate = distance_function(self.nlp.surrogate.grid) if self.nlp.surrogate is not None else None
        self.bounds = self.obj.bounds()
        self.anchors = Anchors(self.bounds, self.nlp.surrogate.grid if self.nlp.surrogate is not None else None)
        self.approach = self.hand.approach
        self.fingers = list(self.nlp.hand.fingers)
        self.joint_names = self.nlp.hand.joint_names
        self.physics = None
        if job.physics_path:
            from grasptask.physics.scene import object_body
            from grasptask.physics.settings import load_physics_settings

            physics = load_physics_settings(job.physics_path)
            self.physics = (physics, object_body(self.obj, physics))

    def solve(self, start: Start) -> dict:
        """One start: solved from mid-range joints (Section 7.3) and, while the verifier rejects the result, again
        from each of the solver config's retry postures. The row is the last attempt's; its seconds, iterations,
        placement seconds and feedback rounds are those of every attempt together, and ``first_attempt_*`` say
        how the first did."""
        if str(start.start_id) in os.environ.get(CRASH_ENV, "").split(","):
            os._exit(13)
        if self.approach is not None:  # the start's palm normal is the hand's approach direction
            start = replace(start, palm_rotation=start.palm_rotation @ self.approach.T)
        hand = self.nlp.hand
        postures = [hand.mid_range()] + [hand.posture(f) for f in self.job.solver.retry_postures]
        spent = {"seconds": 0.0, "iterations": 0, "placement_seconds": 0.0, "feedback_rounds": 0}
        for attempt, joints in enumerate(postures, 1):
            row = self._attempt(start, joints)
            if attempt == 1:
                first = {"first_attempt_seconds": row["seconds"], "first_attempt_verified": row["verified"]}
            for key in spent:
                spent[key] += row[key]
            if row["verified"]:
                break
        return {**row, **spent, **first, "attempts": attempt}

    def _attempt(self, start: Start, joints: np.ndarray) -> dict:
        """Placement, IPOPT and the verifier from one posture, with the verifier's feedback rounds."""
        from grasptask.synthesis.placement import place

        row: dict[str, Any] = {
            "start_id": start.start_id,
            "orientation": start.orientation,
            "position": start.position_name,
        }
        began = time.perf_counter()
        if self.job.solver.placement:
            row["placement_backoff_m"] = place(self.nlp, start, self.anchors, joints)
        else:
            self.nlp.initialise(start.palm_rotation, start.palm_position, joints)
        row["placement_seconds"] = placed = time.perf_counter() - began
        result = self.backend.solve(_values(self.order))
        seconds, iterations, rounds = result.seconds + placed, result.iterations, 0
        judged = self._judge(result)
        limits = self.nominal
        while judged is not None and rounds < self.job.solver.feedback_rounds:
            check = judged[1]
            if result.status not in ("optimal", "acceptable") or check.ok:
                break
            cap = self.nominal.activation_cap
            tighter = tightened(limits, cap, check.failures, check.torque_effort, check.pad_angle_deg)
            if tighter is None:
                break
            limits, rounds = tighter, rounds + 1
            again = self.backend.solve(_values(self.order), self._bounds(limits))
            seconds, iterations = seconds + again.seconds, iterations + again.iterations
            retried = self._judge(again)
            if retried is None:  # IPOPT left no point: the last solution stands
                _assign(self.order, judged[2])
                break
            result, judged = again, retried
        # a start's seconds are all it took to solve it: placement (or initialisation), IPOPT and its re-solves
        row.update(
            status=result.status, iterations=iterations, seconds=seconds, message=result.message, feedback_rounds=rounds
        )
        if judged is None:
            return {**row, "Q": float("nan"), "verified": False}
        return {**row, **self._record(*judged[:2])}

    def _judge(self, result: SolveResult) -> tuple[dict, Verification, np.ndarray] | None:
        """IPOPT's point read back and checked by the verifier (None: no point), with the point itself."""
        from grasptask.grasp.verify import Grasp, verify

        if result.x is None:
            return None
        _assign(self.order, result.x)
        solution = self.nlp.read()
        grasp = Grasp(solution["palm_rotation"], solution["palm_position"], solution["joint_angles"])
        return solution, verify(grasp, self.hand, self.obj, self.task, self.settings), result.x

    def _bounds(self, limits: Limits) -> Bounds:
        """The NLP's bounds with ``limits`` in place of the activation cap and the pads' angle bounds."""
        base = self.backend.nlp.bounds
        columns, rows = self.limit_positions
        ubx, lbg = base.ubx.copy(), base.lbg.copy()
        ubx[columns] = limits.activation_cap
        lbg[rows] = np.cos(np.radians(limits.pad_angle_deg))
        return replace(base, ubx=ubx, lbg=lbg)

    def _record(self, solution: dict, check: Verification) -> dict:
        """The columns of a solved start: Q, the grasp, the verifier's figures, and (where configured) the
        physics check and the surrogate's error at the contacts."""
        from grasptask.grasp.verify import Grasp
        from grasptask.io.solutions import grasp_columns
        from grasptask.synthesis.spline import evaluate

        row: dict[str, Any] = {"Q": float(solution["Q"])}
        grasp = Grasp(solution["palm_rotation"], solution["palm_position"], solution["joint_angles"])
        row.update(grasp_columns(grasp, self.joint_names, self.fingers, solution["contacts"], solution["normals"]))
        row.update(check.record(self.fingers))
        if self.physics is not None and check.ok:  # the second judge, on what the first accepted
            from grasptask.physics.protocol import hold_grasp

            physics, body = self.physics
            friction = self.settings.friction_coefficient
            row.update(hold_grasp(self.nlp.hand, self.obj, body, grasp, friction, self.task, physics).record())
        if self.surrogate is not None:  # the surrogate's distance at each contact minus the mesh's own
            seen = evaluate(self.surrogate, solution["contacts"])
            for name, value, truth in zip(self.fingers, seen, check.contact_distance_m, strict=True):
                row[f"surrogate_error_m_{name}"] = float(value - truth)
        return row


def _values(order: list) -> np.ndarray:
    return np.array([v.value if v.value is not None else 0.0 for v in order], dtype=float)


def _assign(order: list, x: np.ndarray) -> None:
    for var, value in zip(order, x, strict=True):
        var.set_value(float(value), skip_validation=True)


def failed_row(start: Start, status: str, seconds: float, message: str) -> dict:
    return schema.failed_row(start.start_id, start.orientation, start.position_name, status, seconds, message)


def solve_guarded(context: SolverContext, start: Start) -> dict:
    """``context.solve(start)``, with any exception a recorded ``error`` row: never a crashed sweep."""
    began = time.perf_counter()
    try:
        return context.solve(start)
    except Exception as exc:  # noqa: BLE001 - a failed start is a recorded status, never a crashed sweep
        return failed_row(start, "error", time.perf_counter() - began, f"{type(exc).__name__}: {exc}"[:300])


def build_failure(exc: BaseException) -> str:
    """The last line of a model build's traceback, for a one-line error."""
    return traceback.format_exception_only(type(exc), exc)[-1].strip()
