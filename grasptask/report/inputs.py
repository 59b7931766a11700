"""What a results folder holds, found by the layout the pipelines write:

    DIR/recordings/manifest.csv          simulate (or your own recordings' manifest; else the one the task
                                         models' provenance names, wherever it is)
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
from grasptask.io.tables import read_table
from grasptask.paths import DEFAULT_HAND, DEFAULT_OBJECT
from grasptask.physics.judge import TRACE_COLUMNS
from grasptask.records.sweeps import SOLUTIONS, Sweep, SweepFiles, finished_sweeps, unfinished_sweeps
from grasptask.task.manifest import is_manifest


def paper_setup(files: SweepFiles) -> bool:
    """Whether the paper's figures apply to a sweep of ``files``: one of its tasks, by the human hand, on its
    tool. A sugar box's Q beside the paper's tool's says nothing."""
    hand, obj = files.hand, files.object
    human = hand.parent.resolve() == DEFAULT_HAND.parent.resolve() and hand.name.startswith("human")
    tool = obj.is_file() and obj.resolve() == DEFAULT_OBJECT.resolve()
    return files.task in ("drawing", "cutting", "screwdriving") and human and tool


def simulated_recordings(manifest: Path) -> bool:
    """Whether the recordings of ``manifest`` are the bundled simulator's (its provenance says ``simulate``):
    the paper's protocol, whose Tables 1-10 they can be set beside. A user's own recordings are not."""
    try:
        ledger = json.loads((manifest.parent / "provenance.json").read_text())
    except (OSError, ValueError):
        return False
    entry = ledger.get(manifest.name) if isinstance(ledger, dict) else None
    return isinstance(entry, dict) and entry.get("command") == "simulate"


def manifest_read(task_models: Path) -> Path | None:
    """The manifest fit-task read to make ``task_models``, as their provenance records it (None: none that is
    still there, or models fitted to recording files without one)."""
    try:
        provenance = json.loads(task_models.read_text()).get("provenance") or {}
    except (OSError, ValueError, AttributeError):
        return None
    if not isinstance(provenance, dict) or provenance.get("command") != "fit-task":
        return None
    inputs = provenance.get("inputs") or {}
    for name in inputs if isinstance(inputs, dict) else ():
        path = Path(name)
        if path.suffix.lower() == ".csv" and is_manifest(path):
            return path
    return None


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
        """The recordings' manifest: ``recordings/manifest.csv``, else the one fit-task read for the task models
        (their provenance names it), wherever it is (``simulate --out rec``, a lab's own folder)."""
        laid_out = self._tasks_file("manifest.csv", up="recordings")
        if laid_out.is_file():
            return laid_out
        read = manifest_read(self.task_models)
        return read if read is not None else laid_out

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

    def sweep_folders(self) -> list[Path]:
        """The folders that a sweep has finished, at any depth."""
        return finished_sweeps(self.root)

    def physics_folders(self) -> list[Path]:
        """Folders of ``grasptask physics`` under the root (``physics_summary.json`` not beside a sweep)."""
        found = [p.parent for p in self.root.rglob("physics_summary.json")]
        sweeps = set(self.sweep_folders())
        return sorted(f for f in found if f not in sweeps and not _hidden(f, self.root))

    def export_folders(self) -> list[Path]:
        """Folders of ``grasptask export`` under the root (``grasps.json``)."""
        return sorted(p.parent for p in self.root.rglob("grasps.json") if not _hidden(p.parent, self.root))

    def holds_anything(self) -> bool:
        laid_out = (self.manifest, self.stats, self.ellipsoids, self.task_models, self.distances)
        found = self.sweep_folders() or self.unfinished_sweeps() or self.physics_folders() or self.export_folders()
        return bool(found or any(p.is_file() for p in laid_out))

    def unfinished_sweeps(self) -> list[Path]:
        """Sweeps interrupted or still running, at any depth."""
        return unfinished_sweeps(self.root)


def _hidden(folder: Path, root: Path) -> bool:
    return any(part.startswith(".") for part in folder.relative_to(root).parts)


def find_results(root: str | Path) -> ResultsFolder:
    """``root`` as results; a folder that holds nothing a report shows is one line saying where it looked.

    The task models are ``tasks/task_models.json``, else the ones the sweeps were made for, else the shallowest
    ``task_models.json`` that ``fit-task --out`` wrote anywhere under ``root``."""
    root = Path(root)
    if not root.is_dir():
        raise BadInputError(root, "results folder not found")
    results = ResultsFolder(root)
    if not results.task_models.is_file():  # a synthesize --out folder: the models its sweeps were made for
        for folder in results.sweep_folders():
            named = SweepFiles.of(folder / SOLUTIONS).tasks
            if named is not None and named.is_file():
                results = ResultsFolder(root, named)
                break
    if not results.task_models.is_file():
        fitted = _fitted_models(root)
        if fitted is not None:
            results = ResultsFolder(root, fitted)
    if not results.holds_anything():
        raise BadInputError(
            root,
            "holds nothing to report: looked at any depth for a sweep (<task>/run.json beside solutions.parquet), "
            "task models (task_models.json, as fit-task writes them), physics and export folders, and at "
            f"{results.ellipsoids} and {results.manifest}",
        )
    return results


def _fitted_models(root: Path) -> Path | None:
    """The shallowest ``task_models.json`` under ``root`` with fit-task's ``ellipsoids.parquet`` beside it (or
    else any), leaving out hidden folders and reports."""
    found = [p for p in root.rglob("task_models.json") if not _hidden(p.parent, root)]
    found.sort(key=lambda p: (not (p.parent / "ellipsoids.parquet").is_file(), len(p.parts), str(p)))
    return found[0] if found else None


def verifier_q(optimum: Any) -> float:
    """The verifier's Q of an optimum (a row of ``optima.parquet``) as synthesis recorded it, the NLP's own where
    an older table has no ``verify_Q``: one Q in every title and table, not the NLP's in one and the verifier's
    in another."""
    value = optimum.get("verify_Q")
    return float(value) if value is not None and np.isfinite(value) else float(optimum["Q"])


@dataclass(frozen=True)
class PhysicsOutcome:
    """One task's physics check: its ``physics_summary.json`` (with the traced grasps' worst moments) and their
    motion over the protocol (``physics_trace.parquet``, best Q first; empty when no grasp was traced)."""

    task: str
    folder: Path
    summary: dict
    trace: pd.DataFrame

    def moment(self, start_id: int) -> dict | None:
        """The traced grasp of ``start_id``'s worst moment (None: that start was not traced)."""
        return next((m for m in self.summary.get("traced") or [] if m.get("start_id") == start_id), None)

    def film(self, start_id: int) -> Path | None:
        moment = self.moment(start_id)
        path = self.folder / moment["film"] if moment is not None and moment.get("film") else None
        return path if path is not None and path.is_file() else None


def read_physics(results: ResultsFolder, sweep: Sweep) -> PhysicsOutcome | None:
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
