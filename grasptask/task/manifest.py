"""Manifests: one CSV row per recording, naming its file, labels, frame, units and tool.

Required columns: ``path, task, subject, trial, grasp``. Optional: ``id`` (default
``<task>_<grasp>_s<subject>_t<trial>``), ``frame`` (``object`` or ``sensor``), ``force_unit``, ``torque_unit``,
``time_unit``, ``tool`` (a tool config, required for ``frame=sensor``) and ``bias_window_s`` (length of the
initial static window used for bias removal, then trimmed). Paths are relative to the manifest's folder.
A ROS bag (``.bag``, or a ROS 2 bag's folder or storage file) needs the ``topic`` of its ``WrenchStamped``
messages, and may give a time window, ``start_s`` and ``end_s`` seconds after the topic's first message.
Row numbers count data rows from 1.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from grasptask.errors import BadInputError, existing_file
from grasptask.io.csv_format import header, sniff
from grasptask.task.rosbag import is_bag
from grasptask.task.units import UNIT_TABLES

REQUIRED = ("path", "task", "subject", "trial", "grasp")
OPTIONAL = (
    "id",
    "frame",
    "force_unit",
    "torque_unit",
    "time_unit",
    "tool",
    "bias_window_s",
    "topic",
    "start_s",
    "end_s",
)
FRAMES = ("object", "sensor")


@dataclass(frozen=True)
class RecordingEntry:
    """One recording and how to read it."""

    id: str
    path: Path
    task: str
    subject: str
    trial: int
    grasp: str
    frame: str = "object"
    units: dict[str, str] = field(default_factory=dict)
    tool: Path | None = None
    bias_window_s: float = 0.0
    source: str = ""  # "<manifest>: row N", for messages
    #: a ROS bag's topic of WrenchStamped messages ("": the file is a CSV or Parquet recording) ...
    topic: str = ""
    #: ... and the time window to read, seconds after the topic's first message (None: from the start, to the end)
    window_s: tuple[float | None, float | None] = (None, None)

    @property
    def group(self) -> str:
        """Statistics group: ``<task>_<grasp>`` when the grasp was imposed, ``<task>`` when it was free."""
        return self.task if self.grasp == "free" else f"{self.task}_{self.grasp}"


def default_id(task: str, grasp: str, subject: str, trial: int) -> str:
    return f"{task}_{grasp}_s{subject}_t{trial}"


def is_manifest(path: str | Path) -> bool:
    """A CSV whose header has a ``path`` column is a manifest, not a recording."""
    path = Path(path)
    if path.suffix.lower() != ".csv" or not path.is_file():
        return False
    return "path" in header(path)


def read_manifest(path: str | Path) -> list[RecordingEntry]:
    path = existing_file(path, "manifest")
    try:
        options = sniff(path).read_csv_options()
        frame = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True, **options)
    except pd.errors.EmptyDataError:
        raise BadInputError(path, "empty manifest") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise BadInputError(path, f"not a readable CSV ({type(exc).__name__})") from None
    frame.columns = [c.strip() for c in frame.columns]
    for name in REQUIRED:
        if name not in frame.columns:
            raise BadInputError(path, "missing column", column=name)
    for name in frame.columns:
        if name not in REQUIRED + OPTIONAL:
            raise BadInputError(path, f"unexpected column (allowed: {', '.join(REQUIRED + OPTIONAL)})", column=name)
    if frame.empty:
        raise BadInputError(path, "manifest lists no recordings")
    entries: list[RecordingEntry] = []
    seen: dict[str, int] = {}
    for index, row in enumerate(frame.to_dict("records"), start=1):
        entry = _entry(path, index, row)
        if entry.id in seen:
            raise BadInputError(path, f"duplicate recording id '{entry.id}' (first at row {seen[entry.id]})", row=index)
        seen[entry.id] = index
        entries.append(entry)
    return entries


def _entry(path: Path, row_number: int, row: dict[str, str]) -> RecordingEntry:
    def fail(column: str, problem: str) -> BadInputError:
        return BadInputError(path, problem, row=row_number, column=column)

    for name in REQUIRED:
        if not row[name].strip():
            raise fail(name, "empty value")
    try:
        trial = int(row["trial"])
    except ValueError:
        raise fail("trial", f"trial must be an integer, got {row['trial']!r}") from None
    frame = row.get("frame", "").strip() or "object"
    if frame not in FRAMES:
        raise fail("frame", f"unknown frame '{frame}' (known: {', '.join(FRAMES)})")
    units = {}
    for key, table in UNIT_TABLES.items():
        unit = row.get(key, "").strip()
        if unit:
            if unit not in table:
                raise fail(key, f"unknown unit '{unit}' (known: {', '.join(table)})")
            units[key] = unit
    tool = row.get("tool", "").strip()
    tool_path = (path.parent / tool) if tool else None
    if frame == "sensor" and tool_path is None:
        raise fail("tool", "frame is 'sensor' but no tool config names the sensor pose")
    if tool_path is not None and not tool_path.is_file():
        raise fail("tool", f"tool config not found: {tool_path}")
    bias = row.get("bias_window_s", "").strip()
    try:
        bias_window = float(bias) if bias else 0.0
    except ValueError:
        bias_window = -1.0
    if not np.isfinite(bias_window) or bias_window < 0:
        raise fail("bias_window_s", f"must be a non-negative number of seconds, got {bias!r}")
    recording = path.parent / row["path"].strip()
    topic, window = _bag_fields(row, recording, fail)
    task, grasp, subject = row["task"].strip(), row["grasp"].strip(), row["subject"].strip()
    return RecordingEntry(
        id=row.get("id", "").strip() or default_id(task, grasp, subject, trial),
        path=recording,
        task=task,
        subject=subject,
        trial=trial,
        grasp=grasp,
        frame=frame,
        units=units,
        tool=tool_path,
        bias_window_s=bias_window,
        source=f"{path}: row {row_number}",
        topic=topic,
        window_s=window,
    )


def _bag_fields(row: dict[str, str], recording: Path, fail) -> tuple[str, tuple[float | None, float | None]]:
    """A bag row's topic and time window, checked; a recording that is not a bag may have neither."""
    topic = row.get("topic", "").strip()
    bounds: list[float | None] = []
    for name in ("start_s", "end_s"):
        text = row.get(name, "").strip()
        try:
            value = float(text) if text else None
        except ValueError:
            value = -1.0
        if value is not None and (not np.isfinite(value) or value < 0):
            raise fail(name, f"must be a non-negative number of seconds, got {text!r}")
        bounds.append(value)
    if not is_bag(recording):
        for name in ("topic", "start_s", "end_s"):
            if row.get(name, "").strip():
                raise fail(name, f"only a ROS bag has a {name}; {recording.name} is not one")
        return "", (None, None)
    if not topic:
        raise fail("topic", f"{recording.name} is a ROS bag: name the topic of its WrenchStamped messages")
    if row.get("time_unit", "").strip():
        raise fail("time_unit", "a ROS bag's times are its messages' stamps, in seconds; leave time_unit empty")
    start, end = bounds
    if start is not None and end is not None and end <= start:
        raise fail("end_s", f"the window ends ({end} s) before it starts ({start} s)")
    return topic, (start, end)
