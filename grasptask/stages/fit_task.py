"""``grasptask fit-task``: a 6D ellipsoid per recording, a Log-Euclidean mean model per task, and the paper's
Tables 1-10 recomputed."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import pandas as pd

from grasptask.errors import BadInputError
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.io.locking import check_writable, folder_lock
from grasptask.paths import as_paths
from grasptask.progress import progress
from grasptask.task.fit import FitOptions, fit_recordings
from grasptask.task.manifest import RecordingEntry, is_manifest, read_manifest
from grasptask.task.preprocess import Preprocess
from grasptask.task.rosbag import is_bag
from grasptask.task.stats import statistics_table
from grasptask.task.task_model import task_models_payload
from grasptask.task.units import FORCE_UNITS, TIME_UNITS, TORQUE_UNITS

__all__ = ["FitOptions", "FitSummary", "FitTaskOptions", "Preprocess", "run_fit_task"]

FRAMES = ("object", "sensor")


@dataclass(frozen=True, kw_only=True)
class FitTaskOptions:
    """What to fit: a manifest CSV, or recording files that share the labels below (their task, grasp, frame,
    tool and units); where to write; how to preprocess and fit (:class:`FitOptions`); and whether a bad
    recording is set aside (``skip_bad``) rather than stopping the fit."""

    inputs: tuple[Path, ...]
    out: Path
    fit: FitOptions = field(default_factory=FitOptions)
    skip_bad: bool = False
    task: str = "unlabelled"
    grasp: str = "free"
    frame: str = "object"
    tool: Path | None = None
    torque_unit: str | None = None
    force_unit: str | None = None
    time_unit: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "inputs", tuple(Path(p) for p in self.inputs))
        as_paths(self, "out", optional=("tool",))
        if not self.inputs:
            raise BadInputError("fit-task", "give a manifest or at least one recording file")
        if self.frame not in FRAMES:
            raise BadInputError("fit-task", f"unknown frame '{self.frame}' (known: {', '.join(FRAMES)})")
        for name, known in (("torque_unit", TORQUE_UNITS), ("force_unit", FORCE_UNITS), ("time_unit", TIME_UNITS)):
            unit = getattr(self, name)
            if unit is not None and unit not in known:
                raise BadInputError(
                    "fit-task", f"unknown {name.replace('_', ' ')} '{unit}' (known: {', '.join(known)})"
                )

    @property
    def labels(self) -> dict[str, Any]:
        """What plain recording files are labelled with (a manifest's rows say it themselves)."""
        units = {"torque_unit": self.torque_unit, "force_unit": self.force_unit, "time_unit": self.time_unit}
        return {"task": self.task, "grasp": self.grasp, "frame": self.frame, "tool": self.tool, "units": units}


@dataclass(frozen=True)
class FitSummary:
    """The ellipsoids fitted (one row per recording), the paper's Tables 1-10 in long form, the recordings set
    aside, what the checks said of the others (uneven sampling, short, implausible, spikes, offset: one dict
    each, as ``task_models.json`` holds them) and where they were written."""

    out: Path
    ellipsoids: pd.DataFrame
    stats: pd.DataFrame
    skipped: list[BadInputError]
    findings: list[dict] = field(default_factory=list)


def _entries(options: FitTaskOptions) -> list[RecordingEntry]:
    """A manifest's entries, or one entry per recording file, labelled by the options."""
    paths = list(options.inputs)
    if len(paths) == 1 and is_manifest(paths[0]):
        return read_manifest(paths[0])
    for path in paths:
        if is_manifest(path):
            raise BadInputError(path, "a manifest must be the only input")
        if is_bag(path):
            raise BadInputError(path, "a ROS bag is read through a manifest row that names its topic (README)")
    units = {k: v for k, v in options.labels["units"].items() if v}
    entries = [
        RecordingEntry(id=path.stem, path=path, task=options.task, subject=path.stem, trial=trial,
                       grasp=options.grasp, frame=options.frame, units=units, tool=options.tool, source=str(path))
        for trial, path in enumerate(paths, start=1)
    ]  # fmt: skip
    if len({e.id for e in entries}) < len(entries):
        raise BadInputError("fit-task", "two input files share a name; use a manifest to give them ids")
    if any(e.frame == "sensor" and e.tool is None for e in entries):
        raise BadInputError("fit-task", "--frame sensor needs --tool naming the sensor pose")
    return entries


def run_fit_task(options: FitTaskOptions) -> FitSummary:
    """Fit ellipsoids and write ``ellipsoids.parquet``, ``task_models.json`` and ``stats.csv``."""
    entries = _entries(options)
    # --out held, and known to be writable, from the start: a second run into it is refused, not overwritten
    with folder_lock(options.out, "fit-task"):
        check_writable(options.out)
        return _fit_and_write(entries, options)


def _fit_and_write(entries: list[RecordingEntry], options: FitTaskOptions) -> FitSummary:
    result = fit_recordings(entries, options.fit, options.skip_bad, partial(progress, desc="fit-task", unit="rec"))
    stats = statistics_table(result.ellipsoids)
    recorded = [e.path for e in entries if e.path.is_file()]
    recorded += [f for e in entries if e.path.is_dir() for f in sorted(e.path.iterdir()) if f.is_file()]  # ROS 2
    hashed = recorded + list(dict.fromkeys(e.tool for e in entries if e.tool))
    labels = {**options.labels, "tool": str(options.tool) if options.tool else None}
    config = {"options": asdict(options.fit), "skip_bad": options.skip_bad, "labels": labels}
    with StagedOutput(options.out, Provenance.of("fit-task", config, [*options.inputs, *hashed])) as staged:
        staged.write_parquet("ellipsoids.parquet", result.ellipsoids)
        staged.write_json("task_models.json", task_models_payload(result.ellipsoids, result.findings))
        staged.write_csv("stats.csv", stats)
    return FitSummary(options.out, result.ellipsoids, stats, result.skipped, result.findings)
