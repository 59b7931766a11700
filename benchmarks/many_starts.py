"""What more starts buy on the search route (issue 88 item 5): the paper's human hand on the tool, 126 starts on
the paper route against 1,008 on the search route (the paper's 126 and 882 seeded over the surface,
``--surface-starts``), both in the same run on 2 workers. Per task: each sweep's wall time (what a user waits
for), distinct verified optima, best Q and when it came, and the search route's starts converged and polished.

    python benchmarks/many_starts.py [--tasks drawing,...] [--surface-starts 882]
    python benchmarks/many_starts.py --table      # the saved results as a table

Target (issue 88): the search route's 1,008 starts within the paper route's time for 126, best Q no worse.
Results are saved after every sweep (benchmarks/results/many_starts.json).
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT)]
from common import check_solver, demonstration_tasks, save  # noqa: E402
from search_route import route_figures  # noqa: E402

from grasptask.stages import SynthesisOptions, run_synthesize  # noqa: E402

NAME = "many_starts"
SOLVER = ROOT / "configs" / "solver.yaml"
HAND = ROOT / "configs/hands/human_paper.yaml"
GRASP = ROOT / "configs/grasp_paper.yaml"
TASKS = ("drawing", "cutting", "screwdriving")


def main(tasks: list[str], surface: int) -> dict:
    results: dict = {"paper_starts": 126, "search_starts": 126 + surface, "tasks": {}}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        models = demonstration_tasks(folder)
        for task in tasks:
            entry: dict = {}
            for route, seeded in (("paper", 0), ("search", surface)):
                out = folder / route
                options = SynthesisOptions(
                    tasks=models, task=task, out=out, hand=HAND, grasp_config=GRASP, solver_config=SOLVER,
                    workers=2, route=route, surface_starts=seeded,
                )  # fmt: skip
                began = time.perf_counter()
                run_synthesize(options, echo=print)
                entry[route] = route_figures(out / task, time.perf_counter() - began)
                print(f"{task} {route}: {entry[route]}", flush=True)
                results["tasks"][task] = entry
                save(NAME, results)  # partial results kept after every sweep
            paper, search = entry["paper"], entry["search"]
            entry["search_over_paper_time"] = search["sweep_wall_s"] / paper["sweep_wall_s"]
            entry["best_Q_ratio"] = search["best_Q"] / paper["best_Q"] if paper["best_Q"] and search["best_Q"] else None
            entry["meets"] = {
                "time": entry["search_over_paper_time"] <= 1.0,
                "best_Q": entry["best_Q_ratio"] is not None and entry["best_Q_ratio"] <= 1.0,
            }
            save(NAME, results)
    return results


def markdown_table(results: dict) -> str:
    lines = [
        f"| task | paper {results['paper_starts']} s | search {results['search_starts']} s | x time "
        "| optima paper / search | best Q paper / search |",
        "|---|---|---|---|---|---|",
    ]
    for task, e in results["tasks"].items():
        if "search" not in e:
            continue
        p, s = e["paper"], e["search"]
        lines.append(
            f"| {task} | {p['sweep_wall_s']:.0f} | {s['sweep_wall_s']:.0f} | {e['search_over_paper_time']:.2f} | "
            f"{p['distinct_optima']} / {s['distinct_optima']} | {p['best_Q']:.4g} / {s['best_Q']:.4g} |"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table", action="store_true", help=f"print the saved {NAME}.json as a table")
    parser.add_argument("--tasks", default=",".join(TASKS))
    parser.add_argument("--surface-starts", type=int, default=882, help="starts seeded over the surface (search)")
    args = parser.parse_args()
    if args.table:
        print(markdown_table(json.loads((ROOT / "benchmarks" / "results" / f"{NAME}.json").read_text())))
        sys.exit(0)
    chosen = args.tasks.split(",")
    unknown = sorted(set(chosen) - set(TASKS))
    if unknown:
        raise SystemExit(f"unknown task(s) {', '.join(unknown)} (known: {', '.join(TASKS)})")
    check_solver(SOLVER)
    print(markdown_table(main(chosen, args.surface_starts)))
