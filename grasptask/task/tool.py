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
from pydantic.dataclasses import dataclass as schema
from scipy.spatial.transform import Rotation

from grasptask.io.config_schema import SCHEMA, Text, Vector, load_yaml, validated
from grasptask.task.units import UNIT_TABLES

CANONICAL_COLUMNS = ("t", "fx", "fy", "fz", "tx", "ty", "tz")


@schema(frozen=True, config=SCHEMA)
class SensorFile:
    """The sensor frame's pose in the object frame: a position, and roll-pitch-yaw or a rotation matrix."""

    position_m: Vector = (0.0, 0.0, 0.0)
    #: fixed-axis roll (x), pitch (y), yaw (z), applied in that order
    rotation_rpy_deg: Vector = (0.0, 0.0, 0.0)
    rotation_matrix: tuple[Vector, Vector, Vector] | None = None
    #: the header frame_id of the sensor's ROS messages, checked when given
    frame_id: str = ""

    def __post_init__(self) -> None:
        if self.rotation_matrix is not None:
            rotation = np.asarray(self.rotation_matrix, dtype=float)
            if not np.allclose(rotation @ rotation.T, np.eye(3), atol=1e-6) or np.linalg.det(rotation) < 0:
                raise ValueError("rotation_matrix must be a 3x3 rotation matrix")

    def rotation(self) -> np.ndarray:
        if self.rotation_matrix is None:
            return np.asarray(Rotation.from_euler("xyz", self.rotation_rpy_deg, degrees=True).as_matrix())
        return np.asarray(self.rotation_matrix, dtype=float)


@schema(frozen=True, config=SCHEMA)
class ColumnsFile:
    """The recording's column name for each canonical column it names differently."""

    t: Text | None = None
    fx: Text | None = None
    fy: Text | None = None
    fz: Text | None = None
    tx: Text | None = None
    ty: Text | None = None
    tz: Text | None = None


@schema(frozen=True, config=SCHEMA)
class UnitsFile:
    """The recordings' units, unless the manifest's columns say otherwise."""

    force_unit: Text | None = None
    torque_unit: Text | None = None
    time_unit: Text | None = None

    def __post_init__(self) -> None:
        for key, table in UNIT_TABLES.items():
            unit = getattr(self, key)
            if unit is not None and unit not in table:
                raise ValueError(f"unknown unit '{unit}' in 'units.{key}' (known: {', '.join(table)})")


@schema(frozen=True, config=SCHEMA)
class ToolFile:
    """A tool config file's schema."""

    name: Text
    description: str = ""
    sensor: SensorFile = SensorFile()
    columns: ColumnsFile = ColumnsFile()
    #: recording columns to drop
    ignore_columns: list[Text] = field(default_factory=list)
    units: UnitsFile = UnitsFile()


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
    tool = validated(ToolFile, load_yaml(path), path)
    columns = {name: getattr(tool.columns, name) for name in CANONICAL_COLUMNS}
    units = {key: getattr(tool.units, key) for key in UNIT_TABLES}
    return ToolConfig(
        name=tool.name,
        sensor_position=np.array(tool.sensor.position_m, dtype=float),
        sensor_rotation=tool.sensor.rotation(),
        columns={k: v for k, v in columns.items() if v is not None},
        ignore_columns=tuple(tool.ignore_columns),
        units={k: v for k, v in units.items() if v is not None},
        frame_id=tool.sensor.frame_id,
    )
