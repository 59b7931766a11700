"""A worker's solver context: the model built once from a :class:`Job`, then re-solved from each start's
initial point, every solution checked by the independent verifier, and the result row of one start."""

from __future__ import annotations

import time
import traceback
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from grasptask.records import solutions as schema
from grasptask.synthesis.config import SolverConfig
from grasptask.synthesis.feedback import Limits, tightened
from grasptask.synthesis.starts import Start

if TYPE_CHECKING:  # the solver stack loads in the workers, not where a Job is made
    from grasptask.grasp.settings import GraspSettings
    from grasptask.hand.model import Hand
    from grasptask.objects.surface import ImplicitObject
    from grasptask.synthesis.backends import Backend, Bounds, SolveResult
    from grasptask.synthesis.model import GraspNLP
    from grasptask.task.model import TaskModel
    from grasptask.verifier.verify import Verification


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
    #: --unit, --mass and --task-frame for the object, as (field, value) pairs (grasptask.objects.load_object)
    object_overrides: tuple[tuple[str, Any], ...] = ()


@dataclass
class Solver:
    """One NLP and the IPOPT backend built for it, with the NL file's variable order, the positions of the
    limits that the verifier's feedback tightens and those of the held turn's reference (None: not held)."""

    nlp: GraspNLP
    order: list
    backend: Backend
    limit_positions: tuple[np.ndarray, np.ndarray]
    held_positions: tuple[np.ndarray, np.ndarray] | None = None

    def bounds(self, limits: Limits) -> Bounds:
        """The NLP's bounds with ``limits`` in place of the activation cap and the pads' angle bounds."""
        base = self.backend.nlp.bounds
        columns, rows = self.limit_positions
        ubx, lbg = base.ubx.copy(), base.lbg.copy()
        ubx[columns] = limits.activation_cap
        lbg[rows] = np.cos(np.radians(limits.pad_angle_deg))
        return replace(base, ubx=ubx, lbg=lbg)

    def solve(self, x0: np.ndarray, limits: Limits | None = None) -> SolveResult:
        """IPOPT from ``x0`` within ``limits`` (None: the model's own). A held turn is held at ``x0``'s palm
        pose: its reference variables are set to it and pinned there by their bounds."""
        bounds = self.backend.nlp.bounds if limits is None else self.bounds(limits)
        if self.held_positions is not None:
            reference, palm = self.held_positions
            x0 = x0.copy()
            x0[reference] = x0[palm]
            lbx, ubx = bounds.lbx.copy(), bounds.ubx.copy()
            lbx[reference] = ubx[reference] = x0[palm]
            bounds = replace(bounds, lbx=lbx, ubx=ubx)
        return self.backend.solve(x0, bounds)


def build_solver(
    hand: Hand,
    obj: ImplicitObject,
    task: TaskModel,
    settings: GraspSettings,
    job: Job,
    torque_axes: int | None = None,
    max_iter: int | None = None,
) -> Solver:
    """The NLP for ``job`` written, imported into the backend and compiled for initialisation; ``max_iter``
    caps IPOPT's iterations below the solver config's."""
    from grasptask.synthesis.backends import BACKENDS, write_nl_rows
    from grasptask.synthesis.model import build_model

    config = job.solver
    held = held_axis(obj, task, config.hold_axis_rotation)
    nlp = build_model(hand, obj, task, settings, config.search_bounds, config.regularisation, torque_axes, held)
    text, order, rows = write_nl_rows(nlp.model)
    nlp.compile()  # now, so that its one-off cost is not counted in the first start's seconds
    options = config.ipopt if max_iter is None else {**config.ipopt, "max_iter": max_iter}
    backend = BACKENDS[job.backend](text, options, nlp.surrogate_spec(order, rows))
    return Solver(nlp, order, backend, nlp.limit_positions(order, rows), nlp.held_positions(order))


def held_axis(obj: ImplicitObject, task: TaskModel, tolerance: float | None) -> tuple[np.ndarray, np.ndarray] | None:
    """The object's axis of revolution when the grasp's turn about it is to be held: the object has one and the
    task is at most ``tolerance`` asymmetric about it (None: never held)."""
    from grasptask.task.symmetry import axis_asymmetry

    axis = obj.revolution_axis()
    if tolerance is None or axis is None or axis_asymmetry(task.weights, task.axes, *axis) > tolerance:
        return None
    return axis


class SolverContext:
    """A worker's models and solvers, built once; ``size`` is the variable and constraint count of the model a
    start is solved with first.

    With the solver config's ``torque_axes``, a start is first solved with eq. 10 for the task's longest axes
    only, a smaller model whose iterations cost less. A grasp the verifier then rejects on its torque check, which
    covers all six axes, is solved again from itself with the whole model. With ``geometric_iterations``
    (``held_geometric_iterations`` where the turn about the object's axis is held), a start's first iterations
    are made on the model without eq. 10 at all: they move the grasp most, and there they cost half. Objects
    whose surface the NLP sees through a surrogate (meshes, point clouds) skip that phase."""

    def __init__(self, job: Job):
        from grasptask.grasp.settings import GraspSettings, load_grasp_settings
        from grasptask.hand import load_hand
        from grasptask.objects import load_object
        from grasptask.synthesis.placement import Anchors
        from grasptask.synthesis.spline import distance_function
        from grasptask.task.model import load_task_models

        self.job = job
        self.hand = load_hand(job.hand_path)
        if job.fingers:
            self.hand = self.hand.with_grasping(job.fingers)
        self.obj = load_object(job.object_path, **dict(job.object_overrides))
        self.task = load_task_models(job.tasks_path)[job.task]
        self.settings = load_grasp_settings(job.settings_path) if job.settings_path else GraspSettings()
        parts = (self.hand, self.obj, self.task, self.settings, job)
        self.whole = build_solver(*parts)
        axes = job.solver.torque_axes
        self.first = build_solver(*parts, axes) if axes is not None and axes < len(self.task.weights) else self.whole
        self._carried = _positions(self.first, self.whole)
        # formula objects only: on meshes the phase lost verified starts and added a third surrogate-laden build
        held = self.first.held_positions is not None
        warmup = job.solver.phase_iterations(held) if self.first.nlp.surrogate is None else 0
        self.geometric = build_solver(*parts, 0, warmup) if warmup else None
        self._geometric = None if self.geometric is None else _positions(self.first, self.geometric)
        # the whole model's starting point where the first model has no variable: eq. 10's initial forces and
        # activations for the other axes, which depend on no pose
        self.whole.nlp.initialise_forces()
        self._whole_initial = _values(self.whole.order)
        self.nlp = self.first.nlp
        self.size = {**self.nlp.size(), "geometric_iterations": warmup}
        self.nominal = Limits(
            self.settings.activation_cap(self.nlp.hand.capability.kind) - self.settings.activation_margin,
            np.full(len(self.nlp.hand.fingers), self.settings.pad_angle_max_deg),
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
        """One start: solved from the solver config's first posture (mid-range joints are Section 7.3's) and,
        while the verifier rejects the result, again from each of its retry postures. The row is the last
        attempt's; its seconds, iterations, placement seconds and feedback rounds are those of every attempt
        together, and ``first_attempt_*`` say how the first did."""
        if self.approach is not None:  # the start's palm normal is the hand's approach direction
            start = replace(start, palm_rotation=start.palm_rotation @ self.approach.T)
        postures = [self.nlp.hand.posture(f) for f in self.job.solver.postures]
        spent = {"seconds": 0.0, "iterations": 0, "placement_seconds": 0.0, "feedback_rounds": 0, "all_axes_solves": 0}
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
        """Placement, IPOPT and the verifier from one posture; the whole model's solve when the first model left
        out an axis the grasp cannot hold; the verifier's feedback rounds."""
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
        solver = self.first
        x0 = _values(solver.order)
        seconds, iterations, rounds, whole = placed, 0, 0, 0
        if self.geometric is not None:  # the first iterations without eq. 10, carried into the first model
            phase = self.geometric.solve(x0[self._geometric])
            seconds, iterations = seconds + phase.seconds, phase.iterations
            if phase.x is not None and phase.status in ("optimal", "acceptable", "max-iter"):
                x0[self._geometric] = phase.x
        result = solver.solve(x0)
        seconds, iterations = seconds + result.seconds, iterations + result.iterations
        judged = self._judge(solver, result)
        if solver.nlp is not self.whole.nlp and _solved_but(result, judged, "torque_feasibility"):
            assert judged is not None
            again = self.whole.solve(self._in_whole(judged[2]))
            seconds, iterations, whole = seconds + again.seconds, iterations + again.iterations, 1
            retried = self._judge(self.whole, again)
            if retried is None:  # IPOPT left no point: the first model's solution stands
                _assign(solver.order, judged[2])
            else:
                solver, result, judged = self.whole, again, retried
        limits = self.nominal
        while rounds < self.job.solver.feedback_rounds and _solved_but(result, judged):
            assert judged is not None
            check = judged[1]
            cap = self.nominal.activation_cap
            tighter = tightened(limits, cap, check.failures, check.torque_effort, check.pad_angle_deg)
            if tighter is None:
                break
            limits, rounds = tighter, rounds + 1
            again = solver.solve(_values(solver.order), limits)
            seconds, iterations = seconds + again.seconds, iterations + again.iterations
            retried = self._judge(solver, again)
            if retried is None:  # IPOPT left no point: the last solution stands
                _assign(solver.order, judged[2])
                break
            result, judged = again, retried
        # a start's seconds are all it took to solve it: placement (or initialisation), IPOPT and its re-solves
        row.update(
            status=result.status,
            iterations=iterations,
            seconds=seconds,
            message=result.message,
            feedback_rounds=rounds,
            all_axes_solves=whole,
        )
        if judged is None:
            return {**row, "Q": float("nan"), "verified": False}
        return {**row, **self._record(*judged[:2])}

    def _judge(self, solver: Solver, result: SolveResult) -> tuple[dict, Verification, np.ndarray] | None:
        """IPOPT's point read back and checked by the verifier (None: no point), with the point itself."""
        from grasptask.verifier.verify import Grasp, verify

        if result.x is None:
            return None
        _assign(solver.order, result.x)
        solution = solver.nlp.read()
        grasp = Grasp(solution["palm_rotation"], solution["palm_position"], solution["joint_angles"])
        return solution, verify(grasp, self.hand, self.obj, self.task, self.settings), result.x

    def _in_whole(self, x: np.ndarray) -> np.ndarray:
        """The first model's point as a starting point of the whole model: the shared variables carried over,
        the other axes' eq. 10 forces and activations at their initial values."""
        x0 = self._whole_initial.copy()
        carried = self._carried >= 0
        x0[carried] = x[self._carried[carried]]
        return x0

    def _record(self, solution: dict, check: Verification) -> dict:
        """The columns of a solved start: Q, the grasp, the verifier's figures, and (where configured) the
        physics check and the surrogate's error at the contacts."""
        from grasptask.records.solutions import grasp_columns
        from grasptask.synthesis.spline import evaluate
        from grasptask.verifier.verify import Grasp

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


def _solved_but(result: SolveResult, judged: tuple | None, failure: str | None = None) -> bool:
    """IPOPT solved the NLP and the verifier rejected the grasp (on ``failure`` among others, when given)."""
    if judged is None or result.status not in ("optimal", "acceptable") or judged[1].ok:
        return False
    return failure is None or failure in judged[1].failures


def _positions(source: Solver, target: Solver) -> np.ndarray:
    """Where each of ``target``'s variables is in ``source``'s order (-1: ``source`` has no such variable)."""
    position = {v.name: k for k, v in enumerate(source.order)}
    return np.array([position.get(v.name, -1) for v in target.order], dtype=int)


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
