"""From manifest entries to one 6D ellipsoid per recording, in SI units and the object frame."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from grasptask.errors import BadInputError
from grasptask.io.tables import read_table
from grasptask.task import preprocess
from grasptask.task import recording_checks as checks
from grasptask.task.ellipsoid import Ellipsoid, ellipsoid_matrices, is_singular, second_moment
from grasptask.task.frames import transform_wrenches
from grasptask.task.manifest import RecordingEntry, default_id
from grasptask.task.matlab import MAT_SUFFIX
from grasptask.task.recording_checks import Finding
from grasptask.task.recordings import MIN_SAMPLES, Layout, mat_elements, read_recording, window_mask
from grasptask.task.rosbag import read_wrench_bag
from grasptask.task.spd import spd_problem
from grasptask.task.tool import ToolConfig, load_tool
from grasptask.task.units import UNIT_TABLES


@dataclass(frozen=True)
class FitOptions:
    preprocess: preprocess.Preprocess = field(default_factory=preprocess.Preprocess)
    centered: bool = False


@dataclass(frozen=True)
class Samples:
    """A recording as fitted: time (s) and ``(n, 6)`` wrenches (N, N.m) in the object frame, preprocessed, and
    what the checks found in it (the offset's, a check of the fitted second moment, only from :func:`fit_entry`)."""

    t: np.ndarray
    wrenches: np.ndarray
    findings: list[Finding] = field(default_factory=list)


def load_wrenches(entry: RecordingEntry, tool: ToolConfig | None = None, options: FitOptions = FitOptions()) -> Samples:
    """The entry's samples in SI units and the object frame, cut to its window, checked and preprocessed."""
    tool = tool or ToolConfig(name="none")
    layout = entry_layout(entry, tool)
    data = _read_samples(entry, tool, layout)
    units = {**tool.units, **entry.units}
    factor = {key: table[units.get(key, next(iter(table)))] for key, table in UNIT_TABLES.items()}
    t, wrenches = data[:, 0], data[:, 1:]
    if factor["time_unit"] != 1.0 and not layout.rated:
        t = t * factor["time_unit"]
    if factor["force_unit"] != 1.0 or factor["torque_unit"] != 1.0:
        wrenches = wrenches * np.repeat([factor["force_unit"], factor["torque_unit"]], 3)
    if entry.frame == "sensor":
        wrenches = transform_wrenches(wrenches, tool.sensor_rotation, tool.sensor_position)
    rows = np.arange(1, len(t) + 1)
    if not entry.topic and entry.window_s != (None, None):  # a bag's own reader cuts its window
        keep = window_mask(entry.source or entry.path, t, *entry.window_s)
        t, wrenches, rows = t[keep], wrenches[keep], rows[keep]
        if len(t) < MIN_SAMPLES:
            raise BadInputError(
                entry.source or entry.path, f"only {len(t)} samples in its time window (at least {MIN_SAMPLES})"
            )
    steps = options.preprocess
    bounds = checks.extremes(wrenches)
    spiky = checks.spike_rows(wrenches, bounds)
    findings = [
        checks.uneven_sampling(t, steps.resample_hz, steps.lowpass_hz),
        checks.too_short(t, tool.plausible.min_duration_s),
        checks.implausible(
            wrenches[~spiky] if spiky.any() else wrenches,
            tool.plausible.force_n,
            tool.plausible.torque_nm,
            None if spiky.any() else bounds,
        ),
        checks.spikes(wrenches, spiky, rows, steps.drop_spikes),
    ]
    if steps.drop_spikes and spiky.any():
        t, wrenches = t[~spiky], wrenches[~spiky]
    try:
        t, wrenches = preprocess.apply(t, wrenches, steps, entry.bias_window_s)
    except ValueError as exc:
        raise BadInputError(entry.path, str(exc)) from exc
    if len(t) < MIN_SAMPLES:
        raise BadInputError(entry.path, f"only {len(t)} samples left after preprocessing (at least {MIN_SAMPLES})")
    return Samples(t, wrenches, [f for f in findings if f is not None])


def entry_layout(entry: RecordingEntry, tool: ToolConfig) -> Layout:
    """The tool's layout as the entry's row overrides it (its variable, its rate) for its element."""
    layout = replace(tool.layout, variable=entry.variable or tool.layout.variable, element=entry.element)
    if entry.rate_hz:
        return replace(layout, rate_hz=entry.rate_hz, rate_from=None, period_from=None)
    if entry.rate_from:
        return replace(layout, rate_hz=None, rate_from=entry.rate_from, period_from=None)
    return layout


def expand_trials(entries: Iterable[RecordingEntry], tools: dict[Path, ToolConfig]) -> list[RecordingEntry]:
    """Each entry, or where its ``.mat`` layout reads every element of a cell or struct array (``{*}``), one
    entry per element, numbered as trials from the entry's own trial number."""
    expanded: list[RecordingEntry] = []
    for entry in entries:
        tool = entry_tool(entry, tools) or ToolConfig(name="none")
        count = None
        if not entry.topic and entry.path.suffix.lower() == MAT_SUFFIX and entry.path.is_file():
            count = mat_elements(entry.path, entry_layout(entry, tool))
        if count is None:
            expanded.append(entry)
            continue
        for k in range(1, count + 1):
            trial = entry.trial + k - 1
            given = entry.id != default_id(entry.task, entry.grasp, entry.subject, entry.trial)
            name = f"{entry.id}_{k}" if given else default_id(entry.task, entry.grasp, entry.subject, trial)
            expanded.append(replace(entry, id=name, trial=trial, element=k, source=f"{entry.source} element {k}"))
    return expanded


def _read_samples(entry: RecordingEntry, tool: ToolConfig, layout: Layout) -> np.ndarray:
    """The entry's ``(n, 7)`` samples from its CSV, Parquet or MATLAB file, or from its ROS bag's topic, whose
    frame must be the tool's sensor frame when the manifest says the wrenches are in the sensor frame."""
    if not entry.topic:
        return read_recording(entry.path, layout)

    bag = read_wrench_bag(entry.path, entry.topic, *entry.window_s)
    if entry.frame == "sensor" and tool.frame_id and bag.frame_id != tool.frame_id:
        raise BadInputError(
            f"{entry.path} (topic {entry.topic})",
            f"messages in frame '{bag.frame_id}', not the sensor frame '{tool.frame_id}' of tool '{tool.name}'",
        )
    if entry.frame == "object" and tool.frame_id and bag.frame_id == tool.frame_id:
        raise BadInputError(
            f"{entry.path} (topic {entry.topic})",
            f"messages in the sensor frame '{bag.frame_id}' of tool '{tool.name}', but the manifest says the "
            "object frame: set its frame column to 'sensor'",
        )
    return bag.data


def fit_entry(
    entry: RecordingEntry, tool: ToolConfig | None = None, options: FitOptions = FitOptions()
) -> tuple[Ellipsoid, Samples]:
    """The recording's ellipsoid, and its samples as fitted."""
    samples = load_wrenches(entry, tool, options)
    wrenches = samples.wrenches
    if not np.any(wrenches):
        raise BadInputError(entry.path, "all wrench samples are zero, so the ellipsoid is singular")
    matrix = second_moment(wrenches, options.centered)
    if is_singular(matrix):
        rank = np.linalg.matrix_rank(matrix)
        raise BadInputError(
            entry.path, f"wrench samples span only {rank} of 6 dimensions, so the ellipsoid is singular"
        )
    if not options.centered:  # the mean, against the spread that the second moment holds
        found = checks.offset(wrenches.mean(axis=0), np.diag(matrix))
        samples = replace(samples, findings=samples.findings + ([found] if found else []))
    return Ellipsoid.from_matrix(matrix), samples


@dataclass
class FitResult:
    """The ellipsoids (a row per recording), the recordings set aside, and what the checks said of the rest:
    one dict per finding, with the recording's id and file (:meth:`Finding`'s check, message and figures)."""

    ellipsoids: pd.DataFrame
    skipped: list[BadInputError]
    findings: list[dict] = field(default_factory=list)

    @property
    def matrices(self) -> np.ndarray:
        return ellipsoid_matrices(self.ellipsoids)


def entry_tool(entry: RecordingEntry, cache: dict[Path, ToolConfig]) -> ToolConfig | None:
    """The entry's tool config, read once per file into ``cache``; None when the entry names none."""
    if entry.tool is None:
        return None
    if entry.tool not in cache:
        cache[entry.tool] = load_tool(entry.tool)
    return cache[entry.tool]


def fit_recordings(
    entries: Iterable[RecordingEntry],
    options: FitOptions = FitOptions(),
    skip_bad: bool = False,
    progress: Callable[[Iterable], Iterable] = iter,
) -> FitResult:
    """Fit every recording; with ``skip_bad`` a bad recording is set aside instead of stopping the run."""
    tools: dict[Path, ToolConfig] = {}
    rows: list[dict] = []
    skipped: list[BadInputError] = []
    findings: list[dict] = []
    seen: dict[str, str] = {}
    for row in progress(list(entries)):
        try:
            parts = expand_trials([row], tools)
        except BadInputError as exc:
            if not skip_bad:
                raise
            skipped.append(exc)
            continue
        for entry in parts:
            if entry.id in seen:
                raise BadInputError(entry.source, f"recording id '{entry.id}' again (first from {seen[entry.id]})")
            seen[entry.id] = entry.source
            try:
                tool = entry_tool(entry, tools)
                ellipsoid, samples = fit_entry(entry, tool, options)
            except BadInputError as exc:
                if not skip_bad:
                    raise
                skipped.append(exc)
                continue
            findings += [
                {"id": entry.id, "file": str(entry.path), "check": f.check, "message": f.message, "figures": f.figures}
                for f in samples.findings
            ]
            rows.append(_ellipsoid_row(entry, ellipsoid, samples))
    if not rows and skipped:  # the first one's own line says what is wrong, the count how widespread it is
        first = skipped[0]
        raise BadInputError(
            first.source,
            f"{first.problem}; none of the {len(skipped)} recordings is usable (this is the first)",
            row=first.row,
            column=first.column,
        )
    if not rows:
        raise BadInputError("fit-task", "no recordings to fit")
    return FitResult(pd.DataFrame(rows), skipped, findings)


def _ellipsoid_row(entry: RecordingEntry, ellipsoid: Ellipsoid, samples: Samples) -> dict:
    return {
        "id": entry.id,
        "task": entry.task,
        "grasp": entry.grasp,
        "group": entry.group,
        "subject": entry.subject,
        "trial": entry.trial,
        "path": str(entry.path),
        "n_samples": len(samples.t),
        "duration_s": float(samples.t[-1] - samples.t[0]),
        "S": ellipsoid.S.ravel(),
        "axes": ellipsoid.axes.ravel(),
        "lengths": ellipsoid.lengths,
    }


def read_ellipsoids(path: str | Path) -> pd.DataFrame:
    """Read ``ellipsoids.parquet``, checking it has what later stages need."""
    path = Path(path)
    frame = read_table(path, ("id", "task", "group", "S"))
    if frame.empty:
        raise BadInputError(path, "no ellipsoids")
    repeated = frame["id"].astype(str).duplicated().to_numpy()
    if repeated.any():
        row = int(repeated.argmax()) + 1
        raise BadInputError(path, f"duplicate id {frame['id'].iloc[row - 1]!r}", row=row, column="id")
    for row, s in enumerate(frame["S"], start=1):
        try:
            matrix = np.asarray(s, dtype=float).reshape(6, 6)
        except (TypeError, ValueError):
            raise BadInputError(path, "S must hold 36 numbers", row=row, column="S") from None
        problem = spd_problem(matrix)
        if problem:
            raise BadInputError(path, f"S {problem}", row=row, column="S")
    return frame
