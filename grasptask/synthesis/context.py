"""A worker's solver context: the models built once from a :class:`Job`, and the route of one start from each
of its postures: placement, the geometric phase, IPOPT, the whole model for a torque rejection and the
verifier's feedback rounds, until a grasp is verified. What is built is in :mod:`grasptask.synthesis.solvers`,
what is recorded of each point in :mod:`grasptask.synthesis.judging`."""

from __future__ import annotations

import time
import traceback
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand import load_hand
from grasptask.hand.hand_model import Hand
from grasptask.io.artifacts import config_hash
from grasptask.objects import load_object
from grasptask.objects.surface import ImplicitObject
from grasptask.physics.physics_settings import PhysicsSettings
from grasptask.records import solutions as schema
from grasptask.synthesis.feedback import Limits, tightened
from grasptask.synthesis.judging import Judges
from grasptask.synthesis.near_spheres import (
    NearSpheres,
    carrying,
    chosen,
    clearances,
    penetrating,
    sphere_count,
    within,
)
from grasptask.synthesis.solver_config import SolverConfig
from grasptask.synthesis.solvers import assign, build_models, values
from grasptask.synthesis.starts import Start
from grasptask.task.task_model import TaskModel, load_task_models

if TYPE_CHECKING:  # the solver stack loads in the workers, not where a Job is made
    from grasptask.synthesis.backends import SolveResult
    from grasptask.synthesis.batch_search import BatchEnd, BatchSearch
    from grasptask.synthesis.force_problem import ForceProblem
    from grasptask.synthesis.nlp import GraspNLP
    from grasptask.synthesis.polish import Polish
    from grasptask.synthesis.search import SearchBatch, SearchEnd


#: how many times a polish is done again with the left-out spheres its grasp sank into
WIDENINGS = 2
#: the polish models of other sphere sets a worker keeps (each built in seconds)
KEPT_CONTEXTS = 4


@dataclass(frozen=True)
class Job:
    """Everything a worker needs to build its models: the hand (its grasping fingers chosen), the object and the
    task model, loaded once where the sweep is prepared and handed to the workers by value (a pickle of 1-8 MB,
    where a published hand's sphere cover takes seconds to fit again); the settings, read and checked once."""

    hand: Hand
    obj: ImplicitObject
    task: TaskModel
    backend: str = "casadi"
    solver: SolverConfig = SolverConfig()
    #: the grasp settings, always given: a forgotten argument must not silently mean the defaults
    settings: GraspSettings = field(kw_only=True)
    #: each verified grasp is also held in MuJoCo with these (grasptask.physics); None: not
    physics: PhysicsSettings | None = None
    #: what the job was made from (a hash): a Dask worker keeps one context per job it was given
    key: str = field(kw_only=True)
    #: "paper" or "search": a search's worker builds its NLP without collision spheres on a hand of many,
    #: each polish's with those near its grasp (:mod:`grasptask.synthesis.near_spheres`)
    route: str = field(default="paper", kw_only=True)

    @classmethod
    def from_files(
        cls,
        hand_path: str | Path,
        object_path: str | Path,
        tasks_path: str | Path,
        task: str,
        *,
        fingers: tuple[str, ...] | list[str] | None = None,
        object_overrides: dict[str, Any] | None = None,
        **rest: Any,
    ) -> Job:
        """The job of the files a sweep names (``object_overrides``: --unit, --mass, --task-frame)."""
        hand = load_hand(hand_path)
        hand = hand.with_grasping(list(fingers)) if fingers else hand
        obj = load_object(object_path, say=lambda _: None, **(object_overrides or {}))
        named = [str(hand_path), str(object_path), str(tasks_path), task, list(fingers or []), object_overrides]
        key = rest.pop("key", None) or config_hash(named)
        return cls(hand, obj, load_task_models(tasks_path)[task], key=key, **rest)


class SolverContext:
    """A worker's models, judges and starting geometry, built once from a :class:`Job`; :meth:`solve` runs one
    start. ``size`` is the variable and constraint count of the model a start is solved with first.

    With the solver config's ``torque_axes``, a start is first solved with eq. 10 for the task's longest axes
    only; a grasp the verifier then rejects on its torque check, which covers all six axes, is solved again from
    itself with the whole model. With ``geometric_iterations`` (``held_geometric_iterations`` where the turn
    about the object's axis is held), a start's first iterations are made on the model without eq. 10: they move
    the grasp most, and there they cost half. Meshes and point clouds skip that phase."""

    def __init__(self, job: Job, carried: NearSpheres | None = None, judges: Judges | None = None):
        """``carried``: the collision spheres the models carry (None: every one; on the search route, a hand of
        more than the search config's ``polish_all_spheres_max`` none, each polish then the spheres near its
        grasp); ``judges``: another context's, shared."""
        # the solver stack (Pyomo, CasADi) and the loaders, in the worker that builds the models
        from grasptask.synthesis.placement import Anchors

        self.job = job
        self.hand, self.obj, self.task = job.hand, job.obj, job.task
        self.settings = job.settings
        count = sphere_count(self.hand)
        if carried is None and job.route == "search" and count > job.solver.search.polish_all_spheres_max:
            carried = chosen(self.hand, np.zeros(count, dtype=bool))  # none
        self.carried = carried
        #: the polish contexts of other sphere sets, the last few kept (:meth:`_carrying`)
        self._near_contexts: dict[NearSpheres, SolverContext] = {}
        built = self.hand if carried is None else carrying(self.hand, carried)
        self.models = build_models(built, self.obj, self.task, self.settings, job.solver, job.backend)
        self.nlp = self.models.first.nlp
        self.size = self.models.size
        if carried is not None:
            self.size = {**self.size, "spheres": carried.count, "hand_spheres": count}
        self.judges = judges or Judges(self.hand, self.obj, self.task, self.settings, self.nlp, job.physics)
        self.nominal = Limits(
            self.settings.activation_cap(self.nlp.hand.capability.kind) - self.settings.activation_margin,
            self.nlp.hand.pad_angle_limits(self.settings.pad_angle_max_deg),
        )
        self.bounds = self.obj.bounds()
        self.anchors = Anchors(self.bounds, self.nlp.surrogate.grid if self.nlp.surrogate is not None else None)
        self.approach = self.hand.approach

    @cached_property
    def batch_search(self) -> BatchSearch:
        """The search of route search, traced on first use: the paper's route never needs it."""
        from grasptask.synthesis.batch_geometry import StrengthArrays
        from grasptask.synthesis.batch_search import BatchSearch

        hand, settings = self.hand.grasping_hand(), self.settings  # every sphere a penalty, near or not
        axes = sorted({a for a, _, _, _ in self.nlp.model.lam.keys()})
        lever = 0.5 * float(np.linalg.norm(np.diff(self.bounds, axis=0)))
        strength = StrengthArrays.of(hand.capability, axes, settings, lever)
        return BatchSearch(
            hand, self.obj, self.task, strength, settings.pad_angle_max_deg, settings.rolling_contacts,
            self.job.solver.search,
        )  # fmt: skip

    @cached_property
    def force_problem(self) -> ForceProblem:
        from grasptask.synthesis.force_problem import ForceProblem

        hand, solver = self.nlp.hand, self.job.solver
        joints = tuple(f.n_joints for f in hand.fingers.values())
        return ForceProblem(
            hand.capability,
            joints,
            self.task,
            self.settings,
            solver.force_slack_weight,
            solver.search_bounds,
            solver.regularisation,
            soft=len({j for j, _ in self.nlp.twists}),
        )

    def _facing(self, start: Start) -> Start:
        """A start from afar with its palm normal turned to the hand's approach direction (warm starts are not)."""
        if self.approach is not None and start.joints is None:
            return replace(start, palm_rotation=start.palm_rotation @ self.approach.T)
        return start

    def search(self, task: SearchBatch) -> list[SearchEnd]:
        """A batch of starts searched together from their placed poses (the solver config's first posture); each
        end point that converged judged by the force problem at the NLP's geometry there."""
        from grasptask.synthesis.search import EndGrasp, SearchEnd

        began = time.perf_counter()
        joints = self.nlp.hand.posture(self.job.solver.postures[0])
        poses = []
        for start in task.starts:
            self._place(self.nlp, self._facing(start), joints)
            read = self.nlp.read()
            poses.append((read["palm_rotation"], read["palm_position"], read["joint_angles"]))
        rotation, position, angles = (np.array(column) for column in zip(*poses, strict=True))
        ended = self.batch_search.run(rotation, position, angles)
        converged, iterations = ended.converged(), self.job.solver.search.iterations
        share = (time.perf_counter() - began) / len(task.starts)
        out = []
        for k, start in enumerate(task.starts):
            if not converged[k]:
                why = "not finite" if not ended.finite[k] else _shortfall(ended, k)
                status = "search-nan" if not ended.finite[k] else "search-far"
                out.append(SearchEnd(start.start_id, status, iterations, share, 1, why))
                continue
            spent = time.perf_counter()
            self.nlp.initialise(ended.palm_rotation[k], ended.palm_position[k], ended.joint_angles[k])
            read = self.nlp.read()
            grasp = EndGrasp(read["palm_rotation"], read["palm_position"], read["joint_angles"], read["contacts"],
                             read["normals"])  # fmt: skip
            forces = self.force_problem.solve(self.nlp.geometry())
            seconds = share + time.perf_counter() - spent
            out.append(SearchEnd(start.start_id, "converged", iterations, seconds, 1, "", grasp, forces))
        return out

    def polish(self, task: Polish) -> dict:
        """A basin's end point solved by the paper's NLP from it, forces and all (:mod:`.polish`). A context whose
        models carry only some spheres polishes with those within the search config's
        ``polish_sphere_distance_m`` of the object at the end point, and again with any left-out sphere the
        polished grasp sinks into (at most :data:`WIDENINGS` times)."""
        if self.carried is None:
            return self.solve(task.warm_start(), task.end)
        grasp = task.end.grasp
        assert grasp is not None, "a polish of a search that did not converge"
        reach = self.job.solver.search.polish_sphere_distance_m
        at = clearances(self.hand, self.obj, grasp.palm_rotation, grasp.palm_position, grasp.joint_angles)
        near, spent = self.carried.widened(within(self.hand, at, reach)), {"seconds": 0.0, "iterations": 0}
        for widening in range(WIDENINGS + 1):
            context = self._carrying(near)
            row = context.solve(task.warm_start(), task.end)
            for key in spent:  # a widened polish's seconds and iterations are those of all its solves
                spent[key] += row[key]
            size = context.size
            row.update(spent, polish_spheres=near.count, polish_widenings=widening,
                       polish_variables=size["variables"], polish_constraints=size["constraints"])  # fmt: skip
            if not np.isfinite(row.get("Q", np.nan)):
                return row
            g = schema.grasp_from_row(row, self.judges.joint_names)
            after = clearances(self.hand, self.obj, g.palm_rotation, g.palm_position, g.joint_angles)
            deep = penetrating(self.hand, after, self.hand.compliance_m)
            if near.covers(deep):
                return row
            near = near.widened(deep)
        return row

    def _carrying(self, near: NearSpheres) -> SolverContext:
        """The context whose models carry the spheres ``near`` (built once; the last few kept), judged by this
        context's judges: the verifier and physics check every sphere."""
        if near == self.carried:
            return self
        cache = self._near_contexts
        if near not in cache:
            if len(cache) >= KEPT_CONTEXTS:
                cache.pop(next(iter(cache)))
            cache[near] = SolverContext(self.job, carried=near, judges=self.judges)
        return cache[near]

    def _polish_point(self, end: SearchEnd) -> np.ndarray:
        """The first model's initial point at a search's end point (the model initialised there already): the
        force problem's forces at that geometry, every defined variable from the pose."""
        assert end.forces is not None and end.grasp is not None, "a polish of a search that did not converge"
        self.nlp.set_forces(end.forces)
        return values(self.models.first.order)

    def _place(self, nlp: GraspNLP, start: Start, joints: np.ndarray) -> float | None:
        """``nlp`` initialised at ``start`` in the posture ``joints``: placed at the object (the solver config's
        ``placement``; how far the palm backed away, m) or where the start is (None)."""
        from grasptask.synthesis.placement import place  # Pyomo, loaded in the workers

        if self.job.solver.placement:
            return place(nlp, start, self.anchors, joints)
        nlp.initialise(start.palm_rotation, start.palm_position, joints)
        return None

    def run(self, task: Start | SearchBatch | Polish) -> dict | list[SearchEnd]:
        """A worker's job: a start of the paper's route, a batch's search, or a polish."""
        from grasptask.synthesis.polish import Polish
        from grasptask.synthesis.search import SearchBatch

        if isinstance(task, SearchBatch):
            return self.search(task)
        if isinstance(task, Polish):
            return self.polish(task)
        return self.solve(task)

    def solve(self, start: Start, end: SearchEnd | None = None) -> dict:
        """One start: solved from the solver config's first posture (mid-range joints are Section 7.3's) and,
        while the verifier rejects the result, again from each of its retry postures. The row is the last
        attempt's; its seconds, iterations, placement seconds and feedback rounds are those of every attempt
        together, and ``first_attempt_*`` say how the first did. ``end``: a polish's, whose first attempt starts
        from the search's whole point there (``start`` is its grasp)."""
        warm = start.joints is not None  # an optimum's palm turned with the hand already
        start = self._facing(start)
        postures = [self.nlp.hand.posture(f) for f in self.job.solver.postures]
        if start.joints is not None:  # a warm start's first attempt is its own grasp, then the retries as any
            postures[0] = np.asarray(start.joints, dtype=float)
        spent = {"seconds": 0.0, "iterations": 0, "placement_seconds": 0.0, "feedback_rounds": 0, "all_axes_solves": 0}
        for attempt, joints in enumerate(postures, 1):
            row = self._attempt(start, joints, as_it_is=warm and attempt == 1, end=end if attempt == 1 else None)
            if attempt == 1:
                first = {"first_attempt_seconds": row["seconds"], "first_attempt_verified": row["verified"]}
            for key in spent:
                spent[key] += row[key]
            if row["verified"]:
                break
        return {**row, **spent, **first, "attempts": attempt}

    def _initial_point(
        self,
        start: Start,
        joints: np.ndarray,
        row: dict[str, Any],
        as_it_is: bool = False,
        end: SearchEnd | None = None,
    ) -> tuple[np.ndarray, float, int]:
        """The first model's initial point from ``start`` in the posture ``joints``: placed (or initialised),
        then moved by the geometric phase where there is one; its seconds and iterations. The placement's
        figures go into ``row``. ``as_it_is``: a warm start's grasp, initialised where it is and not moved;
        with a polish's ``end``, the search's point there (:meth:`_polish_point`), then moved by the geometric
        phase as a placed start is (of the same end points, polishes took half the time so: the paper's hand
        10.0 s against 19.3, the Allegro 15.4 against 30.1, every one verified)."""
        models = self.models
        began = time.perf_counter()
        if as_it_is:
            self.nlp.initialise(start.palm_rotation, start.palm_position, joints)
            x0 = values(models.first.order) if end is None else self._polish_point(end)
            row["placement_seconds"] = seconds = time.perf_counter() - began
            return (x0, seconds, 0) if end is None else self._geometric_phase(x0, seconds)
        backoff = self._place(self.nlp, start, joints)
        if backoff is not None:
            row["placement_backoff_m"] = backoff
        row["placement_seconds"] = seconds = time.perf_counter() - began
        return self._geometric_phase(values(models.first.order), seconds)

    def _geometric_phase(self, x0: np.ndarray, seconds: float) -> tuple[np.ndarray, float, int]:
        """``x0`` moved by the first iterations without eq. 10 where the solver config has them, carried into the
        first model; ``seconds`` with the phase's, and its iterations."""
        models, iterations = self.models, 0
        if models.geometric is not None:
            phase = models.geometric.solve(x0[models.geometric_positions])
            seconds, iterations = seconds + phase.seconds, phase.iterations
            if phase.x is not None and phase.status in ("optimal", "acceptable", "max-iter"):
                x0[models.geometric_positions] = phase.x
        return x0, seconds, iterations

    def _attempt(self, start: Start, joints: np.ndarray, as_it_is: bool = False, end: SearchEnd | None = None) -> dict:
        """Placement, IPOPT and the verifier from one posture; the whole model's solve when the first model left
        out an axis the grasp cannot hold; the verifier's feedback rounds."""
        models = self.models
        row: dict[str, Any] = {
            "start_id": start.start_id,
            "orientation": start.orientation,
            "position": start.position_name,
        }
        solver = models.first
        x0, seconds, iterations = self._initial_point(start, joints, row, as_it_is, end)
        rounds, whole = 0, 0
        result = solver.solve(x0)
        seconds, iterations = seconds + result.seconds, iterations + result.iterations
        judged = self.judges.judge(solver, result)
        if solver.nlp is not models.whole.nlp and _solved_but(result, judged, "torque_feasibility"):
            assert judged is not None
            again = models.whole.solve(models.in_whole(judged[2]))
            seconds, iterations, whole = seconds + again.seconds, iterations + again.iterations, 1
            retried = self.judges.judge(models.whole, again)
            if retried is None:  # IPOPT left no point: the first model's solution stands
                assign(solver.order, judged[2])
            else:
                solver, result, judged = models.whole, again, retried
        limits = self.nominal
        while rounds < self.job.solver.feedback_rounds and _solved_but(result, judged):
            assert judged is not None
            check = judged[1]
            cap = self.nominal.activation_cap
            off_tip = np.nan_to_num(check.fingertip_gap_m, nan=-np.inf) > 0.0  # outside the real fingertip
            tighter = tightened(limits, cap, check.failures, check.torque_effort, check.pad_angle_deg, off_tip)
            if tighter is None:
                break
            limits, rounds = tighter, rounds + 1
            again = solver.solve(values(solver.order), limits)
            seconds, iterations = seconds + again.seconds, iterations + again.iterations
            retried = self.judges.judge(solver, again)
            if retried is None:  # IPOPT left no point: the last solution stands
                assign(solver.order, judged[2])
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
        return {**row, **self.judges.record(*judged[:2])}


def _solved_but(result: SolveResult, judged: tuple | None, failure: str | None = None) -> bool:
    """IPOPT solved the NLP and the verifier rejected the grasp (on ``failure`` among others, when given)."""
    if judged is None or result.status not in ("optimal", "acceptable") or judged[1].ok:
        return False
    return failure is None or failure in judged[1].failures


def _shortfall(ended: BatchEnd, k: int) -> str:
    """Why a search's end point is not grouped: how far from the surface, how deep, how far from facing it."""
    gap = float(np.abs(ended.gaps[k]).max())
    return (
        f"search ended {1e3 * gap:.2f} mm from the surface, a collision sphere {1e3 * float(ended.depth[k]):.2f} mm "
        f"deep, a pad {float(ended.facing[k]):.3f} short of facing it"
    )


def failed_row(start: Any, status: str, seconds: float, message: str) -> dict:
    return schema.failed_row(start.start_id, start.orientation, start.position_name, status, seconds, message)


def solve_guarded(context: SolverContext, start: Any) -> Any:
    """``context.run(start)`` (a start, a search or a polish), with any exception a recorded ``error`` row:
    never a crashed sweep."""
    began = time.perf_counter()
    try:
        return context.run(start)
    except Exception as exc:  # noqa: BLE001 - a failed start is a recorded status, never a crashed sweep
        return failed_row(start, "error", time.perf_counter() - began, f"{type(exc).__name__}: {exc}"[:300])


def build_failure(exc: BaseException) -> str:
    """The last line of a model build's traceback, for a one-line error."""
    return traceback.format_exception_only(type(exc), exc)[-1].strip()
