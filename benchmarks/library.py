"""The grasp library (``synthesize --library DIR``) against full sweeps, in one run, on the human 3-finger hand
and the tool: drawing's full sweep fills the library, then each other task is swept twice, in full (126 starts,
no library: today's route) and with the library (the optima of the nearest task as warm starts, then a few of
its own starts). Per task: wall time, best Q, distinct verified optima, and the library sweep's as ratios to the
full one's. The other tasks: cutting and screw driving (the paper's other tasks), and two like drawing: drawing
recorded again (the simulator's recordings of another seed) and drawing pressed 10% harder (its ellipsoid 10%
longer on every axis).

    python benchmarks/library.py [--own-starts N] [--solver YAML]   # writes benchmarks/results/library.json

The prerequisites (the solver config) are checked first; each task's figures are printed and saved as soon as
its two sweeps are done.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT)]
from common import DEFAULT_SOLVER, check_solver, demonstration_tasks, save  # noqa: E402

from grasptask.stages import SynthesisOptions, run_synthesize  # noqa: E402


def similar_tasks(folder: Path, tasks: Path) -> Path:
    """The task models with two tasks like drawing: drawing from the simulator's seed-1 recordings, and drawing's
    ellipsoid 10% longer on every axis."""
    data = json.loads(tasks.read_text())
    again = json.loads(demonstration_tasks(folder / "seed1", seed=1).read_text())["tasks"]["drawing"]
    data["tasks"]["drawing_again"] = again
    drawing = data["tasks"]["drawing"]
    data["tasks"]["drawing_firmer"] = {**drawing, "S": (np.asarray(drawing["S"]) * 1.1**2).tolist()}
    path = folder / "task_models_with_similar.json"
    path.write_text(json.dumps(data))
    return path


def sweep(tasks: Path, task: str, out: Path, solver: Path, starts: int | None, library: Path | None) -> dict:
    began = time.perf_counter()
    options = SynthesisOptions(
        tasks=tasks, task=task, out=out, solver_config=solver, starts=starts, workers=2, library=library
    )
    run = run_synthesize(options, echo=print).run
    wall = time.perf_counter() - began
    optima = pd.read_parquet(out / task / "optima.parquet")
    return {
        "starts": run["starts"],
        "wall_s": wall,
        "best_Q": run["best_Q"],
        "distinct_optima": int(len(optima)),
        "verified": run["verified"],
        "library": run.get("library"),
        "best_Q_after_s": (run.get("throughput") or {}).get("best_Q_after_s"),
    }


def compared(full: dict, warm: dict) -> dict:
    return {
        "full": full,
        "library": warm,
        "wall_full_over_library": full["wall_s"] / warm["wall_s"],
        "best_Q_library_over_full": (warm["best_Q"] / full["best_Q"]) if full["best_Q"] and warm["best_Q"] else None,
        "best_Q_within_1pct": bool(full["best_Q"] and warm["best_Q"] and warm["best_Q"] <= full["best_Q"] * 1.01),
        "optima_library_minus_full": warm["distinct_optima"] - full["distinct_optima"],
    }


def line(task: str, c: dict) -> str:
    f, w = c["full"], c["library"]
    source = (w["library"] or {}).get("from_task")
    return (
        f"{task}: full {f['starts']} starts {f['wall_s']:.0f} s, best Q {f['best_Q']:.4g}, {f['distinct_optima']} "
        f"optima | library ({source}) {w['starts']} starts {w['wall_s']:.0f} s, best Q {w['best_Q']:.4g}, "
        f"{w['distinct_optima']} optima | {c['wall_full_over_library']:.1f}x sooner, best Q ratio "
        f"{c['best_Q_library_over_full']:.3f}"
    )


def markdown_table(r: dict) -> str:
    """The results page's table: per task, the full sweep beside the library's, and their ratios."""
    lines = [
        "| task | nearest in the library (distance) | full: starts, s, best Q, optima | library: starts, s, best Q, "
        "optima | sooner | best Q ratio |",
        "|---|---|---|---|---|---|",
    ]
    for task, c in r["tasks"].items():
        f, w = c["full"], c["library"]
        used = w.get("library") or {}
        lines.append(
            f"| {task} | {used.get('from_task')} ({used.get('distance', float('nan')):.3g}) | {f['starts']}, "
            f"{f['wall_s']:.0f}, {f['best_Q']:.4g}, {f['distinct_optima']} | {w['starts']}, {w['wall_s']:.0f}, "
            f"{w['best_Q']:.4g}, {w['distinct_optima']} | {c['wall_full_over_library']:.1f}x | "
            f"{c['best_Q_library_over_full']:.3f} |"
        )
    return "\n".join(lines)


def main(own_starts: int, solver: Path) -> dict:
    check_solver(solver)
    results: dict = {"own_starts_with_library": own_starts, "solver_config": str(solver), "tasks": {}}
    with tempfile.TemporaryDirectory() as scratch:
        tmp = Path(scratch)
        tasks = similar_tasks(tmp, demonstration_tasks(tmp))
        library = tmp / "library"
        results["filled_by_drawing"] = sweep(tasks, "drawing", tmp / "fill", solver, None, library)
        print(f"library filled by drawing's full sweep: {results['filled_by_drawing']}")
        save("library", results)
        for task in ("drawing_again", "drawing_firmer", "cutting", "screwdriving"):
            full = sweep(tasks, task, tmp / "full", solver, None, None)
            # a copy per task: the library sweep of one task must not start the next from its own optima
            copy = tmp / f"library_{task}"
            copy.mkdir()
            for entry in library.rglob("*.json"):
                (copy / entry.relative_to(library)).parent.mkdir(parents=True, exist_ok=True)
                (copy / entry.relative_to(library)).write_bytes(entry.read_bytes())
            warm = sweep(tasks, task, tmp / "warm", solver, own_starts, copy)
            results["tasks"][task] = compared(full, warm)
            print(line(task, results["tasks"][task]))
            save("library", results)
    return results


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--own-starts", type=int, default=12, help="the library sweep's own starts (default 12)")
    parser.add_argument("--solver", type=Path, default=DEFAULT_SOLVER, help="solver settings (YAML)")
    args = parser.parse_args()
    main(args.own_starts, args.solver)
    print("saved benchmarks/results/library.json")
