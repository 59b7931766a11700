"""The same answer on a busy machine: one 12-start cutting sweep (the human 3-finger hand on the tool, the
shipped settings) run with 2 workers, with 1, and with 2 beside 6 busy processes; its rows (status,
iterations, verified, Q, the grasp) compared, and the wall time of each run said.

    python benchmarks/busy_machine.py [--starts 12] [--busy 6]

Prints as it goes and saves ``benchmarks/results/busy_machine.json``, partial results included."""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd
from common import DEFAULT_SOLVER, demonstration_tasks, save

TASK = "cutting"


def run(tasks: Path, out: Path, workers: int, starts: int) -> float:
    from grasptask.stages import SynthesisOptions, run_synthesize

    began = time.perf_counter()
    options = SynthesisOptions(
        tasks=tasks, task=TASK, out=out, solver_config=DEFAULT_SOLVER, starts=starts, workers=workers
    )
    run_synthesize(options, echo=lambda _: None)
    return time.perf_counter() - began


def rows(out: Path) -> pd.DataFrame:
    table = pd.read_parquet(out / TASK / "solutions.parquet")
    grasp = [c for c in table.columns if c.startswith(("palm_", "q_", "contact_"))]
    return table[["start_id", "status", "iterations", "verified", "Q", *grasp]].sort_values("start_id")


def differences(a: pd.DataFrame, b: pd.DataFrame) -> int:
    """How many rows differ in any of the compared columns (NaN equal to NaN)."""
    a, b = a.reset_index(drop=True), b.reset_index(drop=True)
    same = (a == b) | (a.isna() & b.isna())
    return int((~same.all(axis=1)).sum())


def markdown_table(r: dict) -> str:
    """One row per run: its workers, the busy processes beside it, its wall time and how many rows differ."""
    lines = [
        "| run | workers | busy processes | wall s | verified | rows differing from 2 workers |",
        "|---|---|---|---|---|---|",
    ]
    for name, run in r["runs"].items():
        lines.append(
            f"| {name.replace('_', ' ')} | {run['workers']} | {run['busy_processes']} | {run['wall_s']:.1f} | "
            f"{run['verified']}/{r['starts']} | {run['rows_differing_from_two_workers']} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--starts", type=int, default=12)
    parser.add_argument("--busy", type=int, default=6)
    args = parser.parse_args()
    results: dict = {"task": TASK, "starts": args.starts, "busy_processes": args.busy, "runs": {}}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        tasks = demonstration_tasks(root / "demo")
        runs = {"two_workers": (2, 0), "one_worker": (1, 0), "two_workers_busy": (2, args.busy)}
        for name, (workers, busy) in runs.items():
            spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(busy)]
            try:
                seconds = run(tasks, root / name, workers, args.starts)
            finally:
                for spinner in spinners:
                    spinner.kill()
                    spinner.wait()
            table = rows(root / name)
            entry = {
                "workers": workers,
                "busy_processes": busy,
                "wall_s": round(seconds, 2),
                "verified": int(table["verified"].sum()),
                "statuses": table["status"].value_counts().to_dict(),
                "rows_differing_from_two_workers": differences(table, rows(root / "two_workers")),
            }
            results["runs"][name] = entry
            print(f"{name}: {entry}", flush=True)
            save("busy_machine", results)
    results["identical"] = all(r["rows_differing_from_two_workers"] == 0 for r in results["runs"].values())
    print(f"saved {save('busy_machine', results)}; rows identical: {results['identical']}")


if __name__ == "__main__":
    main()
