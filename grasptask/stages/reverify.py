"""``grasptask verify``: the independent verifier run again over a solutions table."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.records.sweeps import Sweep
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
    sweep = Sweep.open(
        solutions_path, tasks=tasks_path, task=task, hand=hand_path, object=object_path, grasp_config=grasp_config,
        fingers=fingers, object_overrides=object_overrides,
    )  # fmt: skip
    obj = sweep.load_object(say=print)
    rows = []
    for row, grasp in sweep.rows:
        record: dict[str, object] = {"start_id": int(row["start_id"])}
        if grasp is None:
            record.update({"verified": False, "verify_failures": "no solution"})
        else:
            check = verify(grasp, sweep.hand, obj, sweep.task_model, sweep.settings)
            record.update(check.record(list(sweep.hand.fingers)))
        rows.append(record)
    table = pd.DataFrame(rows)
    files = sweep.files
    provenance = Provenance.of(
        "verify", {"task": sweep.task}, [solutions_path, sweep.tasks, files.hand, files.object, files.grasp_config]
    )
    with StagedOutput(out, provenance) as staged:
        staged.write_parquet("verification.parquet", table)
    return table
