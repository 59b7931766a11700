"""``grasptask verify``: the independent verifier run again over a solutions table."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from grasptask.grasp.grasp_settings import load_grasp_settings
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.objects import load_object
from grasptask.records.sweeps import SweepFiles, read_grasps
from grasptask.task.task_model import load_task_model
from grasptask.verifier.verify import verify


def run_verify(
    solutions_path: str | Path,
    tasks_path: str | Path | None,
    task: str | None,
    out: str | Path,
    hand_path: str | Path | None = None,
    object_path: str | Path | None = None,
    grasp_config: str | Path | None = None,
    fingers: tuple[str, ...] | None = None,
    object_overrides: dict[str, Any] | None = None,
) -> pd.DataFrame:
    """Verify every row of ``solutions_path`` for ``task``; writes ``out/verification.parquet`` (one row per
    start: ``verified``, ``verify_failures`` and the verifier's figures) and returns it. Every file left None is
    the sweep's (its ``run.json``), else the package's default; ``fingers`` defaults to those the table holds
    contacts of; ``object_overrides`` are --unit, --mass and --task-frame."""
    files = SweepFiles.of(solutions_path, hand_path, object_path, grasp_config, fingers, tasks_path, task)
    tasks_file, task = files.named_task(solutions_path)
    model = load_task_model(tasks_file, task)
    solved = read_grasps(solutions_path, files.hand, files.fingers)
    obj = load_object(files.object, **(object_overrides or {}))
    settings = load_grasp_settings(files.grasp_config)
    rows = []
    for row, grasp in solved.rows:
        record: dict[str, object] = {"start_id": int(row["start_id"])}
        if grasp is None:
            record.update({"verified": False, "verify_failures": "no solution"})
        else:
            check = verify(grasp, solved.hand, obj, model, settings)
            record.update(check.record(list(solved.hand.fingers)))
        rows.append(record)
    table = pd.DataFrame(rows)
    provenance = Provenance.of(
        "verify", {"task": task}, [solutions_path, tasks_file, files.hand, files.object, files.grasp_config]
    )
    with StagedOutput(out, provenance) as staged:
        staged.write_parquet("verification.parquet", table)
    return table
