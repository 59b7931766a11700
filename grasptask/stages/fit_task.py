"""``grasptask fit-task``: a 6D ellipsoid per recording, a Log-Euclidean mean model per task, and the paper's
Tables 1-10 recomputed."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict
from functools import partial
from pathlib import Path

import pandas as pd

from grasptask.errors import BadInputError
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.io.locking import check_writable, folder_lock
from grasptask.progress import progress
from grasptask.task.fit import FitOptions, FitResult, fit_recordings
from grasptask.task.manifest import RecordingEntry, default_id, is_manifest, read_manifest
from grasptask.task.preprocess import Preprocess
from grasptask.task.rosbag import is_bag
from grasptask.task.stats import statistics_table
from grasptask.task.task_model import task_models_payload

__all__ = ["FitOptions", "Preprocess", "entries_from_inputs", "run_fit_task"]


def entries_from_inputs(inputs: Sequence[str | Path], **labels) -> list[RecordingEntry]:
    """A manifest's entries, or one entry per recording file labelled by ``labels``."""
    paths = [Path(p) for p in inputs]
    if not paths:
        raise BadInputError("fit-task", "give a manifest or at least one recording file")
    if len(paths) == 1 and is_manifest(paths[0]):
        return read_manifest(paths[0])
    for path in paths:
        if is_manifest(path):
            raise BadInputError(path, "a manifest must be the only input")
        if is_bag(path):
            raise BadInputError(path, "a ROS bag is read through a manifest row that names its topic (README)")
    task, grasp = labels.get("task", "unlabelled"), labels.get("grasp", "free")
    entries = []
    for trial, path in enumerate(paths, start=1):
        subject = labels.get("subject") or path.stem
        entries.append(
            RecordingEntry(
                id=default_id(task, grasp, subject, trial) if labels.get("subject") else path.stem,
                path=path,
                task=task,
                subject=subject,
                trial=trial,
                grasp=grasp,
                frame=labels.get("frame", "object"),
                units={k: v for k, v in labels.get("units", {}).items() if v},
                tool=Path(labels["tool"]) if labels.get("tool") else None,
                source=str(path),
            )
        )
    if len({e.id for e in entries}) < len(entries):
        raise BadInputError("fit-task", "two input files share a name; use a manifest to give them ids")
    if any(e.frame == "sensor" and e.tool is None for e in entries):
        raise BadInputError("fit-task", "--frame sensor needs --tool naming the sensor pose")
    return entries


def run_fit_task(
    inputs: Sequence[str | Path],
    out: str | Path,
    options: FitOptions = FitOptions(),
    skip_bad: bool = False,
    **labels,
) -> tuple[FitResult, pd.DataFrame]:
    """Fit ellipsoids and write ``ellipsoids.parquet``, ``task_models.json`` and ``stats.csv``."""
    entries = entries_from_inputs(inputs, **labels)
    # --out held, and known to be writable, from the start: a second run into it is refused, not overwritten
    with folder_lock(out, "fit-task"):
        check_writable(out)
        return _fit_and_write(entries, inputs, out, options, skip_bad, labels)


def _fit_and_write(
    entries: list[RecordingEntry],
    inputs: Sequence[str | Path],
    out: str | Path,
    options: FitOptions,
    skip_bad: bool,
    labels: dict,
) -> tuple[FitResult, pd.DataFrame]:
    result = fit_recordings(entries, options, skip_bad, partial(progress, desc="fit-task", unit="rec"))
    stats = statistics_table(result.ellipsoids)
    recorded = [e.path for e in entries if e.path.is_file()]
    recorded += [f for e in entries if e.path.is_dir() for f in sorted(e.path.iterdir()) if f.is_file()]  # ROS 2
    hashed = recorded + list(dict.fromkeys(e.tool for e in entries if e.tool))
    config = {"options": asdict(options), "skip_bad": skip_bad, "labels": labels}
    with StagedOutput(out, Provenance.of("fit-task", config, [*map(Path, inputs), *hashed])) as staged:
        staged.write_parquet("ellipsoids.parquet", result.ellipsoids)
        staged.write_json("task_models.json", task_models_payload(result.ellipsoids))
        staged.write_csv("stats.csv", stats)
    return result, stats
