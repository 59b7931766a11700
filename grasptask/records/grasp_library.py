"""A grasp library: the verified optima of earlier sweeps, kept by hand, object and task, to warm-start a sweep
of a similar task from them.

Similar is the paper's own measure of task similarity, the Log-Euclidean distance between the task ellipsoids.
A sweep reads and adds to a library only when the user names one (``synthesize --library DIR``), so that a
sweep without one stays reproducible. An entry is one JSON file per setup and task, replaced whole in one rename:
a kill leaves the old entry or the new one."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from grasptask.errors import BadInputError
from grasptask.io.artifacts import config_hash, write_json_atomic
from grasptask.io.config_schema import read_json
from grasptask.io.tables import check_numbers
from grasptask.records.solutions import GRASP_PREFIXES
from grasptask.task.spd import log_euclidean_distance, spd_problem
from grasptask.task.task_model import TaskModel


@dataclass(frozen=True)
class LibraryEntry:
    """The optima of one task for one setup, and how far its task is from the one asked for."""

    path: Path
    task: str
    S: np.ndarray
    #: the optima, best (lowest Q) first
    optima: pd.DataFrame
    distance: float = 0.0


def setup_key(hand: str, obj: str, fingers: list[str]) -> str:
    """What a warm start must share with the sweep it came from: the hand file, the object (its files and
    options, as hashes) and the grasping fingers. Another hand's joints or another object's surface would start
    a grasp nowhere near an optimum."""
    return config_hash({"hand": hand, "object": obj, "fingers": list(fingers)})[:16]


def add_to_library(library: str | Path, setup: str, task: TaskModel, optima: pd.DataFrame) -> Path | None:
    """Keep ``optima`` (a sweep's distinct verified optima) as ``task``'s for ``setup``, in place of an earlier
    sweep's of the same task; None when there is none to keep."""
    if optima.empty:
        return None
    kept = [c for c in optima.columns if c.startswith(GRASP_PREFIXES)] + ["Q"]  # what a warm start needs
    rows = optima.sort_values("Q")[kept].astype(float).to_dict("records")
    S = np.asarray(task.ellipsoid.S, dtype=float)
    path = Path(library) / setup / f"{task.name}-{config_hash(S.round(12).tolist())[:12]}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, {"task": task.name, "S": S.tolist(), "optima": rows})
    return path


def nearest_entry(library: str | Path, setup: str, task: TaskModel) -> LibraryEntry | None:
    """The entry of ``setup`` whose task is nearest ``task`` by the Log-Euclidean distance (None: the library
    holds none for this hand, object and fingers). A broken entry is one line naming its file."""
    folder = Path(library) / setup
    entries = [_read_entry(path) for path in sorted(folder.glob("*.json"))] if folder.is_dir() else []
    if not entries:
        return None
    S = np.asarray(task.ellipsoid.S, dtype=float)
    distances = [log_euclidean_distance(S, entry.S) for entry in entries]
    best = int(np.argmin(distances))
    entry = entries[best]
    return LibraryEntry(entry.path, entry.task, entry.S, entry.optima, float(distances[best]))


def _read_entry(path: Path) -> LibraryEntry:
    data: dict[str, Any] = read_json(path)
    task, S, optima = data.get("task"), data.get("S"), data.get("optima")
    if not isinstance(task, str):
        raise BadInputError(path, f"field 'task' must be a name, got {task!r}")
    problem = spd_problem(S)
    if problem is not None:
        raise BadInputError(path, f"field 'S': {problem}")
    if not isinstance(optima, list) or not optima or not all(isinstance(row, dict) for row in optima):
        raise BadInputError(path, "field 'optima' must be a list of grasps")
    numbers = pd.DataFrame(optima).apply(pd.to_numeric, errors="coerce")
    check_numbers(path, numbers, list(numbers.columns), missing_ok=False)  # no NaN from a file reaches a solver
    return LibraryEntry(path, task, np.asarray(S, dtype=float), numbers)
