"""``grasptask simulate``: the simulated protocol's recordings, its tool config and ``manifest.csv``."""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from pathlib import Path

import pandas as pd

from grasptask.errors import BadInputError
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.paths import DEFAULT_SIMULATE_CONFIG, as_paths
from grasptask.progress import progress
from grasptask.task import simulate as sim
from grasptask.task.manifest import default_id
from grasptask.task.recordings import write_recording

FORMATS = {"csv": ".csv", "parquet": ".parquet"}


@dataclass(frozen=True, kw_only=True)
class SimulateOptions:
    """Where the recordings go, the simulator's parameters (YAML), the seed (the output is identical for a
    seed) and the recordings' file format (``csv`` or ``parquet``)."""

    out: Path
    config: Path = DEFAULT_SIMULATE_CONFIG
    seed: int = 0
    format: str = "csv"

    def __post_init__(self) -> None:
        as_paths(self, "out", "config")
        if self.format not in FORMATS:
            raise BadInputError("simulate", f"unknown format '{self.format}' (known: {', '.join(FORMATS)})")


@dataclass(frozen=True)
class SimulateSummary:
    out: Path
    recordings: int
    manifest: Path


def run_simulate(options: SimulateOptions) -> SimulateSummary:
    """Write the simulated protocol's recordings, the tool config and ``manifest.csv`` under ``options.out``."""
    config_path, out, seed = options.config, options.out, options.seed
    config = sim.load_config(config_path)
    suffix = FORMATS[options.format]
    provenance = Provenance.of("simulate", {"config": config, "format": options.format}, [config_path], seed)
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
    return SimulateSummary(out, len(rows), out / "manifest.csv")
