"""``grasptask simulate``: the simulated protocol's recordings, its tool config and ``manifest.csv``."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import pandas as pd

from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.progress import progress
from grasptask.task import simulate as sim
from grasptask.task.manifest import default_id
from grasptask.task.recordings import write_recording

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
