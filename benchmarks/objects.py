"""Grasp synthesis on mesh objects beside the tool cylinder: the human hand, drawing, cutting and screw
driving, on 2 workers. Per object and task: a worker's build seconds, ms per IPOPT iteration, median and p90
seconds per start, the verified fraction and distinct optima; ratios of each median over the cylinder's for the
same task, in the same run. ``mug_gp`` is today's route for a mesh (a GP implicit surface), for comparison;
``kitchen_knife_handle``, ``screwdriver_handle`` and ``spray_bottle_body`` are the part of a mesh the hand holds,
alone, as an exact superquadric (``benchmarks/proxies/``): its shape without a surrogate's cost.

    python benchmarks/objects.py [--starts N] [--objects tool,mug,...] [--keep DIR]
    python benchmarks/objects.py --table     # the saved results as the README's table

``scan_bottle``, ``scan_box`` and ``scan_marker`` are scanned household objects as people download them, written
by the run (``tests/scan_files.py``): bare textured OBJs split along every texture seam, no YAML, so their task
frame is the default, their centre of volume.

``ycb_mug``, ``ycb_wood_block`` and ``ycb_power_drill`` are three YCB scans as published
(``../shared/zoo/objects``), bare files too; they run only when asked for (``--objects``). Each sweep's
``time_shares`` say where its time went, by kind of start (``common.time_shares``).

With ``--physics`` each sweep's grasps are then held by the physics judge (grip controller, real strength and
friction), and the share of the verified grasps it holds is recorded.

Targets: a worker's model ready in <= 15 s, the median within 2x the cylinder's (4x for the scans), >= 80% of
starts verified, and with ``--physics`` >= 90% of the verified grasps held.
Results are saved after every sweep (benchmarks/results/objects.json), so an interrupted run keeps what it did.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT)]
from common import (  # noqa: E402
    check_solver,
    demonstration_tasks,
    finished_sweep,
    first_attempt_cell,
    first_attempt_figures,
    held,
    held_cell,
    print_saved,
    ratios_to,
    save,
    save_and_print,
    solver_option,
    span,
    sweep_parser,
    time_shares,
)

TASKS = ("drawing", "cutting", "screwdriving")
OBJECTS = {
    name: ROOT / "configs" / "objects" / f"{name}.yaml"
    for name in ("tool", "mug", "spray_bottle", "kitchen_knife", "screwdriver", "mug_gp")
}
# the grasped part of three meshes alone as an exact superquadric: its shape without a surrogate's cost
# (docs/design/synthesis.md, "Meshes: the surrogate surface")
OBJECTS.update(
    {
        name: ROOT / "benchmarks" / "proxies" / f"{name}.yaml"
        for name in ("kitchen_knife_handle", "screwdriver_handle", "spray_bottle_body")
    }
)


#: three YCB scans as their authors publish them (../shared/zoo/objects: textured OBJs in metres, the origin on
#: the base), run as bare files when asked for (--objects); outside the repository
ZOO = ROOT.parent / "shared" / "zoo" / "objects"
OBJECTS.update(
    {"ycb_mug": ZOO / "025_mug/textured.obj", "ycb_wood_block": ZOO / "036_wood_block/textured.obj",
     "ycb_power_drill": ZOO / "035_power_drill/textured.obj"}
)  # fmt: skip

#: scanned household objects as people download them, written by the run itself (tests/scan_files.py): bare
#: textured OBJs split along their seams, base at the file's origin, no YAML; the marker is a rod 18 mm across and
#: 12 cm long, as YCB's large marker, a thin object
SCANS = ("scan_bottle", "scan_box", "scan_marker")


def scan_file(name: str, folder: Path) -> Path:
    from tests.scan_files import bottle, box, rod, write_textured_obj

    folder.mkdir(parents=True, exist_ok=True)
    shapes = {"scan_bottle": bottle, "scan_box": box, "scan_marker": lambda: rod(radius=0.009)}
    return write_textured_obj(shapes[name](), folder / f"{name}.obj")


def object_path(name: str, folder: Path) -> Path:
    return scan_file(name, folder / "scans") if name in SCANS else OBJECTS[name]


def check_prerequisites(objects: list[str]) -> None:
    from grasptask.objects import load_object

    with tempfile.TemporaryDirectory() as scratch:
        for name in objects:
            if name not in OBJECTS and name not in SCANS:
                raise SystemExit(f"unknown object '{name}' (known: {', '.join([*OBJECTS, *SCANS])})")
            if name in OBJECTS and not OBJECTS[name].is_file():
                raise SystemExit(f"{OBJECTS[name]}: not found")
            load_object(object_path(name, Path(scratch)), say=lambda _: None)  # a broken mesh fails here


def build_seconds(path: Path, tasks: Path, task: str, solver: Path) -> float:
    """The object loaded and one worker's models built, in this process with the sweep's solver config: what a
    sweep does before its first start."""
    from grasptask.grasp.grasp_settings import load_grasp_settings
    from grasptask.synthesis.context import Job, SolverContext
    from grasptask.synthesis.solver_config import load_solver_config

    began = time.perf_counter()
    job = Job.from_files(str(ROOT / "configs/hands/human.yaml"), str(path), str(tasks), task,
                         solver=load_solver_config(solver), settings=load_grasp_settings())  # fmt: skip
    SolverContext(job)
    return time.perf_counter() - began


def sweep_figures(run: dict, solutions: pd.DataFrame) -> dict:
    solved = solutions[solutions["iterations"] > 0]
    solving = solved["seconds"] - solved.get("placement_seconds", 0.0)
    per_iteration = (solving / solved["iterations"]).median() * 1000 if len(solved) else None
    errors = solutions.filter(like="surrogate_error_m_").abs().max(axis=1)
    distances = solutions.filter(like="verify_contact_distance_m_").abs().max(axis=1)
    return {
        "starts": run["starts"],
        "median_s_per_start": run["seconds_per_start"]["median"],
        "p90_s_per_start": run["seconds_per_start"]["p90"],
        "ms_per_iteration": None if per_iteration is None else float(per_iteration),
        "verified_fraction": run["verified_fraction"],
        "distinct_optima": run["distinct_optima"],
        "model_size": run["model_size"],
        "status_counts": run["status_counts"],
        "max_surrogate_error_mm_verified": (
            float(errors[solutions["verified"]].max() * 1000) if errors.notna().any() and solutions["verified"].any()
            else None
        ),
        "sweep_wall_s": run["sweep_wall_seconds_this_run"],
        "first_attempt": first_attempt_figures(solutions),
        "all_axes_starts": run.get("all_axes_starts", 0),
        "max_contact_distance_mm_verified": (
            float(distances[solutions["verified"]].max() * 1000) if solutions["verified"].any() else None
        ),
        "task_frame": run.get("task_frame"),
    }  # fmt: skip


def compare(results: dict) -> dict:
    ratios_to(results["objects"], "tool", "median_over_tool")
    results["targets"] = {
        name: {
            "build_within_15_s": entry["build_s"] <= 15,
            "median_within_2x_tool": all((t["median_over_tool"] or np.inf) <= 2 for t in entry["tasks"].values()),
            # a scanned mesh's bar
            "median_within_4x_tool": all((t["median_over_tool"] or np.inf) <= 4 for t in entry["tasks"].values()),
            "verified_at_least_80pct": all(t["verified_fraction"] >= 0.8 for t in entry["tasks"].values()),
            "held_at_least_90pct": all(
                (t["physics"]["held_of_verified"] or 0) >= 0.9 for t in entry["tasks"].values() if "physics" in t
            ),
        }
        for name, entry in results["objects"].items()
        if name != "tool"
    }
    return results


def main(
    n_starts: int | None, objects: list[str], name: str, solver: Path, keep: Path | None = None, physics: bool = False
) -> dict:
    from grasptask.stages import SynthesisOptions, run_synthesize

    hand = "configs/hands/human.yaml"
    results: dict = {"starts_per_task": n_starts or 126, "hand": hand, "solver_config": str(solver), "objects": {}}
    with tempfile.TemporaryDirectory() as scratch:
        tmp = Path(keep or scratch)
        tasks = demonstration_tasks(tmp)
        for obj in objects:
            path = object_path(obj, tmp)
            build = build_seconds(path, tasks, "drawing", solver)
            print(f"{obj}: a worker's models in {build:.1f} s", flush=True)
            shown = path.name if obj in SCANS else os.path.relpath(path, ROOT)
            entry = results["objects"][obj] = {"file": shown, "build_s": build, "tasks": {}}
            for task in TASKS:
                began = time.perf_counter()
                options = SynthesisOptions(
                    tasks=tasks, task=task, out=tmp / obj, object=path, starts=n_starts, workers=2, solver_config=solver
                )
                run_synthesize(options, echo=print)
                figures = entry["tasks"][task] = sweep_figures(*finished_sweep(tmp / obj / task))
                figures["time_shares"] = time_shares(tmp / obj / task)
                print(
                    f"{obj} {task}: median {figures['median_s_per_start']:.2f} s, "
                    f"{figures['ms_per_iteration'] or float('nan'):.1f} ms/iteration, "
                    f"{figures['verified_fraction']:.0%} verified ({time.perf_counter() - began:.0f} s)",
                    flush=True,
                )
                if physics:
                    figures["physics"] = held(tmp / obj / task, tasks, task, tmp / "physics" / obj / task)
                    print(f"{obj} {task}: physics holds {figures['physics']['held_of_verified']:.0%}", flush=True)
                save(name, results)  # partial results survive an interruption
    save_and_print(name, compare(results), markdown_table)
    print(summary(results))
    return results


def markdown_table(results: dict) -> str:
    lines = [
        "| object | build s | task | median s (x cylinder) | p90 s | ms/iteration | verified | first attempt only: "
        "median s, verified | optima | held |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for obj, entry in results["objects"].items():
        for task, f in entry["tasks"].items():
            ratio = f" ({f['median_over_tool']:.1f}x)" if f.get("median_over_tool") else ""
            per = f"{f['ms_per_iteration']:.1f}" if f["ms_per_iteration"] is not None else "-"
            lines.append(
                f"| {obj} | {entry['build_s']:.1f} | {task} | {f['median_s_per_start']:.2f}{ratio} | "
                f"{f['p90_s_per_start']:.1f} | {per} | {f['verified_fraction']:.0%} | "
                f"{first_attempt_cell(f.get('first_attempt'))} | {f['distinct_optima']} | {held_cell(f)} |"
            )
    return "\n".join(lines)


def summary(results: dict) -> str:
    """What the run says of each object against the tool's, one line each: the docs' prose is made from it."""
    lines = []
    for name, entry in results["objects"].items():
        tasks = entry["tasks"].values()
        held = [t.get("physics", {}).get("held_of_verified") for t in tasks]
        speed = (
            "" if name == "tool" else f", {span([t.get('median_over_tool') for t in tasks], '.1f')}x the tool's median"
        )
        lines.append(
            f"**{name}**: {span([t['verified_fraction'] for t in tasks])} of the starts verified{speed}, "
            f"{span([t['ms_per_iteration'] for t in tasks], '.1f')} ms an iteration, first attempts verifying "
            f"{span([(t.get('first_attempt') or {}).get('verified_fraction') for t in tasks])}"
            + (f"; physics holds {span(held)} of the verified grasps" if any(h is not None for h in held) else "")
            + f"; the model ready in {entry['build_s']:.1f} s."
        )
    missed = [
        f"{name} ({', '.join(k for k, ok in targets.items() if not ok)})"
        for name, targets in results.get("targets", {}).items()
        if not all(targets.values())
    ]
    lines.append("**Targets missed**: " + "; ".join(missed) + "." if missed else "**Every target is met.**")
    return "\n".join(lines)


if __name__ == "__main__":
    parser = sweep_parser(__doc__.splitlines()[0], "objects")
    parser.add_argument(
        "--objects", default="tool,mug,spray_bottle,kitchen_knife,screwdriver,scan_bottle,scan_box,scan_marker"
    )
    parser.add_argument(
        "--keep", type=Path, help="run the sweeps in this folder and keep them (default: a temporary one)"
    )
    parser.add_argument("--physics", action="store_true", help="hold each sweep's grasps in the physics judge")
    solver_option(parser)
    args = parser.parse_args()
    if args.table:
        print_saved(args.name, markdown_table)
        raise SystemExit(0)
    chosen = [o.strip() for o in args.objects.split(",") if o.strip()]
    check_prerequisites(chosen)
    check_solver(args.solver)
    np.seterr(all="ignore")
    main(args.starts, chosen, args.name, args.solver, args.keep, args.physics)
