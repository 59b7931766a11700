"""``grasptask physics``: every solved grasp of a solutions table held in MuJoCo against its task's wrenches
(:mod:`grasptask.physics`), beside the analytic verifier's verdict, as a table and a summary with the 2x2
agreement of the two judges."""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import pandas as pd

from grasptask.errors import BadInputError
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.io.child_processes import die_with_parent
from grasptask.io.config_schema import MAX_WORKERS
from grasptask.io.locking import check_writable, folder_lock
from grasptask.io.tables import read_table
from grasptask.paths import DEFAULT_PHYSICS_CONFIG, as_paths
from grasptask.physics.judge import Holding, Judge, Traced, traced_rows, write_physics_results
from grasptask.physics.physics_settings import CONTROLLERS, Controller, load_physics_settings
from grasptask.progress import Progress, preparing, timed_stage
from grasptask.records.sweeps import Sweep, SweepInputs


@dataclass(frozen=True, kw_only=True)
class PhysicsOptions(SweepInputs):
    """What one check is made from (the sweep, :class:`SweepInputs`; its physics settings) and where it goes."""

    out: Path
    #: simulation processes
    workers: int = 1
    physics_config: Path = DEFAULT_PHYSICS_CONFIG
    #: None: the physics config's controller
    controller: Controller | None = None
    #: the hand's actuators and the friction coefficient this many times the models' (the judge's own checks)
    strength: float = 1.0
    friction_scale: float = 1.0

    def __post_init__(self) -> None:
        as_paths(self, "solutions", "out", "physics_config")
        if not 1 <= self.workers <= MAX_WORKERS:
            raise BadInputError("physics", f"--workers must be from 1 to {MAX_WORKERS}, got {self.workers}")
        if self.strength <= 0 or self.friction_scale <= 0:
            raise BadInputError("physics", "--strength and --friction-scale must be positive")
        if self.controller is not None and self.controller not in CONTROLLERS:
            raise BadInputError("physics", f"unknown controller '{self.controller}' (known: {', '.join(CONTROLLERS)})")


@dataclass(frozen=True)
class PhysicsSummary:
    """The check's table (one row per start) and summary (pass rates, the judges' 2x2 agreement), and where
    they were written."""

    out: Path
    table: pd.DataFrame
    summary: dict[str, Any]


def _judge_for(options: PhysicsOptions, sweep: Sweep) -> Judge:
    """The judge of ``sweep``: its grasps, task model, object, settings, strength and friction; the first grasp's
    scene built, so that a hand file MuJoCo cannot compile is one line before any worker starts."""
    settings = load_physics_settings(options.physics_config)
    settings = replace(settings, controller=options.controller or settings.controller)
    friction = sweep.settings.friction_coefficient * options.friction_scale
    torsion = sweep.settings.torsional_friction_m
    holding = Holding.of(sweep.load_object(), friction, settings, options.strength, torsion)
    judge = Judge(sweep.solved, sweep.task_model, holding)
    judge.check_scene()
    return judge


_worker: Judge | None = None


def _start_worker(judge: Judge) -> None:
    global _worker

    die_with_parent()  # a physics run killed outright left its pool workers running for minutes
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    _worker = judge


def _check_in_worker(index: int) -> dict[str, Any]:
    assert _worker is not None
    return _worker.check(index)


def _trace_in_worker(plan: tuple[int, bool]) -> Traced:
    """A row to trace, and whether to film it (:func:`traced_rows`)."""
    assert _worker is not None
    return _worker.trace(*plan)


@timed_stage
def run_physics(options: PhysicsOptions) -> PhysicsSummary:
    """Check every solved grasp of ``options.solutions``; writes ``out/physics.parquet`` (one row per start),
    ``out/physics_summary.json`` and ``out/physics_trace.parquet`` (the best verified grasp's motion over the
    protocol)."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # inherited by the simulation processes
    out = options.out
    sweep = options.open_sweep()
    with preparing(f"physics {sweep.task}: preparing the object and the first scene ..."):
        judge = _judge_for(options, sweep)  # every input checked here, before any work
    # --out held, and known to be writable, from the start: a second run into it is refused, not overwritten
    with folder_lock(out, f"physics {sweep.task}"):
        check_writable(out)
        return _judge_all(judge, options, sweep)


def _judge_all(judge: Judge, options: PhysicsOptions, sweep: Sweep) -> PhysicsSummary:
    indices = list(range(len(judge.solved.rows)))
    counts = {"held": 0, "dropped": 0}
    workers = options.workers
    optima_file = sweep.solutions.parent / "optima.parquet"
    traced = traced_rows(judge, read_table(optima_file, ("start_id", "Q")) if optima_file.is_file() else None)
    with ProcessPoolExecutor(workers, initializer=_start_worker, initargs=(judge,)) if workers > 1 else (
        nullcontext()
    ) as pool:  # fmt: skip
        with Progress(len(indices), f"physics {sweep.task}", "grasps") as shown:
            results = pool.map(_check_in_worker, indices) if pool is not None else map(judge.check, indices)
            records = []
            for record in results:
                records.append(record)
                if "physics_passed" in record:
                    counts["held" if record["physics_passed"] else "dropped"] += 1
                shown.update(1, **counts)
        with Progress(len(traced), f"physics {sweep.task}: the optima step by step", "grasps") as shown:
            mapped = pool.map(_trace_in_worker, traced) if pool is not None else (judge.trace(*plan) for plan in traced)
            traces = []
            for done in mapped:
                traces.append(done)
                shown.update(1)
    table = pd.DataFrame(records)
    used = sweep.files
    files = [sweep.solutions, sweep.tasks, used.hand, used.object, used.grasp_config, options.physics_config]
    parameters = {
        "task": sweep.task,
        "controller": judge.holding.settings.controller,
        "strength": options.strength,
        "friction_scale": options.friction_scale,
    }
    provenance = Provenance.of("physics", parameters, files)
    with StagedOutput(options.out, provenance) as staged:
        result = write_physics_results(staged, table, judge.task.name, judge.holding.settings, traces, judge=judge)
    return PhysicsSummary(options.out, table, result)
