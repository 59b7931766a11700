"""Tool configs: where the force/torque sensor sits on the tool, and how its recordings are laid out.

A tool config is a YAML file named by a manifest's ``tool`` column::

    name: wrist_sensor
    sensor:                      # pose of the sensor frame in the object frame
      position_m: [0.0, 0.0, -0.105]
      rotation_rpy_deg: [180, 0, 30]   # fixed-axis roll (x), pitch (y), yaw (z), applied in that order
      frame_id: ft_sensor        # optional: the header frame_id of the sensor's ROS messages, checked
    columns: {t: time_ms, fx: Fx}      # optional: recording column name for each canonical column
    ignore_columns: [status]           # optional: recording columns to drop
    units: {torque_unit: N.cm, time_unit: ms}   # optional defaults; the manifest's columns win
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from grasptask.errors import BadInputError
from grasptask.io.config import load_yaml, reject_unknown, require
from grasptask.task.units import UNIT_TABLES

CANONICAL_COLUMNS = ("t", "fx", "fy", "fz", "tx", "ty", "tz")


@dataclass(frozen=True)
class ToolConfig:
    name: str
    sensor_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    sensor_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    columns: dict[str, str] = field(default_factory=dict)
    ignore_columns: tuple[str, ...] = ()
    units: dict[str, str] = field(default_factory=dict)
    #: the frame_id the sensor's ROS WrenchStamped messages carry ("": not checked)
    frame_id: str = ""


def load_tool(path: str | Path) -> ToolConfig:
    path = Path(path)
    data = load_yaml(path)
    reject_unknown(data, {"name", "description", "sensor", "columns", "ignore_columns", "units"}, path)
    sensor = data.get("sensor", {})
    if not isinstance(sensor, dict):
        raise BadInputError(path, "field 'sensor' must be a mapping")
    reject_unknown(sensor, {"position_m", "rotation_rpy_deg", "rotation_matrix", "frame_id"}, path, "sensor.")
    position = _vector(sensor.get("position_m", [0, 0, 0]), 3, path, "sensor.position_m")
    if "rotation_matrix" in sensor:
        rotation = np.asarray(sensor["rotation_matrix"], dtype=float)
        if rotation.shape != (3, 3) or not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6):
            raise BadInputError(path, "field 'sensor.rotation_matrix' must be a 3x3 rotation matrix")
    else:
        rpy = _vector(sensor.get("rotation_rpy_deg", [0, 0, 0]), 3, path, "sensor.rotation_rpy_deg")
        rotation = Rotation.from_euler("xyz", rpy, degrees=True).as_matrix()
    columns = data.get("columns", {}) or {}
    if not isinstance(columns, dict):
        raise BadInputError(path, "field 'columns' must map canonical names to recording column names")
    reject_unknown(columns, set(CANONICAL_COLUMNS), path, "columns.")
    units = data.get("units", {}) or {}
    reject_unknown(units, set(UNIT_TABLES), path, "units.")
    for key, unit in units.items():
        if unit not in UNIT_TABLES[key]:
            raise BadInputError(path, f"unknown unit '{unit}' in 'units.{key}' (known: {', '.join(UNIT_TABLES[key])})")
    return ToolConfig(
        name=str(require(data, "name", path, str)),
        sensor_position=position,
        sensor_rotation=rotation,
        columns={str(k): str(v) for k, v in columns.items()},
        ignore_columns=tuple(str(c) for c in data.get("ignore_columns", []) or []),
        units={str(k): str(v) for k, v in units.items()},
        frame_id=str(sensor.get("frame_id", "") or ""),
    )


def _vector(value, n: int, path: Path, name: str) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        array = np.empty(0)
    if array.shape != (n,) or not np.all(np.isfinite(array)):
        raise BadInputError(path, f"field '{name}' must be a list of {n} finite numbers, got {value!r}")
    return array
