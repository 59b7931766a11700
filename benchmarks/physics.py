"""The physics check (issue 18) over full sweeps: for each hand and task of a folder of kept sweeps (from
``benchmarks/hands.py --keep DIR``), every solved grasp held in MuJoCo. Per sweep: simulation seconds per grasp
(median; each worker process is one core), the physics pass rate of the verified grasps beside DexGraspBench's
test, the 2x2 agreement with the analytic verifier, and which wrenches the dropped verified grasps failed.

    python benchmarks/hands.py --keep DIR [--hands human3,...]      # the sweeps, kept
    python benchmarks/physics.py --sweeps DIR [--hands human3,...] [--workers 2] [--name NAME]
    python benchmarks/physics.py --name NAME --table                 # the saved results as a table

Target: at most 1 s of simulation per grasp on one core for the whole protocol. Results are saved after every
sweep (benchmarks/results/NAME.json), so an interrupted run keeps what it did.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT)]
from common import print_saved, save, save_and_print, sweep_parser  # noqa: E402

TASKS = ("drawing", "cutting", "screwdriving")


def sweeps_in(folder: Path, hands: list[str] | None) -> list[tuple[str, str, Path]]:
    """``(hand, task, folder)`` of every finished sweep under ``folder`` (its ``solutions.parquet``)."""
    found = []
    for hand_dir in sorted(p for p in folder.iterdir() if p.is_dir()):
        if hands and hand_dir.name not in hands:
            continue
        for task in TASKS:
            if (hand_dir / task / "solutions.parquet").is_file():
                found.append((hand_dir.name, task, hand_dir / task))
    return found


def check_prerequisites(folder: Path | None, hands: list[str] | None) -> list[tuple[str, str, Path]]:
    import mujoco  # noqa: F401

    if folder is None or not folder.is_dir():
        raise SystemExit("--sweeps DIR: a folder of sweeps kept by `python benchmarks/hands.py --keep DIR`")
    if not (folder / "tasks" / "task_models.json").is_file():
        raise SystemExit(f"{folder}/tasks/task_models.json: not found (hands.py --keep writes it)")
    found = sweeps_in(folder, hands)
    if not found:
        raise SystemExit(f"{folder}: no HAND/TASK/solutions.parquet")
    return found


def main(folder: Path, found: list[tuple[str, str, Path]], workers: int, name: str) -> dict:
    from grasptask.stages import PhysicsInputs, run_physics

    results: dict = {"sweeps": str(folder), "workers": workers, "hands": {}}
    with tempfile.TemporaryDirectory() as scratch:
        for hand, task, sweep in found:
            began = time.perf_counter()
            inputs = PhysicsInputs(sweep / "solutions.parquet", folder / "tasks" / "task_models.json", task)
            run_physics(inputs, Path(scratch) / hand / task, workers, echo=print)
            summary = json.loads((Path(scratch) / hand / task / "physics_summary.json").read_text())
            summary.pop("provenance", None)
            summary["wall_s"] = time.perf_counter() - began
            results["hands"].setdefault(hand, {})[task] = summary
            print(f"{hand} {task}: {summary['seconds_per_grasp_median']:.2f} s per grasp ({summary['wall_s']:.0f} s)")
            save(name, results)  # partial results survive an interruption
    save_and_print(name, results, markdown_table)
    return results


def markdown_table(results: dict) -> str:
    lines = [
        "| hand | task | verified | held by physics | DexGraspBench's test | verifier x physics (both / only "
        "verifier / only physics / neither) | s per grasp |",
        "|---|---|---|---|---|---|---|",
    ]
    for hand, tasks in results["hands"].items():
        for task, s in tasks.items():
            pair = s["agreement"]

            def pct(value):
                return "-" if value is None else f"{value:.0%}"

            lines.append(
                f"| {hand} | {task} | {s['verified']}/{s['solved']} | {pct(s['physics_pass_rate_of_verified'])} | "
                f"{pct(s['dexgraspbench_pass_rate_of_verified'])} | {pair['verified_and_held']} / "
                f"{pair['verified_and_dropped']} / {pair['rejected_and_held']} / {pair['rejected_and_dropped']} | "
                f"{s['seconds_per_grasp_median']:.2f} |"
            )
    return "\n".join(lines)


if __name__ == "__main__":
    parser = sweep_parser(__doc__.splitlines()[0], "physics")
    parser.add_argument("--sweeps", type=Path, default=None, help="a folder of sweeps kept by hands.py --keep")
    parser.add_argument("--hands", default=None, help="comma-separated hand folders (default: all there)")
    parser.add_argument("--workers", type=int, default=2, help="simulation processes")
    args = parser.parse_args()
    if args.table:
        print_saved(args.name, markdown_table)
        raise SystemExit(0)
    chosen = [h.strip() for h in args.hands.split(",")] if args.hands else None
    main(args.sweeps, check_prerequisites(args.sweeps, chosen), args.workers, args.name)
