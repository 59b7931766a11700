"""``grasptask verify``: the independent verifier run again over a solutions table."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.records.sweeps import SweepInputs
from grasptask.verifier.verify import verify


@dataclass(frozen=True, kw_only=True)
class VerifyOptions(SweepInputs):
    """What to verify again (:class:`SweepInputs`), and where the table goes."""

    out: Path
    #: what a bare mesh cannot say (--unit, --mass, --task-frame, --task-frame-outside); None: the object's own
    unit: str | None = None
    mass_kg: float | None = None
    task_frame: str | None = None
    task_frame_outside: bool | None = None

    def __post_init__(self) -> None:
        for name in ("solutions", "out"):
            object.__setattr__(self, name, Path(getattr(self, name)))  # strings from a notebook are welcome

    @property
    def object_overrides(self) -> dict[str, Any]:
        given = {"unit": self.unit, "mass_kg": self.mass_kg, "task_frame": self.task_frame,
                 "task_frame_outside": self.task_frame_outside}  # fmt: skip
        return {k: v for k, v in given.items() if v is not None}


@dataclass(frozen=True)
class VerifySummary:
    """The verification table (one row per start: ``verified``, ``verify_failures``, the verifier's figures)
    and where it was written."""

    table: pd.DataFrame
    path: Path

    @property
    def verified(self) -> int:
        return int(self.table["verified"].sum())


def run_verify(options: VerifyOptions) -> VerifySummary:
    """Verify every row of ``options.solutions`` for its task; writes ``out/verification.parquet``."""
    sweep = options.open_sweep(options.object_overrides)
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
    inputs = [options.solutions, sweep.tasks, files.hand, files.object, files.grasp_config]
    with StagedOutput(options.out, Provenance.of("verify", {"task": sweep.task}, inputs)) as staged:
        staged.write_parquet("verification.parquet", table)
    return VerifySummary(table, options.out / "verification.parquet")
