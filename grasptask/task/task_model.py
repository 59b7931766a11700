"""Task models: the Log-Euclidean mean ellipsoid of each task's recordings (``task_models.json``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from grasptask.errors import BadInputError
from grasptask.io.config_schema import read_json
from grasptask.task.ellipsoid import Ellipsoid, ellipsoid_matrices
from grasptask.task.spd import log_euclidean_mean, spd_problem
from grasptask.task.stats import group_order

WRENCH_ORDER = ["fx", "fy", "fz", "tx", "ty", "tz"]


@dataclass(frozen=True)
class TaskModel:
    """A task's mean ellipsoid: axes ``u_i`` (rows here), lengths ``gamma_i`` (SI) and weights of eq. 12."""

    name: str
    n_recordings: int
    ellipsoid: Ellipsoid

    @property
    def axes(self) -> np.ndarray:
        """``(6, 6)``: row i is the unit wrench direction ``u_i``, longest axis first."""
        return self.ellipsoid.axes.T

    @property
    def lengths(self) -> np.ndarray:
        return self.ellipsoid.lengths

    @property
    def weights(self) -> np.ndarray:
        return self.ellipsoid.weights

    def to_dict(self) -> dict:
        return {
            "n_recordings": self.n_recordings,
            "S": self.ellipsoid.S.tolist(),
            "axes": self.axes.tolist(),
            "lengths": self.lengths.tolist(),
            "weights": self.weights.tolist(),
        }


def mean_models(ellipsoids: pd.DataFrame, by: str) -> dict[str, TaskModel]:
    """One Log-Euclidean mean model per value of column ``by`` (``task`` or ``group``)."""
    order = group_order(ellipsoids[by]) if by == "group" else list(dict.fromkeys(ellipsoids[by]))
    models = {}
    for name in order:
        members = ellipsoids[ellipsoids[by] == name]
        models[name] = TaskModel(
            name, len(members), Ellipsoid.from_matrix(log_euclidean_mean(ellipsoid_matrices(members)))
        )
    return models


def task_models_payload(ellipsoids: pd.DataFrame, findings: list[dict] | None = None) -> dict:
    """What ``task_models.json`` holds: a model per task and per group, and what fit-task's checks said of the
    recordings (``findings``: one entry per recording and check, with its message and figures)."""
    return {
        "frame": "object (origin at the handle centre, z along the handle axis)",
        "wrench_order": WRENCH_ORDER,
        "units": {"force": "N", "torque": "N.m"},
        "tasks": {name: m.to_dict() for name, m in mean_models(ellipsoids, "task").items()},
        "groups": {name: m.to_dict() for name, m in mean_models(ellipsoids, "group").items()},
        "findings": findings or [],
    }


def _model(path: Path, section: str, name: object, data: object) -> TaskModel:
    where = f"field '{section}.{name}"
    if not isinstance(name, str) or not name:
        raise BadInputError(path, f"{where}': a task name must be a non-empty string")
    if not isinstance(data, dict) or "S" not in data:
        raise BadInputError(path, f"{where}' must be a mapping with S (the 6 x 6 second moment)")
    problem = spd_problem(data["S"])
    if problem:
        raise BadInputError(path, f"{where}.S' {problem}")
    count = data.get("n_recordings", 1)
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise BadInputError(path, f"{where}.n_recordings' must be a positive whole number, got {count!r}")
    return TaskModel(name, count, Ellipsoid.from_matrix(np.asarray(data["S"], dtype=float)))


def load_task_models(path: str | Path, section: str = "tasks") -> dict[str, TaskModel]:
    """Read ``task_models.json``: ``{task name: TaskModel}``, every ``S`` checked to be a 6 x 6 SPD matrix
    (the axes, lengths and weights are derived from it again)."""
    data = read_json(path)
    models = data.get(section)
    if not isinstance(models, dict) or not models:
        raise BadInputError(path, f"not a task-models file: no '{section}' mapping of task models")
    return {name: _model(Path(path), section, name, model) for name, model in models.items()}


def load_task_model(path: str | Path, task: str) -> TaskModel:
    """Task ``task`` of the task-models file ``path``; one line naming the file and its tasks when it has none
    by that name."""
    models = load_task_models(path)
    if task not in models:
        raise BadInputError(path, f"no task '{task}' (has: {', '.join(models)})")
    return models[task]
