"""``grasptask physics``: every solved grasp of a solutions table held in MuJoCo against its task's wrenches
(:mod:`grasptask.physics`), beside the analytic verifier's verdict, as a table and a summary with the 2x2
agreement of the two judges."""

from __future__ import annotations

import os
from collections.abc import Callable
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
from grasptask.paths import DEFAULT_PHYSICS_CONFIG
from grasptask.physics.judge import Judge, best_grasp_trace, write_physics_results
from grasptask.physics.physics_settings import Controller, load_physics_settings
from grasptask.progress import Progress
from grasptask.records.sweeps import SweepFiles, SweepInputs


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

    def resolved(self) -> PhysicsOptions:
        used = SweepFiles.of(
            self.solutions, self.hand, self.object, self.grasp_config, self.fingers, self.tasks, self.task
        )
        tasks, task = used.named_task(self.solutions)
        return replace(
            self,
            solutions=Path(self.solutions),
            out=Path(self.out),
            tasks=tasks,
            task=task,
            hand=used.hand,
            object=used.object,
            grasp_config=used.grasp_config,
            physics_config=Path(self.physics_config),
            fingers=used.fingers,
        )


def _judge_for(inputs: PhysicsOptions) -> Judge:
    """The judge of ``inputs`` (resolved): its grasps, task model, object, settings, strength and friction; the
    first grasp's scene built, so that a hand file MuJoCo cannot compile is one line before any worker starts."""
    assert inputs.hand is not None and inputs.object is not None and inputs.grasp_config is not None
    assert inputs.tasks is not None and inputs.task is not None, "resolved() first"
    sweep = inputs.open_sweep()
    settings = load_physics_settings(inputs.physics_config)
    settings = replace(settings, controller=inputs.controller or settings.controller)
    friction = sweep.settings.friction_coefficient * inputs.friction_scale
    judge = Judge.of(sweep.solved, sweep.task_model, inputs.object, friction, settings, inputs.strength)
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


def run_physics(options: PhysicsOptions, echo: Callable[[str], Any] = print) -> pd.DataFrame:
    """Check every solved grasp of ``options.solutions``; writes ``out/physics.parquet`` (one row per start),
    ``out/physics_summary.json`` and ``out/physics_trace.parquet`` (the best verified grasp's motion over the
    protocol), and returns the table."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # inherited by the simulation processes
    inputs = options.resolved()
    out, workers = inputs.out, inputs.workers
    if not 1 <= workers <= MAX_WORKERS:
        raise BadInputError("physics", f"--workers must be from 1 to {MAX_WORKERS}, got {workers}")
    if inputs.strength <= 0 or inputs.friction_scale <= 0:
        raise BadInputError("physics", "--strength and --friction-scale must be positive")
    judge = _judge_for(inputs)  # every input checked here, before any work
    # --out held, and known to be writable, from the start: a second run into it is refused, not overwritten
    with folder_lock(out, f"physics {inputs.task}"):
        check_writable(out)
        return _judge_all(judge, inputs, out, workers, echo)


def _judge_all(
    judge: Judge, inputs: PhysicsOptions, out: str | Path, workers: int, echo: Callable[[str], Any]
) -> pd.DataFrame:
    indices = list(range(len(judge.solved.rows)))
    counts = {"held": 0, "dropped": 0}
    with Progress(len(indices), f"physics {inputs.task}", "grasps") as shown:
        parallel = workers > 1
        with ProcessPoolExecutor(workers, initializer=_start_worker, initargs=(judge,)) if parallel else (
            nullcontext()
        ) as pool:  # fmt: skip
            results = pool.map(_check_in_worker, indices) if pool is not None else map(judge.check, indices)
            records = []
            for record in results:
                records.append(record)
                if "physics_passed" in record:
                    counts["held" if record["physics_passed"] else "dropped"] += 1
                shown.update(1, **counts)
    table = pd.DataFrame(records)
    trace = best_grasp_trace(judge)
    files = [inputs.solutions, inputs.tasks, inputs.hand, inputs.object, inputs.grasp_config, inputs.physics_config]
    parameters = {
        "task": inputs.task,
        "controller": judge.holding.settings.controller,
        "strength": inputs.strength,
        "friction_scale": inputs.friction_scale,
    }
    provenance = Provenance.of("physics", parameters, [f for f in files if f is not None])
    with StagedOutput(out, provenance) as staged:
        result = write_physics_results(staged, table, judge.task.name, judge.holding.settings, trace, judge=judge)
    echo(physics_line(result))
    return table


def physics_line(result: dict[str, Any]) -> str:
    pair = result["agreement"]
    ours, theirs = result["physics_pass_rate_of_verified"], result["dexgraspbench_pass_rate_of_verified"]
    rates = "no verified grasps" if ours is None else f"{ours:.0%} held (DexGraspBench's test: {theirs:.0%})"
    return (
        f"{result['task']}: of {result['verified']} verified grasps {rates}; verifier x physics: "
        f"{pair['verified_and_held']} both accept, {pair['verified_and_dropped']} only the verifier, "
        f"{pair['rejected_and_held']} only physics, {pair['rejected_and_dropped']} neither"
        + (
            f"; the object's mass is not given: {result['object_mass_kg']:g} kg assumed (physics config "
            "object_mass_kg; --mass KG on synthesize)"
            if result.get("object_mass_given") is False
            else ""
        )
    )
