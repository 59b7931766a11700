"""Tool configs: where the force/torque sensor sits on the tool, and how its recordings are laid out.

A tool config is a YAML file named by a manifest's ``tool`` column::

    name: wrist_sensor
    sensor:                      # pose of the sensor frame in the object frame
      position_m: [0.0, 0.0, -0.105]
      rotation_rpy_deg: [180, 0, 30]   # fixed-axis roll (x), pitch (y), yaw (z), applied in that order
      frame_id: ft_sensor        # optional: the header frame_id of the sensor's ROS messages, checked
    columns: {t: time_ms, fx: Fx}      # optional: recording column name for each canonical column
    ignore_columns: [status]           # optional: recording columns to drop, or `rest` for all not mapped
    rate_hz: 1000                      # optional: the sample rate, for files without a time column
    matlab: {variable: ft, samples: rows, wrench: [2, 3, 4, 5, 6, 7], time: 1}   # optional: .mat layout
    matlab: {variable: "rawdata_FT{*}.Tool_FT", period_s: dt}   # or: every cell a trial, the period a variable
    units: {torque_unit: N.cm, time_unit: ms}   # optional defaults; the manifest's columns win
    plausible: {force_n: 500, torque_nm: 20, min_duration_s: 1}   # optional: what fit-task says is implausible
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, Strict
from pydantic.dataclasses import dataclass as schema
from scipy.spatial.transform import Rotation

from grasptask.io.config_schema import SCHEMA, NonNegative, Positive, Text, Vector, load_yaml, validated
from grasptask.task.recordings import CANONICAL_COLUMNS, REST, Layout
from grasptask.task.units import UNIT_TABLES

Channel = Annotated[int, Strict(), Field(ge=1)]


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
class MatlabFile:
    """Where a MATLAB file keeps the samples: one matrix, how it lies, and which of its channels are which."""

    #: the matrix of samples (a struct's field as ``data.ft``); the manifest's ``variable`` column overrides it
    variable: Text | None = None
    #: rows: one sample a row (n x k); columns: one sample a column (k x n); none: the longer axis
    samples: Literal["rows", "columns"] | None = None
    #: its channels holding fx, fy, fz, tx, ty, tz, counted from 1
    wrench: tuple[Channel, Channel, Channel, Channel, Channel, Channel] = (1, 2, 3, 4, 5, 6)
    #: its channel holding time (from 1), or the name of a time vector; none: a rate gives the time
    time: Channel | Text | None = None
    #: the sample rate (Hz) or period (s), as a number or as the variable that holds it (``fs``, ``proc_data{*}.dt``)
    rate_hz: Positive | Text | None = None
    period_s: Positive | Text | None = None

    def __post_init__(self) -> None:
        if len(set(self.wrench)) < 6:
            raise ValueError("matlab.wrench names a channel twice")
        if isinstance(self.time, int) and self.time in self.wrench:
            raise ValueError(f"matlab.time is channel {self.time}, which matlab.wrench holds too")
        if self.rate_hz is not None and self.period_s is not None:
            raise ValueError("matlab.rate_hz and matlab.period_s both give the sample rate: give one")
        if self.time is not None and (self.rate_hz is not None or self.period_s is not None):
            raise ValueError("matlab.time and a sample rate both give the time: give one")


@schema(frozen=True, config=SCHEMA)
class PlausibleFile:
    """What a hand-held tool plausibly measures: fit-task says where a recording goes beyond it (a probable unit
    error) or is too short to hold a task. The defaults leave room above what a person's hand does: it pushes,
    pulls and grips with at most a few hundred newtons and turns with at most about 10-15 N.m (NASA-STD-3000,
    Man-Systems Integration Standards, vol. I, strength data). A robot's tool may need more."""

    force_n: Positive = 500.0
    torque_nm: Positive = 20.0
    min_duration_s: NonNegative = 1.0


@schema(frozen=True, config=SCHEMA)
class ToolFile:
    """A tool config file's schema."""

    name: Text
    description: str = ""
    sensor: SensorFile = SensorFile()
    columns: ColumnsFile = ColumnsFile()
    #: recording columns to drop, or ``rest``: every column that ``columns`` does not map
    ignore_columns: list[Text] | Literal["rest"] = field(default_factory=list)
    #: the sample rate (Hz) of files without a time column; the manifest's ``rate_hz`` column overrides it
    rate_hz: Positive | None = None
    matlab: MatlabFile = MatlabFile()
    units: UnitsFile = UnitsFile()
    plausible: PlausibleFile = PlausibleFile()

    def __post_init__(self) -> None:
        if self.rate_hz is not None and (self.matlab.rate_hz is not None or self.matlab.period_s is not None):
            raise ValueError("rate_hz and matlab's rate both give the sample rate: give one")


@dataclass(frozen=True)
class ToolConfig:
    name: str
    sensor_position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    sensor_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    #: where its files keep time and wrench
    layout: Layout = Layout()
    units: dict[str, str] = field(default_factory=dict)
    #: the frame_id the sensor's ROS WrenchStamped messages carry ("": not checked)
    frame_id: str = ""
    plausible: PlausibleFile = PlausibleFile()


def load_tool(path: str | Path) -> ToolConfig:
    path = Path(path)
    tool = validated(ToolFile, load_yaml(path), path)
    columns = {name: getattr(tool.columns, name) for name in CANONICAL_COLUMNS}
    units = {key: getattr(tool.units, key) for key in UNIT_TABLES}
    rate, period = tool.matlab.rate_hz, tool.matlab.period_s
    numeric = rate if not isinstance(rate, str) else None
    numeric = 1.0 / period if period is not None and not isinstance(period, str) else numeric
    layout = Layout(
        columns={k: v for k, v in columns.items() if v is not None},
        ignore=REST if tool.ignore_columns == REST else tuple(tool.ignore_columns),
        rate_hz=tool.rate_hz or numeric,
        variable=tool.matlab.variable,
        samples=tool.matlab.samples,
        wrench=tuple(tool.matlab.wrench),
        time=tool.matlab.time,
        rate_from=rate if isinstance(rate, str) else None,
        period_from=period if isinstance(period, str) else None,
    )
    return ToolConfig(
        name=tool.name,
        sensor_position=np.array(tool.sensor.position_m, dtype=float),
        sensor_rotation=tool.sensor.rotation(),
        layout=layout,
        units={k: v for k, v in units.items() if v is not None},
        frame_id=tool.sensor.frame_id,
        plausible=tool.plausible,
    )
