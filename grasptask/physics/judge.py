"""The physics judge of a sweep: what every check of one run shares (:class:`Judge`), and the run's table turned
into its summary, its 2x2 agreement with the analytic verifier and the best grasp's trace.

``grasptask physics`` and ``synthesize --physics`` both judge through it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from grasptask.grasp.grasp_pose import Grasp
from grasptask.io.artifacts import StagedOutput
from grasptask.physics.physics_settings import PhysicsSettings

if TYPE_CHECKING:
    from grasptask.hand.hand_model import Hand
    from grasptask.objects.surface import ImplicitObject
    from grasptask.physics.protocol import PhysicsResult
    from grasptask.physics.scene import ObjectBody, Scene
    from grasptask.records.sweeps import SolvedGrasps
    from grasptask.task.task_model import TaskModel


@dataclass(frozen=True)
class Holding:
    """What holding any grasp on one object needs, built once: the object and its convex parts (CoACD can take
    seconds), the friction, the settings and the actuators' strength factor."""

    obj: ImplicitObject
    friction: float
    settings: PhysicsSettings
    body: ObjectBody
    #: the hand's actuators this many times as strong as its model (the judge's validity protocol)
    strength: float = 1.0
    #: a flat pad's torsional friction (m): the grasp config's soft-finger coefficient
    pad_torsion: float = 0.0

    @classmethod
    def of(
        cls,
        obj: ImplicitObject,
        friction: float,
        settings: PhysicsSettings,
        strength: float = 1.0,
        pad_torsion: float = 0.0,
    ) -> Holding:
        from grasptask.physics.scene import object_body  # deferred: MuJoCo

        return cls(obj, friction, settings, object_body(obj, settings), strength, pad_torsion)

    def hold(self, hand: Hand, grasp: Grasp, task: TaskModel) -> PhysicsResult:
        from grasptask.physics.protocol import hold_grasp  # deferred: MuJoCo

        body, friction = self.body, self.friction
        return hold_grasp(hand, self.obj, body, grasp, friction, task, self.settings, self.strength, self.pad_torsion)

    def traced(self, hand: Hand, grasp: Grasp, task: TaskModel) -> tuple[Scene, PhysicsResult]:
        """The grasp's seated scene and its check with every control step kept (an exported scene's)."""
        from grasptask.physics.protocol import check_grasp, seated_scene  # deferred: MuJoCo

        h = self
        scene, seating = seated_scene(hand, h.obj, h.body, grasp, h.friction, h.settings, h.strength, h.pad_torsion)
        return scene, check_grasp(scene, task, h.body.mass_kg, h.settings, True, seating)


@dataclass(frozen=True)
class Judge:
    """What every check of one run shares, built once and handed to the worker processes: the solved grasps,
    the task model and the holding of grasps on the object."""

    solved: SolvedGrasps
    task: TaskModel
    holding: Holding

    def check_scene(self) -> None:
        """Build the first solved grasp's scene, so that a hand file MuJoCo cannot compile is one line here,
        before any worker starts."""
        from grasptask.physics.scene import build_scene  # deferred: MuJoCo

        grasp = next((grasp for _, grasp in self.solved.rows if grasp is not None), None)
        if grasp is not None:
            h = self.holding
            build_scene(self.solved.hand, h.obj, h.body, grasp, h.friction, h.settings, h.strength, h.pad_torsion)

    def hold(self, grasp: Grasp) -> PhysicsResult:
        return self.holding.hold(self.solved.hand, grasp, self.task)

    def trace(self, index: int, filmed: bool = False) -> Traced:
        """Row ``index``'s grasp held again with its trace kept (:class:`Traced`)."""
        from grasptask.physics.worst_moment import film_of, worst_moment  # deferred: MuJoCo

        row, grasp = self.solved.rows[index]
        assert grasp is not None
        start = int(row["start_id"])
        scene, result = self.holding.traced(self.solved.hand, grasp, self.task)
        frames = [
            pd.DataFrame({"start_id": start, "phase": phase, "time_s": t.time_s, "translation_m": t.translation_m,
                          "rotation_deg": t.rotation_deg})
            for phase, t in result.traces.items()
        ]  # fmt: skip
        moment = {"start_id": start, **worst_moment(scene, result, self.holding.settings)}
        film = film_of(scene, result, moment["phase"], self.holding) if filmed else None
        if film is not None:
            moment["film"] = f"films/start_{start:03d}.gif"
        return Traced(pd.concat(frames, ignore_index=True), moment, film)

    def check(self, index: int) -> dict[str, Any]:
        row, grasp = self.solved.rows[index]
        record: dict[str, Any] = {"start_id": int(row["start_id"]), "verified": bool(row.get("verified", False))}
        if grasp is None:
            return record
        record.update(self.hold(grasp).record())
        return record


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
#: the optima whose motion is kept over the whole protocol, best Q first, and how many of those are filmed
MAX_TRACED, MAX_FILMED = 12, 4


@dataclass(frozen=True)
class Traced:
    """One grasp held again with every control step kept: its motion (``TRACE_COLUMNS``), its worst moment
    (where the object was furthest from its start in the phase that dropped it, else in its worst phase of the
    task's) and, where offscreen rendering works, that phase as a GIF."""

    trace: pd.DataFrame
    moment: dict[str, Any]
    film: bytes | None = None


def traced_rows(judge: Judge, optima: pd.DataFrame | None) -> list[tuple[int, bool]]:
    """Which of ``judge``'s rows to trace, and whether to film each: the distinct optima's best starts, best Q
    first (at most :data:`MAX_TRACED`, the first :data:`MAX_FILMED` filmed); without optima, the verified grasp
    of lowest Q."""
    index = {int(row["start_id"]): k for k, (row, grasp) in enumerate(judge.solved.rows) if grasp is not None}
    if optima is not None and len(optima):
        ordered = optima.sort_values("Q", kind="stable")["start_id"].astype(int)
        rows = [index[s] for s in ordered if s in index][:MAX_TRACED]
    else:
        verified = [
            (float(row["Q"]), k)
            for k, (row, grasp) in enumerate(judge.solved.rows)
            if grasp is not None and row.get("verified") and np.isfinite(float(row.get("Q", np.nan)))
        ]
        rows = [min(verified)[1]] if verified else []
    return [(k, n < MAX_FILMED) for n, k in enumerate(rows)]


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
    traced: list[Traced],
    table_name: str | None = "physics.parquet",
    judge: Judge | None = None,
) -> dict[str, Any]:
    """``physics_summary.json`` (with each traced grasp's worst moment, and why nothing was filmed where
    offscreen rendering is unavailable), ``physics_trace.parquet``, ``films/`` (and the table itself, unless
    ``table_name`` is None: a sweep's solutions table already holds the columns); the summary, with the
    object's mass from ``judge``."""
    from grasptask.physics.film import offscreen_unavailable  # deferred: it starts a process once

    summarised = ("physics_passed", "dexgraspbench_passed", "physics_failed_wrench", "physics_seconds")
    table = table.assign(**{c: pd.NA for c in summarised if c not in table})  # no columns: no grasp was checked
    result = summary(table, task, settings)
    if judge is not None:  # a mass not given is stated, never silently assumed
        result["object_mass_kg"] = judge.holding.body.mass_kg
        result["object_mass_given"] = getattr(judge.holding.obj, "mass_kg", None) is not None
    result["traced"] = [t.moment for t in traced]
    # a film made says rendering works; the probe (a process of its own) only where none was
    result["films_unavailable"] = offscreen_unavailable() if traced and not any(t.film for t in traced) else None
    if table_name is not None:
        staged.write_parquet(table_name, table)
    staged.write_json("physics_summary.json", result)
    frames = [t.trace for t in traced] or [pd.DataFrame({column: [] for column in TRACE_COLUMNS})]
    staged.write_parquet("physics_trace.parquet", pd.concat(frames, ignore_index=True))
    for t in traced:
        if t.film is not None:
            staged.path(t.moment["film"]).write_bytes(t.film)
    return result
