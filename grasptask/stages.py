"""The pipeline's task-modelling stages as functions: inputs and options in, artifacts on disk, a summary out.

The CLI is a thin layer over these; a notebook can call them directly, or the lower-level functions in
:mod:`grasptask.task` that work on arrays and tables without touching the disk.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict
from functools import partial
from pathlib import Path

import pandas as pd

from grasptask.errors import BadInputError
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.io.manifest import RecordingEntry, default_id, is_manifest, read_manifest
from grasptask.io.recordings import write_recording
from grasptask.progress import progress
from grasptask.report.distance_plots import plot_embedding, plot_heatmap
from grasptask.task import simulate as sim
from grasptask.task.distances import compute_distances
from grasptask.task.fit import FitOptions, FitResult, fit_recordings, read_ellipsoids
from grasptask.task.model import task_models_payload
from grasptask.task.stats import statistics_table

FORMATS = {"csv": ".csv", "parquet": ".parquet"}


def run_simulate(config_path: str | Path, out: str | Path, seed: int = 0, fmt: str = "csv") -> dict:
    """Write the simulated protocol's recordings, the tool config and ``manifest.csv`` under ``out``."""
    config = sim.load_config(config_path)
    suffix = FORMATS[fmt]
    provenance = Provenance.of("simulate", {"config": config, "format": fmt}, [config_path], seed)
    rows = []
    with StagedOutput(out, provenance) as staged:
        staged.write_with("sensorized_tool.yaml", lambda p: p.write_text(sim.tool_yaml(config)))
        for trial, samples, in_sensor in sim.simulate(config, seed, partial(progress, desc="simulate", unit="rec")):
            rec_id = default_id(trial.task, trial.grasp, str(trial.subject), trial.trial)
            name = f"recordings/{rec_id}{suffix}"
            write_recording(staged.path(name), samples)
            rows.append(
                {
                    "path": name,
                    "task": trial.task,
                    "subject": trial.subject,
                    "trial": trial.trial,
                    "grasp": trial.grasp,
                    "id": rec_id,
                    "frame": "sensor" if in_sensor else "object",
                    "torque_unit": "N.m",
                    "tool": "sensorized_tool.yaml",
                    "bias_window_s": config["sensor"]["static_s"],
                }
            )
        staged.write_csv("manifest.csv", pd.DataFrame(rows))
    return {"recordings": len(rows), "out": str(out), "manifest": str(Path(out) / "manifest.csv")}


def entries_from_inputs(inputs: Sequence[str | Path], **labels) -> list[RecordingEntry]:
    """A manifest's entries, or one entry per recording file labelled by ``labels``."""
    inputs = [Path(p) for p in inputs]
    if not inputs:
        raise BadInputError("fit-task", "give a manifest or at least one recording file")
    if len(inputs) == 1 and is_manifest(inputs[0]):
        return read_manifest(inputs[0])
    for path in inputs:
        if is_manifest(path):
            raise BadInputError(path, "a manifest must be the only input")
    task, grasp = labels.get("task", "unlabelled"), labels.get("grasp", "free")
    entries = []
    for trial, path in enumerate(inputs, start=1):
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
    result = fit_recordings(entries, options, skip_bad, partial(progress, desc="fit-task", unit="rec"))
    stats = statistics_table(result.ellipsoids)
    hashed = [e.path for e in entries if e.path.is_file()] + list(dict.fromkeys(e.tool for e in entries if e.tool))
    config = {"options": asdict(options), "skip_bad": skip_bad, "labels": labels}
    with StagedOutput(out, Provenance.of("fit-task", config, [*map(Path, inputs), *hashed])) as staged:
        staged.write_parquet("ellipsoids.parquet", result.ellipsoids)
        staged.write_json("task_models.json", task_models_payload(result.ellipsoids))
        staged.write_csv("stats.csv", stats)
    return result, stats


def run_distances(ellipsoids_path: str | Path, out: str | Path) -> dict:
    """Write ``distances.parquet``, ``distance_summary.json`` and the heatmap and embedding PNGs."""
    ellipsoids = read_ellipsoids(ellipsoids_path)
    distances = compute_distances(ellipsoids)
    summary = distances.summary()
    with StagedOutput(out, Provenance.of("distances", {}, [ellipsoids_path])) as staged:
        # k^2 rows of floats that do not compress: no codec, dictionaries and statistics only for the ids
        staged.write_parquet(
            "distances.parquet",
            distances.long_table(),
            compression="none",
            use_dictionary=["id_a", "id_b"],
            write_statistics=["id_a", "id_b"],
        )
        staged.write_json("distance_summary.json", summary)
        staged.write_with("distance_heatmap.png", partial(plot_heatmap, distances))
        staged.write_with("distance_embedding.png", partial(plot_embedding, distances))
    return summary
