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
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from grasptask.errors import BadInputError
from grasptask.grasp.grasp import Grasp
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.io.locking import check_writable, folder_lock
from grasptask.paths import DEFAULT_PHYSICS_CONFIG

if TYPE_CHECKING:
    from grasptask.objects.surface import ImplicitObject
    from grasptask.physics.protocol import PhysicsResult
    from grasptask.physics.scene import ObjectBody
    from grasptask.physics.settings import PhysicsSettings
    from grasptask.stages.verify import SolvedGrasps
    from grasptask.task.model import TaskModel


@dataclass(frozen=True)
class PhysicsInputs:
    """The files one check is made from; ``None`` takes what the sweep of the solutions used (its
    ``run.json``), else the package defaults."""

    solutions: Path
    #: None: what the sweep's run.json names
    tasks: Path | None = None
    task: str | None = None
    hand: Path | None = None
    object: Path | None = None
    grasp_config: Path | None = None
    physics_config: Path = DEFAULT_PHYSICS_CONFIG
    fingers: tuple[str, ...] | None = None
    #: None: the physics config's controller
    controller: str | None = None
    #: the hand's actuators and the friction coefficient this many times the models' (the judge's own checks)
    strength: float = 1.0
    friction_scale: float = 1.0

    def resolved(self) -> PhysicsInputs:
        from grasptask.stages.verify import SweepFiles

        used = SweepFiles.of(
            self.solutions, self.hand, self.object, self.grasp_config, self.fingers, self.tasks, self.task
        )
        tasks, task = used.named_task(self.solutions)
        return replace(
            self,
            solutions=Path(self.solutions),
            tasks=tasks,
            task=task,
            hand=used.hand,
            object=used.object,
            grasp_config=used.grasp_config,
            physics_config=Path(self.physics_config),
            fingers=used.fingers,
        )


@dataclass(frozen=True)
class Judge:
    """What every check of one run shares, built once and handed to the worker processes: the solved grasps,
    the task model, the object and its convex parts (CoACD can take seconds), the friction and the settings."""

    solved: SolvedGrasps
    task: TaskModel
    obj: ImplicitObject
    friction: float
    settings: PhysicsSettings
    body: ObjectBody
    #: the hand's actuators this many times as strong as its model (the judge's validity protocol)
    strength: float = 1.0

    @classmethod
    def of(cls, solved: SolvedGrasps, task: TaskModel, object_path: Path, grasp_config: Path, physics: Path) -> Judge:
        from grasptask.grasp.settings import load_grasp_settings
        from grasptask.objects import load_object
        from grasptask.physics.scene import object_body
        from grasptask.physics.settings import load_physics_settings

        obj = load_object(object_path, say=lambda _: None)
        settings = load_physics_settings(physics)
        friction = load_grasp_settings(grasp_config).friction_coefficient
        return cls(solved, task, obj, friction, settings, object_body(obj, settings))

    @classmethod
    def for_inputs(cls, inputs: PhysicsInputs) -> Judge:
        from grasptask.stages.verify import read_grasps
        from grasptask.task.model import load_task_model

        assert inputs.hand is not None and inputs.object is not None and inputs.grasp_config is not None
        assert inputs.tasks is not None and inputs.task is not None, "resolved() first"
        model = load_task_model(inputs.tasks, inputs.task)
        solved = read_grasps(inputs.solutions, inputs.hand, inputs.fingers)
        judge = cls.of(solved, model, inputs.object, inputs.grasp_config, inputs.physics_config)
        controller = inputs.controller or judge.settings.controller
        settings = replace(judge.settings, controller=controller)
        judge = replace(
            judge, settings=settings, strength=inputs.strength, friction=judge.friction * inputs.friction_scale
        )
        judge.check_scene()
        return judge

    def check_scene(self) -> None:
        """Build the first solved grasp's scene, so that a hand file MuJoCo cannot compile is one line here,
        before any worker starts."""
        from grasptask.physics.scene import build_scene

        grasp = next((grasp for _, grasp in self.solved.rows if grasp is not None), None)
        if grasp is not None:
            build_scene(self.solved.hand, self.obj, self.body, grasp, self.friction, self.settings, self.strength)

    def hold(self, grasp: Grasp, trace: bool = False) -> PhysicsResult:
        from grasptask.physics.protocol import hold_grasp

        hand, obj, body = self.solved.hand, self.obj, self.body
        return hold_grasp(hand, obj, body, grasp, self.friction, self.task, self.settings, trace, self.strength)

    def check(self, index: int) -> dict[str, Any]:
        row, grasp = self.solved.rows[index]
        record: dict[str, Any] = {"start_id": int(row["start_id"]), "verified": bool(row.get("verified", False))}
        if grasp is None:
            return record
        record.update(self.hold(grasp).record())
        return record


_worker: Judge | None = None


def _start_worker(judge: Judge) -> None:
    global _worker
    from grasptask.io.orphans import die_with_parent

    die_with_parent()  # a physics run killed outright left its pool workers running for minutes
    os.environ["OPENBLAS_NUM_THREADS"] = "1"
    _worker = judge


def _check_in_worker(index: int) -> dict[str, Any]:
    assert _worker is not None
    return _worker.check(index)


def agreement(table: pd.DataFrame) -> dict[str, int]:
    """The 2x2 table of the two judges over the solved grasps: verifier accepts or rejects, physics holds or
    drops."""
    solved = table[table["physics_passed"].notna()]
    verified, held = solved["verified"].astype(bool), solved["physics_passed"].astype(bool)
    return {
        "verified_and_held": int((verified & held).sum()),
        "verified_and_dropped": int((verified & ~held).sum()),
        "rejected_and_held": int((~verified & held).sum()),
        "rejected_and_dropped": int((~verified & ~held).sum()),
    }


TRACE_COLUMNS = ("start_id", "phase", "time_s", "translation_m", "rotation_deg")


def best_grasp_trace(judge: Judge) -> pd.DataFrame:
    """The object's motion over the whole protocol (``TRACE_COLUMNS``, phases in the protocol's order) under
    the verified grasp of lowest Q, the best optimum's best start, held again with its trace kept; no rows
    when no grasp is verified."""
    verified = [
        (row, grasp)
        for row, grasp in judge.solved.rows
        if grasp is not None and row.get("verified") and np.isfinite(float(row.get("Q", np.nan)))
    ]
    if not verified:
        return pd.DataFrame({column: [] for column in TRACE_COLUMNS})
    row, grasp = min(verified, key=lambda pair: float(pair[0]["Q"]))
    result = judge.hold(grasp, trace=True)
    frames = [
        pd.DataFrame(
            {
                "start_id": int(row["start_id"]),
                "phase": phase,
                "time_s": motion[:, 0],
                "translation_m": motion[:, 1],
                "rotation_deg": motion[:, 2],
            }
        )
        for phase, motion in result.traces.items()
    ]
    return pd.concat(frames, ignore_index=True)


def summary(table: pd.DataFrame, task: str, settings: PhysicsSettings) -> dict[str, Any]:
    """Pass rates among the verified grasps, DexGraspBench's beside ours, the 2x2 agreement, the failing
    wrenches, the seconds per grasp and the thresholds the pass flags used."""
    solved = table[table["physics_passed"].notna()]
    verified = solved[solved["verified"].astype(bool)]

    def rate(frame: pd.DataFrame, column: str) -> float | None:
        return float(frame[column].astype(bool).mean()) if len(frame) else None

    failing = verified.loc[~verified["physics_passed"].astype(bool), "physics_failed_wrench"]
    return {
        "task": task,
        "solved": int(len(solved)),
        "verified": int(len(verified)),
        "physics_pass_rate_of_verified": rate(verified, "physics_passed"),
        "dexgraspbench_pass_rate_of_verified": rate(verified, "dexgraspbench_passed"),
        "agreement": agreement(table),
        "failed_wrenches_of_verified": {str(k): int(v) for k, v in failing.value_counts().items()},
        "seconds_per_grasp_median": float(np.median(solved["physics_seconds"])) if len(solved) else None,
        "thresholds": {
            "max_translation_m": settings.max_translation_m,
            "max_rotation_deg": settings.max_rotation_deg,
            "benchmark_translation_m": settings.benchmark_translation_m,
            "benchmark_rotation_deg": settings.benchmark_rotation_deg,
        },
    }


def write_physics_results(
    staged: StagedOutput,
    table: pd.DataFrame,
    task: str,
    settings: PhysicsSettings,
    trace: pd.DataFrame,
    table_name: str | None = "physics.parquet",
    judge: Judge | None = None,
) -> dict[str, Any]:
    """``physics_summary.json`` and ``physics_trace.parquet`` (and the table itself, unless ``table_name`` is
    None: a sweep's solutions table already holds the columns); the summary, with the object's mass from
    ``judge``."""
    summarised = ("physics_passed", "dexgraspbench_passed", "physics_failed_wrench", "physics_seconds")
    table = table.assign(**{c: pd.NA for c in summarised if c not in table})  # no columns: no grasp was checked
    result = summary(table, task, settings)
    if judge is not None:  # a mass not given is stated, never silently assumed
        result["object_mass_kg"] = judge.body.mass_kg
        result["object_mass_given"] = getattr(judge.obj, "mass_kg", None) is not None
    if table_name is not None:
        staged.write_parquet(table_name, table)
    staged.write_json("physics_summary.json", result)
    staged.write_parquet("physics_trace.parquet", trace)
    return result


def run_physics(
    inputs: PhysicsInputs, out: str | Path, workers: int = 1, echo: Callable[[str], Any] = print
) -> pd.DataFrame:
    """Check every solved grasp of ``inputs.solutions``; writes ``out/physics.parquet`` (one row per start),
    ``out/physics_summary.json`` and ``out/physics_trace.parquet`` (the best verified grasp's motion over the
    protocol), and returns the table."""

    inputs = inputs.resolved()
    if workers < 1:
        raise BadInputError("physics", "--workers must be at least 1")
    if inputs.strength <= 0 or inputs.friction_scale <= 0:
        raise BadInputError("physics", "--strength and --friction-scale must be positive")
    judge = Judge.for_inputs(inputs)  # every input checked here, before any work
    # --out held, and known to be writable, from the start: a second run into it is refused, not overwritten
    with folder_lock(out, f"physics {inputs.task}"):
        check_writable(out)
        return _judge_all(judge, inputs, out, workers, echo)


def _judge_all(
    judge: Judge, inputs: PhysicsInputs, out: str | Path, workers: int, echo: Callable[[str], Any]
) -> pd.DataFrame:
    from grasptask.progress import Progress

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
        "controller": judge.settings.controller,
        "strength": inputs.strength,
        "friction_scale": inputs.friction_scale,
    }
    provenance = Provenance.of("physics", parameters, [f for f in files if f is not None])
    with StagedOutput(out, provenance) as staged:
        result = write_physics_results(staged, table, judge.task.name, judge.settings, trace, judge=judge)
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
