"""Manifests: one CSV row per recording, naming its file, labels, frame, units and tool.

Required columns: ``path, task, subject, trial, grasp``. Optional: ``id`` (default
``<task>_<grasp>_s<subject>_t<trial>``), ``frame`` (``object`` or ``sensor``), ``force_unit``, ``torque_unit``,
``time_unit``, ``tool`` (a tool config, required for ``frame=sensor``) and ``bias_window_s`` (length of the
initial static window used for bias removal, then trimmed). Paths are relative to the manifest's folder.
A ROS bag (``.bag``, or a ROS 2 bag's folder or storage file) needs the ``topic`` of its ``WrenchStamped``
messages. Any recording may give a time window, ``start_s`` and ``end_s`` seconds after its first sample, so that
several rows cut trials from one log; ``variable`` names the matrix of a ``.mat`` file's samples (a cell's
elements as ``rawdata_FT{3}.Tool_FT``; ``{*}`` makes one recording of each element, numbered as trials from the
row's ``trial``) and ``rate_hz`` the sample rate of a file without time stamps, or the ``.mat`` file's variable
that holds it (both override the tool config's). Row numbers count data rows from 1.
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
    "variable",
    "rate_hz",
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
    #: a ROS bag's topic of WrenchStamped messages ("": the file is a CSV, Parquet or MATLAB recording)
    topic: str = ""
    #: the time window to read, seconds after the first sample (None: from the start, to the end)
    window_s: tuple[float | None, float | None] = (None, None)
    #: a .mat file's matrix of samples ("": the tool config's)
    variable: str = ""
    #: the sample rate of a file without time stamps (None: the tool config's, else the file's time column)
    rate_hz: float | None = None
    #: a .mat file's variable holding its sample rate, in place of ``rate_hz`` ("": none)
    rate_from: str = ""
    #: the element of a .mat file that its references' wildcard ({*}) stands for (None: they hold none)
    element: int | None = None

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
    bias_window = _number(row, "bias_window_s", fail) or 0.0
    recording = path.parent / row["path"].strip()
    topic = _bag_topic(row, recording, fail)
    window = _window(row, fail)
    is_mat = recording.suffix.lower() == ".mat"
    rate_text = row.get("rate_hz", "").strip()
    rate_from = rate_text if is_mat and rate_text and not _is_number(rate_text) else ""
    rate_hz = None if rate_from else _number(row, "rate_hz", fail, positive=True)
    if (rate_hz is not None or rate_from) and topic:
        raise fail("rate_hz", "a ROS bag's times are its messages' stamps; leave rate_hz empty")
    variable = row.get("variable", "").strip()
    if variable and not is_mat:
        raise fail("variable", f"only a MATLAB file has variables; {recording.name} is not one")
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
        variable=variable,
        rate_hz=rate_hz,
        rate_from=rate_from,
    )


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _number(row: dict[str, str], name: str, fail, positive: bool = False) -> float | None:
    """A row's optional number of seconds (``>= 0``) or rate (``> 0``); None where the cell is empty."""
    text = row.get(name, "").strip()
    if not text:
        return None
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not np.isfinite(value) or value < 0 or (positive and value == 0):
        what = "a positive number (Hz)" if positive else "a non-negative number of seconds"
        raise fail(name, f"must be {what}, got {text!r}")
    return value


def _window(row: dict[str, str], fail) -> tuple[float | None, float | None]:
    """The row's time window, seconds after the recording's first sample."""
    start, end = _number(row, "start_s", fail), _number(row, "end_s", fail)
    if start is not None and end is not None and end <= start:
        raise fail("end_s", f"the window ends ({end} s) before it starts ({start} s)")
    return start, end


def _bag_topic(row: dict[str, str], recording: Path, fail) -> str:
    """A bag row's topic, checked; a recording that is not a bag has none."""
    topic = row.get("topic", "").strip()
    if not is_bag(recording):
        if topic:
            raise fail("topic", f"only a ROS bag has a topic; {recording.name} is not one")
        return ""
    if not topic:
        raise fail("topic", f"{recording.name} is a ROS bag: name the topic of its WrenchStamped messages")
    if row.get("time_unit", "").strip():
        raise fail("time_unit", "a ROS bag's times are its messages' stamps, in seconds; leave time_unit empty")
    return topic
