"""Task models: the Log-Euclidean mean ellipsoid of each task's recordings (``task_models.json``)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from grasptask.errors import BadInputError
from grasptask.task.ellipsoid import Ellipsoid
from grasptask.task.fit import ellipsoid_matrices
from grasptask.task.spd import log_euclidean_mean
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

    @classmethod
    def from_dict(cls, name: str, data: dict) -> TaskModel:
        return cls(name, int(data["n_recordings"]), Ellipsoid.from_matrix(np.asarray(data["S"], dtype=float)))


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


def task_models_payload(ellipsoids: pd.DataFrame) -> dict:
    return {
        "frame": "object (origin at the handle centre, z along the handle axis)",
        "wrench_order": WRENCH_ORDER,
        "units": {"force": "N", "torque": "N.m"},
        "tasks": {name: m.to_dict() for name, m in mean_models(ellipsoids, "task").items()},
        "groups": {name: m.to_dict() for name, m in mean_models(ellipsoids, "group").items()},
    }


def load_task_models(path: str | Path, section: str = "tasks") -> dict[str, TaskModel]:
    """Read ``task_models.json``: ``{task name: TaskModel}``."""
    path = Path(path)
    if not path.is_file():
        raise BadInputError(path, "file not found")
    try:
        data = json.loads(path.read_text())
        return {name: TaskModel.from_dict(name, d) for name, d in data[section].items()}
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        raise BadInputError(path, f"not a task-models file ({type(exc).__name__}: {exc})") from exc
