"""Grasp synthesis for every shipped hand: the human hand with 3, 4 and 5 fingers, the BarrettHand
BH8-282 (URDF), the Allegro Hand (MJCF), and ``mesh_allegro``, each on the tool cylinder for drawing, cutting and
screw driving, 126 starts on 2 workers. Per hand and task: median and p90 seconds per start, the verified
fraction, distinct optima, model size, and, where grasps pass every check of the verifier but its torque check,
the torque effort its LP needs there (above 1: the hand's tendons or motors cannot hold the task at that grasp).
Ratios: each hand's median over the human 3-finger hand's, in the same run.

``mesh_allegro`` is a robot hand as people publish one, written by the run (``tests/hand_files.py``): the Allegro's
kinematics as a URDF whose every link is an STL mesh, joints named "0" to "15", no YAML; its medians are also given
over the Allegro's. ``box_gripper`` is the tests' three-finger gripper with box fingertips
(``tests/hand_files.py``: STL links, URDF boxes at the tips), whose pads are flat faces. ``parallel_jaw`` is the
project's parallel-jaw gripper (``configs/hands/parallel_jaw.urdf``: prismatic jaws, the second a mimic, box pads,
no YAML); its whole sweeps are also set against the Allegro's. ``shadow`` and ``inspire``
are two published hands as their authors ship them (``../shared/zoo/hands``: the Shadow Hand with its forearm and
wrist, the Inspire Hand rooted at an empty link), with no YAML; they run only when asked for (``--hands``).

    python benchmarks/hands.py [--starts N] [--hands human3,barrett,...]
    python benchmarks/hands.py --table     # the saved results as the README's table
    python benchmarks/hands.py --keep DIR ...; python benchmarks/hands.py --summarise DIR

Targets: each robot hand verifies >= 80% of its starts, its median within 2x of the human 3-finger hand's; the
mesh hand's within 2x of the Allegro's; the parallel-jaw gripper's whole sweep within 2x of the Allegro's.
Results are saved after every sweep (benchmarks/results/hands.json), so an interrupted run keeps what it did.
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
    sweep_parser,
    time_shares,
)

TASKS = ("drawing", "cutting", "screwdriving")
HANDS = {
    "human3": (ROOT / "configs/hands/human.yaml", None),
    "human4": (ROOT / "configs/hands/human.yaml", ("thumb", "index", "middle", "ring")),
    "human5": (ROOT / "configs/hands/human.yaml", ("thumb", "index", "middle", "ring", "little")),
    "barrett": (ROOT / "configs/hands/barrett_bh8_282.urdf", None),
    "allegro": (ROOT / "configs/hands/allegro.yaml", None),
    "mesh_allegro": (None, None),  # written by the run
    "box_gripper": (None, None),  # written by the run
    "parallel_jaw": (ROOT / "configs/hands/parallel_jaw.urdf", None),
    "shadow": (ROOT.parent / "shared/zoo/hands/shadow_hand/shadow_hand_right.urdf", None),
    "inspire": (ROOT.parent / "shared/zoo/hands/inspire_hand/inspire_hand_right.urdf", None),
}
#: the hands a run takes unless --hands says otherwise (the zoo's published hands are outside the repository)
DEFAULT_HANDS = ("human3", "human4", "human5", "barrett", "allegro", "mesh_allegro", "box_gripper", "parallel_jaw")
#: the robot hands held to the targets, and those whose median is also set against the Allegro's
ROBOTS = ("barrett", "allegro", "mesh_allegro", "box_gripper", "parallel_jaw", "shadow", "inspire")
MESH_HANDS = ("mesh_allegro", "box_gripper", "shadow", "inspire")
#: the grippers whose whole sweeps are set against the Allegro's
JAWS = ("parallel_jaw",)


def hand_path(name: str, folder: Path) -> Path:
    """The hand's file: a shipped one, or the mesh hand or the box gripper written under ``folder``."""
    path = HANDS[name][0]
    if path is not None:
        return path
    from tests.hand_files import write_mesh_allegro, write_mesh_gripper

    if name == "box_gripper":
        return write_mesh_gripper(folder / "box_gripper", tip="box")
    return write_mesh_allegro(folder / "hand_files")


def check_prerequisites(hands: list[str]) -> None:
    import mujoco  # noqa: F401
    import yourdfpy  # noqa: F401

    for name in hands:
        if name not in HANDS:
            raise SystemExit(f"unknown hand '{name}' (known: {', '.join(HANDS)})")
        path = HANDS[name][0]
        if path is not None and not path.is_file():
            raise SystemExit(f"{path}: not found")


def sweep_figures(run: dict, solutions: pd.DataFrame) -> dict:
    from grasptask.records.solutions import why_few_verified

    # grasps the verifier accepts in every respect but the torque check: where the hand's tendons or motors
    # fall short of the task (starts that failed other checks too say nothing about the hand's strength)
    failing = solutions[~solutions["verified"] & (solutions["verify_failures"].fillna("") == "torque_feasibility")]
    return {
        "starts": run["starts"],
        "median_s_per_start": run["seconds_per_start"]["median"],
        "p90_s_per_start": run["seconds_per_start"]["p90"],
        "verified_fraction": run["verified_fraction"],
        "distinct_optima": run["distinct_optima"],
        "best_Q": run["best_Q"],
        "model_size": run["model_size"],
        "status_counts": run["status_counts"],
        "torque_infeasible_starts": int(len(failing)),
        "median_torque_effort_of_those": float(failing["verify_torque_effort"].median()) if len(failing) else None,
        "sweep_wall_s": run["sweep_wall_seconds_this_run"],
        "first_attempt": first_attempt_figures(solutions),
        "all_axes_starts": run.get("all_axes_starts", 0),
        # as the sweep said it, or as this code says it of the same rows (a sweep kept from before it said so)
        "why_few_verified": run.get("why_few_verified") or why_few_verified(solutions, run["task"]),
        "verified_penetration_max_mm": _verified_max_mm(solutions, "verify_penetration_m"),
        "verified_fingertip_gap_max_mm": _verified_max_mm(solutions, "verify_fingertip_gap_m_"),
    }


def _verified_max_mm(solutions: pd.DataFrame, prefix: str) -> float | None:
    """The largest of the verified starts' columns starting with ``prefix`` (mm); None when none has one."""
    columns = [c for c in solutions.columns if c.startswith(prefix)]
    values = solutions.loc[solutions["verified"].astype(bool), columns].to_numpy(dtype=float)
    return float(1e3 * np.nanmax(values)) if values.size and np.isfinite(values).any() else None


def figures_of(folder: Path) -> dict:
    """A finished sweep's figures, from its run.json and solutions.parquet, and where its time went."""
    return {**sweep_figures(*finished_sweep(folder)), "time_shares": time_shares(folder)}


def compare(results: dict) -> dict:
    """Each sweep's median over the human 3-finger hand's for the same task, and the targets."""
    ratios_to(results["hands"], "human3", "median_over_human3")
    ratios_to(results["hands"], "allegro", "median_over_allegro")
    results["targets"] = {
        hand: {
            "verified_at_least_80pct_or_said_why": all(
                t["verified_fraction"] >= 0.8 or bool(t.get("why_few_verified")) for t in entry["tasks"].values()
            ),
            "median_within_2x_human3": all(
                t["median_over_human3"] is not None and t["median_over_human3"] <= 2 for t in entry["tasks"].values()
            ),
            # with --physics: the physics judge holds at least 90% of each task's verified grasps (a task with
            # none verified has nothing to hold, and says why above)
            "held_at_least_90pct": all(
                t["physics"]["held_of_verified"] is None or t["physics"]["held_of_verified"] >= 0.9
                for t in entry["tasks"].values()
                if "physics" in t
            ),
        }
        for hand, entry in results["hands"].items()
        if hand in ROBOTS
    }
    for hand in MESH_HANDS:
        if hand in results["targets"]:
            results["targets"][hand]["median_within_2x_allegro"] = all(
                (t.get("median_over_allegro") or np.inf) <= 2 for t in results["hands"][hand]["tasks"].values()
            )
    allegro = results["hands"].get("allegro", {}).get("tasks", {})
    for hand in JAWS:
        if hand in results["targets"]:
            tasks = results["hands"][hand]["tasks"]
            for task, figures in tasks.items():
                whole = allegro.get(task, {}).get("sweep_wall_s")
                figures["sweep_over_allegro"] = figures["sweep_wall_s"] / whole if whole else None
            results["targets"][hand]["sweep_within_2x_allegro"] = all(
                (t.get("sweep_over_allegro") or np.inf) <= 2 for t in tasks.values()
            )
    return results


def main(
    n_starts: int | None, hands: list[str], name: str, solver: Path, keep: Path | None = None, physics: bool = False
) -> dict:
    from grasptask.stages import SynthesisOptions, run_synthesize

    results: dict = {"starts_per_task": n_starts or 126, "solver_config": str(solver), "hands": {}}
    with tempfile.TemporaryDirectory() as scratch:
        tmp = Path(keep or scratch)
        tasks = demonstration_tasks(tmp)
        for hand in hands:
            path, fingers = hand_path(hand, tmp), HANDS[hand][1]
            shown = os.path.relpath(path, ROOT) if HANDS[hand][0] else path.name
            results["hands"][hand] = {"file": shown, "fingers": fingers, "tasks": {}}
            for task in TASKS:
                began = time.perf_counter()
                options = SynthesisOptions(
                    tasks=tasks,
                    task=task,
                    out=tmp / hand,
                    hand=path,
                    fingers=fingers,
                    starts=n_starts,
                    workers=2,
                    solver_config=solver,
                )
                run_synthesize(options, echo=print)
                figures = results["hands"][hand]["tasks"][task] = figures_of(tmp / hand / task)
                print(
                    f"{hand} {task}: median {figures['median_s_per_start']:.2f} s, "
                    f"{figures['verified_fraction']:.0%} verified, {figures['distinct_optima']} optima "
                    f"({time.perf_counter() - began:.0f} s)",
                    flush=True,
                )
                if physics:
                    held_by(figures, tmp, hand, task, tasks)
                save(name, results)  # partial results survive an interruption
    save_and_print(name, compare(results), markdown_table)
    return results


def held_by(figures: dict, folder: Path, hand: str, task: str, tasks: Path) -> None:
    """The physics judge on one kept sweep's grasps, added to its figures and said."""
    figures["physics"] = held(folder / hand / task, tasks, task, folder / "physics" / hand / task)
    print(f"{hand} {task}: physics holds {held_cell(figures)} of the verified", flush=True)


def summarise(folder: Path, name: str, physics: bool = False) -> dict:
    """The figures of sweeps kept with --keep, saved as hands.json, without solving anything; with ``physics``,
    each sweep's verified grasps held by the physics judge first."""
    results: dict = {"hands": {}}
    for hand, (path, fingers) in HANDS.items():
        tasks = {
            task: figures_of(folder / hand / task) for task in TASKS if (folder / hand / task / "run.json").exists()
        }
        for task, figures in tasks.items() if physics else ():
            held_by(figures, folder, hand, task, folder / "tasks" / "task_models.json")
        if tasks:
            shown = os.path.relpath(path, ROOT) if path else "hand.urdf"
            results["hands"][hand] = {"file": shown, "fingers": fingers, "tasks": tasks}
            results["starts_per_task"] = next(iter(tasks.values()))["starts"]
    save_and_print(name, compare(results), markdown_table)
    return results


def _mm(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def markdown_table(results: dict) -> str:
    """The README's table: one row per hand and task."""
    lines = [
        "| hand | task | model | median s (x human 3, x Allegro) | p90 s | verified | first attempt only: median s, "
        "verified | optima | grasps failing only the torque check (median LP effort) | verified: deepest sink, "
        "farthest contact off its tip (mm) | held in physics |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for hand, entry in results["hands"].items():
        for task, f in entry["tasks"].items():
            size = f"{f['model_size']['variables']} x {f['model_size']['constraints']}"
            shares = [f"{f[k]:.1f}x" for k in ("median_over_human3", "median_over_allegro") if f.get(k)]
            ratio = f" ({', '.join(shares)})" if shares else ""
            effort = f["median_torque_effort_of_those"]
            failing = "-" if not f["torque_infeasible_starts"] else f"{f['torque_infeasible_starts']} "
            if f["torque_infeasible_starts"]:
                failing += "(no force)" if effort is None or not np.isfinite(effort) else f"({effort:.2f})"
            lines.append(
                f"| {hand} | {task} | {size} | {f['median_s_per_start']:.2f}{ratio} | {f['p90_s_per_start']:.1f} | "
                f"{f['verified_fraction']:.0%} | {first_attempt_cell(f.get('first_attempt'))} | "
                f"{f['distinct_optima']} | {failing} | {_mm(f.get('verified_penetration_max_mm'))}, "
                f"{_mm(f.get('verified_fingertip_gap_max_mm'))} | {held_cell(f)} |"
            )
    return "\n".join(lines)


if __name__ == "__main__":
    parser = sweep_parser(__doc__.splitlines()[0], "hands")
    parser.add_argument("--hands", default=",".join(DEFAULT_HANDS), help="comma-separated, of: " + ", ".join(HANDS))
    parser.add_argument(
        "--keep", type=Path, help="run the sweeps in this folder and keep them (default: a temporary one)"
    )
    parser.add_argument("--summarise", type=Path, help="save and print the figures of sweeps kept in this folder")
    parser.add_argument("--physics", action="store_true", help="hold each sweep's verified grasps in MuJoCo too")
    solver_option(parser)
    args = parser.parse_args()
    if args.summarise:
        summarise(args.summarise, args.name, args.physics)
        raise SystemExit(0)
    if args.table:
        print_saved(args.name, markdown_table)
        raise SystemExit(0)
    chosen = [h.strip() for h in args.hands.split(",") if h.strip()]
    check_prerequisites(chosen)
    check_solver(args.solver)
    np.seterr(all="ignore")
    main(args.starts, chosen, args.name, args.solver, args.keep, args.physics)
