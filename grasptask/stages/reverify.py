"""``grasptask verify``: the independent verifier run again over a solutions table."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.objects.object_files import BareObjectFacts
from grasptask.paths import as_paths
from grasptask.records.sweeps import SweepInputs
from grasptask.verifier.verify import verify


@dataclass(frozen=True, kw_only=True)
class VerifyOptions(SweepInputs, BareObjectFacts):
    """What to verify again (:class:`SweepInputs`, and what a bare mesh cannot say: :class:`BareObjectFacts`),
    and where the table goes."""

    out: Path

    def __post_init__(self) -> None:
        as_paths(self, "solutions", "out")


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
