"""What a results folder holds, found by the layout the pipelines write:

    DIR/recordings/manifest.csv          simulate (or your own recordings' manifest)
    DIR/tasks/stats.csv, ellipsoids.parquet, task_models.json      fit-task
    DIR/tasks/distances.parquet, distance_summary.json             distances
    DIR/grasps/<task>/run.json, solutions.parquet, optima.parquet  synthesize
    DIR/physics/<task>/physics_summary.json, physics_trace.parquet physics (or beside the sweep's own files,
                                                                   from synthesize --physics)

Any part may be missing; the report makes what it can from the rest.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from grasptask.errors import BadInputError
from grasptask.io.config_schema import read_json
from grasptask.io.sweep_log import read_log
from grasptask.io.tables import read_table
from grasptask.paths import DEFAULT_HAND, DEFAULT_OBJECT
from grasptask.physics.judge import TRACE_COLUMNS


@dataclass(frozen=True)
class SweepResult:
    """One task's synthesis output: ``run.json`` and its solutions and optima tables."""

    task: str
    folder: Path
    run: dict
    solutions: pd.DataFrame
    optima: pd.DataFrame

    @property
    def paper_setup(self) -> bool:
        """Whether the paper's figures apply: one of its tasks, by the human hand, on its tool. A sugar box's Q
        beside the paper's tool's says nothing."""
        hand, obj = Path(str(self.run.get("hand", ""))), Path(str(self.run.get("object", "")))
        human = hand.parent.resolve() == DEFAULT_HAND.parent.resolve() and hand.name.startswith("human")
        tool = obj.is_file() and obj.resolve() == DEFAULT_OBJECT.resolve()
        return self.task in ("drawing", "cutting", "screwdriving") and human and tool


@dataclass(frozen=True)
class ResultsFolder:
    """A folder of results as the pipelines lay it out (``recordings/``, ``tasks/``, ``grasps/<task>/``,
    ``physics/<task>/``), or any folder holding sweeps at any depth (``synthesize --out X`` writes ``X/<task>/``):
    the task models are then the ones the sweeps' ``run.json`` names."""

    root: Path
    #: the task models when ``tasks/task_models.json`` is not there (None: that path, missing)
    models: Path | None = None

    def _tasks_file(self, name: str, up: str = "") -> Path:
        """``tasks/<name>`` (``<up>/<name>`` for a sibling of ``tasks/``), or else the one that fit-task, distances
        or simulate wrote beside the task models the sweeps name: the report of a ``synthesize --out`` folder
        draws what the user's own run made."""
        laid_out = self.root / (up or "tasks") / name
        if laid_out.is_file() or self.models is None:
            return laid_out
        beside = (self.models.parent.parent / up if up else self.models.parent) / name
        return beside if beside.is_file() else laid_out

    @property
    def manifest(self) -> Path:
        return self._tasks_file("manifest.csv", up="recordings")

    @property
    def stats(self) -> Path:
        return self._tasks_file("stats.csv")

    @property
    def ellipsoids(self) -> Path:
        return self._tasks_file("ellipsoids.parquet")

    @property
    def task_models(self) -> Path:
        laid_out = self.root / "tasks" / "task_models.json"
        return laid_out if laid_out.is_file() or self.models is None else self.models

    @property
    def distances(self) -> Path:
        return self._tasks_file("distances.parquet")

    @property
    def distance_summary(self) -> Path:
        return self._tasks_file("distance_summary.json")

    @property
    def grasps(self) -> Path:
        return self.root / "grasps"

    @property
    def physics(self) -> Path:
        return self.root / "physics"

    def _task_folders_with(self, name: str) -> list[Path]:
        """The folders under the root holding ``name`` beside a sweep's log or table, at any depth (not in hidden
        folders: a stage's staging folder)."""
        found = []
        for path in self.root.rglob(name):
            inside = path.parent.relative_to(self.root).parts
            if any(part.startswith(".") for part in inside):
                continue
            if any((path.parent / kept).is_file() for kept in ("solutions.parquet", "solutions.jsonl")):
                found.append(path.parent)
        return sorted(found)

    def sweep_folders(self) -> list[Path]:
        """The folders that a sweep has finished (``run.json`` beside its solutions), at any depth."""
        return self._task_folders_with("run.json")

    def physics_folders(self) -> list[Path]:
        """Folders of ``grasptask physics`` under the root (``physics_summary.json`` not beside a sweep)."""
        found = [p.parent for p in self.root.rglob("physics_summary.json")]
        return sorted(f for f in found if not (f / "run.json").is_file() and not _hidden(f, self.root))

    def export_folders(self) -> list[Path]:
        """Folders of ``grasptask export`` under the root (``grasps.json``)."""
        return sorted(p.parent for p in self.root.rglob("grasps.json") if not _hidden(p.parent, self.root))

    def holds_anything(self) -> bool:
        laid_out = (self.manifest, self.stats, self.ellipsoids, self.task_models, self.distances)
        found = self.sweep_folders() or self.unfinished_sweeps() or self.physics_folders() or self.export_folders()
        return bool(found or any(p.is_file() for p in laid_out))

    def unfinished_sweeps(self) -> list[Path]:
        """Task folders whose per-start log holds rows that no summary includes: a sweep interrupted or still
        running (with or without the run.json of an earlier, finished sweep)."""
        unfinished = []
        for folder in self._task_folders_with("solutions.jsonl"):
            try:
                summarised = json.loads((folder / "run.json").read_text()).get("log_rows")
            except (OSError, ValueError, AttributeError):
                summarised = None
            if summarised != len(read_log(folder / "solutions.jsonl").rows):
                unfinished.append(folder)
        return unfinished


def _hidden(folder: Path, root: Path) -> bool:
    return any(part.startswith(".") for part in folder.relative_to(root).parts)


def find_results(root: str | Path) -> ResultsFolder:
    """``root`` as results; a folder that holds nothing a report shows is one line."""
    root = Path(root)
    if not root.is_dir():
        raise BadInputError(root, "results folder not found")
    results = ResultsFolder(root)
    if not results.task_models.is_file():  # a synthesize --out folder: the models its sweeps were made for
        for folder in results.sweep_folders():
            named = read_json(folder / "run.json").get("tasks")
            if isinstance(named, str) and Path(named).is_file():
                results = ResultsFolder(root, Path(named))
                break
    if not results.holds_anything():
        raise BadInputError(
            root,
            "holds nothing to report: no sweep (<task>/run.json beside solutions.parquet, at any depth), task "
            "models, ellipsoids or recordings",
        )
    return results


#: what the report reads of run.json, and the types it must have
RUN_FIELDS: dict[str, type | tuple[type, ...]] = {
    "task": str,
    "hand": str,
    "object": str,
    "grasp_config": str,
    "model_size": (dict, type(None)),
}


def read_sweep(folder: Path) -> SweepResult:
    run = read_json(folder / "run.json")
    for name, kind in RUN_FIELDS.items():
        if name in run and not isinstance(run[name], kind):
            raise BadInputError(folder / "run.json", f"field '{name}' has the wrong type: {run[name]!r}")
    size = run.get("model_size") or {}
    if not all(isinstance(size.get(k), int) for k in ("variables", "constraints")) and size:
        raise BadInputError(folder / "run.json", f"field 'model_size' must hold two counts, got {size!r}")
    solutions = read_table(folder / "solutions.parquet", ("start_id", "status", "seconds", "verified"))
    _check_numbers(folder / "solutions.parquet", solutions, ["seconds"], missing_ok=True)
    optima = read_table(folder / "optima.parquet")
    numeric = [c for c in optima.columns if c.startswith(("palm_", "q_", "contact_", "normal_")) or c == "Q"]
    numeric += ["verify_Q"] if "verify_Q" in optima.columns else []
    _check_numbers(folder / "optima.parquet", optima, numeric, missing_ok=False)
    return SweepResult(str(run.get("task", folder.name)), folder, run, solutions, optima)


def verifier_q(optimum: Any) -> float:
    """The verifier's Q of an optimum (a row of ``optima.parquet``) as synthesis recorded it, the NLP's own where
    an older table has no ``verify_Q``: one Q in every title and table, not the NLP's in one and the verifier's
    in another."""
    value = optimum.get("verify_Q")
    return float(value) if value is not None and np.isfinite(value) else float(optimum["Q"])


def _check_numbers(path: Path, table: pd.DataFrame, columns: list[str], missing_ok: bool) -> None:
    """One line naming the row and column of the first value in ``columns`` that is not a finite number (a
    missing one allowed where ``missing_ok``: a start that failed has no time)."""
    for column in columns:
        if not pd.api.types.is_numeric_dtype(table[column]) or pd.api.types.is_bool_dtype(table[column]):
            raise BadInputError(path, f"must hold numbers, not {table[column].dtype} values", column=column)
        values = table[column].astype(float)
        bad = values.isin([float("inf"), float("-inf")])
        if not missing_ok:
            bad |= values.isna()
        if bad.any():
            row = int(bad.to_numpy().argmax())
            raise BadInputError(path, f"not a finite number: {table[column].iloc[row]!r}", row=row + 1, column=column)


@dataclass(frozen=True)
class PhysicsOutcome:
    """One task's physics check: its ``physics_summary.json`` and the best grasp's motion over the protocol
    (``physics_trace.parquet``, empty when no grasp was verified)."""

    task: str
    folder: Path
    summary: dict
    trace: pd.DataFrame


def read_physics(results: ResultsFolder, sweep: SweepResult) -> PhysicsOutcome | None:
    """The physics check of ``sweep``'s task: ``grasptask physics``'s output under ``physics/<task>/`` when
    there is one, else ``synthesize --physics``'s beside the sweep; None when neither ran."""
    folders = [results.physics / sweep.folder.name]
    for folder in results.physics_folders():  # wherever `grasptask physics --out` put it, for this task
        try:
            task = json.loads((folder / "physics_summary.json").read_text()).get("task")
        except (OSError, ValueError, AttributeError):
            task = None
        if task == sweep.task and folder not in folders:
            folders.append(folder)
    if sweep.run.get("physics_config"):  # this sweep ran synthesize --physics, not an earlier one
        folders.append(sweep.folder)
    for folder in folders:
        if (folder / "physics_summary.json").is_file():
            summary = read_json(folder / "physics_summary.json")
            for name in ("verified", "agreement", "thresholds"):
                if name not in summary:
                    raise BadInputError(folder / "physics_summary.json", f"missing field '{name}'")
            trace = read_table(folder / "physics_trace.parquet", TRACE_COLUMNS)
            return PhysicsOutcome(sweep.task, folder, summary, trace)
    return None
