"""Grasps with room to spare, synthesis and the physics judge in one run: for the human 3-finger
hand, the Allegro and the Barrett on the tool, drawing, cutting and screw driving, each of

- ``paper_model``: the paper's contact model, ``configs/grasp_paper.yaml`` (no margin, a fixed pad point, four
  cone edges): the route before the margin;
- ``default``: ``configs/grasp.yaml`` (the margin and rolling contacts);
- the neighbours of the default: ``activation_max``, ``motor_activation_max`` and ``friction_scale`` each 0.1
  either side of it, on every third start (``--neighbour-starts``);

is synthesized from the starts, and every verified grasp is then held in MuJoCo by the grip controller at the
hand's real strength and friction (the physics judge as shipped). Per route, hand and task: the verified
fraction, the fraction of the verified grasps physics holds, the median strength and friction margins, the
deepest penetration of a verified grasp (the verifier's, on the hand's true geometry, and MuJoCo's at the start
of the hold), and the median seconds per start over the paper model's, in the same run.

    python benchmarks/margins.py [--starts N] [--hands human3,allegro,barrett] [--neighbour-starts N]
    python benchmarks/margins.py --routes NAME,... [--keep]  # some routes again (--keep: the others' results kept)
    python benchmarks/margins.py --table                    # the saved results as a table

Targets (default route): held >= 90% and verified >= 80% per hand x task, penetration at most the hand's
compliance, median seconds per start at most 1.5x the paper model's. Results are saved after every sweep
(benchmarks/results/margins.json), so an interrupted run keeps what it did.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT)]
from common import (  # noqa: E402
    RESULTS,
    demonstration_tasks,
    finished_sweep,
    print_saved,
    save,
    save_and_print,
    span,
    sweep_parser,
)

TASKS = ("drawing", "cutting", "screwdriving")
HANDS = {
    "human3": ROOT / "configs/hands/human.yaml",
    "allegro": ROOT / "configs/hands/allegro.yaml",
    "barrett": ROOT / "configs/hands/barrett_bh8_282.urdf",
}
PAPER_MODEL, DEFAULT = ROOT / "configs/grasp_paper.yaml", ROOT / "configs/grasp.yaml"
#: the default's neighbours: (key, change)
NEIGHBOURS = (
    ("activation_max", -0.1),
    ("activation_max", 0.1),
    ("motor_activation_max", -0.1),
    ("motor_activation_max", 0.1),
    ("friction_scale", -0.1),
    ("friction_scale", 0.1),
)


def check_prerequisites(hands: list[str]) -> None:
    import mujoco  # noqa: F401

    from grasptask.grasp.grasp_settings import load_grasp_settings

    for name in hands:
        if name not in HANDS:
            raise SystemExit(f"unknown hand '{name}' (known: {', '.join(HANDS)})")
    for path in (PAPER_MODEL, DEFAULT):
        load_grasp_settings(path)


def routes(folder: Path) -> dict[str, tuple[Path, bool]]:
    """Each route's grasp config, and whether it is a neighbour (run on fewer starts)."""
    found = {"paper_model": (PAPER_MODEL, False), "default": (DEFAULT, False)}
    from grasptask.io.config_schema import load_yaml

    default = settings_of(DEFAULT)
    for key, change in NEIGHBOURS:
        value = round(float(default[key]) + change, 3)
        if not 0 < value <= 1:
            continue
        path = folder / f"grasp_{key}_{value}.yaml"
        path.write_text(yaml.safe_dump({**load_yaml(DEFAULT), key: value}))
        found[f"{key}={value}"] = (path, True)
    return found


def settings_of(config: Path) -> dict:
    """Every grasp setting a config file gives, its defaults included (a shipped file sets only differences)."""
    from grasptask.grasp.grasp_settings import load_grasp_settings

    return dataclasses.asdict(load_grasp_settings(config))


def _median(values: pd.Series) -> float | None:
    values = values.dropna().astype(float)
    return float(values.median()) if len(values) else None


def _largest(values: pd.Series) -> float | None:
    values = values.dropna().astype(float)
    return float(values.max()) if len(values) else None


def figures(sweep: Path, physics: pd.DataFrame | None, compliance_m: float) -> dict:
    run, solutions = finished_sweep(sweep)
    verified = solutions[solutions["verified"]]
    out = {
        "starts": run["starts"],
        "verified_fraction": run["verified_fraction"],
        "median_s_per_start": run["seconds_per_start"]["median"],
        "median_strength_margin": _median(verified.get("verify_strength_margin", pd.Series(dtype=float))),
        "median_friction_margin": _median(verified.get("verify_friction_margin", pd.Series(dtype=float))),
        "largest_strength_margin": _largest(solutions.get("verify_strength_margin", pd.Series(dtype=float))),
        "deepest_penetration_mm": float(verified["verify_penetration_m"].max() * 1e3)
        if len(verified) and "verify_penetration_m" in verified
        else None,
        "compliance_mm": compliance_m * 1e3,
        "held_of_verified": None,
        "physics_initial_penetration_mm_max": None,
    }
    if physics is not None and len(physics):
        checked = physics[physics["verified"]]
        if len(checked):
            out["held_of_verified"] = float(checked["physics_passed"].astype(bool).mean())
            out["physics_initial_penetration_mm_max"] = float(checked["physics_initial_penetration_mm"].max())
            out["physics_s_per_grasp_median"] = float(checked["physics_seconds"].median())
    return out


def main(
    n_starts: int | None, neighbour_starts: int, hands: list[str], name: str, only: list[str] | None, keep: bool
) -> dict:
    from grasptask.hand import load_hand
    from grasptask.stages import PhysicsOptions, SynthesisOptions, run_physics, run_synthesize

    results: dict = {"starts_per_task": n_starts or 126, "neighbour_starts": neighbour_starts, "routes": {}}
    saved = RESULTS / f"{name}.json"
    if keep and saved.exists():  # the routes not run again keep their figures
        results["routes"] = json.loads(saved.read_text())["routes"]
    with tempfile.TemporaryDirectory() as scratch:
        tmp = Path(scratch)
        tasks = demonstration_tasks(tmp)
        for route, (config, neighbour) in routes(tmp).items():
            if only and route not in only:
                continue
            results["routes"][route] = {"grasp_config": settings_of(config), "hands": {}}
            for hand in hands:
                compliance = load_hand(HANDS[hand]).compliance_m
                entry = results["routes"][route]["hands"].setdefault(hand, {})
                for task in TASKS:
                    began = time.perf_counter()
                    out = tmp / route / hand
                    options = SynthesisOptions(
                        tasks=tasks, task=task, out=out, hand=HANDS[hand], grasp_config=config, workers=2,
                        starts=neighbour_starts if neighbour else n_starts,
                    )  # fmt: skip
                    run_synthesize(options, echo=lambda _: None)
                    inputs = PhysicsOptions(
                        solutions=out / task / "solutions.parquet", out=tmp / "physics" / route / hand / task,
                        workers=2, tasks=tasks, task=task,
                    )  # fmt: skip
                    physics = run_physics(inputs).table
                    shown = entry[task] = figures(out / task, physics, compliance)
                    held = "-" if shown["held_of_verified"] is None else f"{shown['held_of_verified']:.0%}"
                    print(
                        f"{route} {hand} {task}: {shown['verified_fraction']:.0%} verified, {held} of them held, "
                        f"margins {shown['median_strength_margin']} / {shown['median_friction_margin']}, "
                        f"{shown['median_s_per_start']:.2f} s per start ({time.perf_counter() - began:.0f} s)",
                        flush=True,
                    )
                    save(name, results)  # partial results survive an interruption
    compare(results)
    save_and_print(name, results, markdown_table)
    print(summary(results))
    return results


def compare(results: dict) -> None:
    """Each route's median seconds per start over the paper model's, and the default route's targets."""
    paper = results["routes"].get("paper_model", {}).get("hands", {})
    for entry in results["routes"].values():
        for hand, tasks in entry["hands"].items():
            for task, f in tasks.items():
                base = paper.get(hand, {}).get(task, {}).get("median_s_per_start")
                f["median_over_paper_model"] = f["median_s_per_start"] / base if base else None
    default = results["routes"].get("default", {}).get("hands", {})
    results["targets"] = {
        hand: {
            "held_at_least_90pct": all((f["held_of_verified"] or 0) >= 0.9 for f in tasks.values()),
            "verified_at_least_80pct": all(f["verified_fraction"] >= 0.8 for f in tasks.values()),
            "penetration_within_compliance": all(
                (f["deepest_penetration_mm"] or 0) <= f["compliance_mm"] + 0.1 for f in tasks.values()
            ),
            "median_within_1_5x_paper_model": all(
                (f["median_over_paper_model"] or np.inf) <= 1.5 for f in tasks.values()
            ),
        }
        for hand, tasks in default.items()
    }


def _cell(value: float | None, form: str) -> str:
    return "-" if value is None else format(value, form)


def markdown_table(results: dict) -> str:
    lines = [
        "| route | hand | task | verified | held | strength margin | friction needed | deepest (mm) | s/start "
        "(x paper model) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for route, entry in results["routes"].items():
        for hand, tasks in entry["hands"].items():
            for task, f in tasks.items():
                ratio = f" ({f['median_over_paper_model']:.2f}x)" if f.get("median_over_paper_model") else ""
                lines.append(
                    f"| {route} | {hand} | {task} | {f['verified_fraction']:.0%} | "
                    f"{_cell(f['held_of_verified'], '.0%')} | {_cell(f['median_strength_margin'], '.2f')} | "
                    f"{_cell(f['median_friction_margin'], '.2f')} | "
                    f"{_cell(f['deepest_penetration_mm'], '.2f')} | {f['median_s_per_start']:.2f}{ratio} |"
                )
    return "\n".join(lines)


def summary(results: dict) -> str:
    """What the run says of the default route against the paper model's, one line each: the docs' prose."""
    default = results["routes"].get("default", {}).get("hands", {})
    paper = results["routes"].get("paper_model", {}).get("hands", {})
    if not default:
        return "The default route has not been run yet."

    def every(route: dict, key: str) -> list:
        return [f[key] for tasks in route.values() for f in tasks.values()]

    missed = [
        f"{hand} {task}"
        for hand, tasks in default.items()
        for task, f in tasks.items()
        if (f["held_of_verified"] or 0) < 0.9 or f["verified_fraction"] < 0.8
    ]
    verdict = f"miss their targets on {', '.join(missed)}" if missed else "are at target for every hand and task"
    deepest = "; ".join(
        f"{hand} {max(f['deepest_penetration_mm'] or 0 for f in tasks.values()):.2f} mm (compliance "
        f"{next(iter(tasks.values()))['compliance_mm']:.1f} mm)"
        for hand, tasks in default.items()
    )
    largest = "; ".join(
        f"{hand} {span([f['largest_strength_margin'] for f in tasks.values()], '.2f')}"
        for hand, tasks in default.items()
    )
    ratios = {hand: [f.get("median_over_paper_model") for f in tasks.values()] for hand, tasks in default.items()}
    over = sum((r or np.inf) > 1.5 for values in ratios.values() for r in values)
    pace = (
        "within 1.5x the paper model's on every pair"
        if not over
        else f"over 1.5x the paper model's on {over} of {len(every(default, 'starts'))} pairs"
    )
    speeds = "; ".join(
        f"{hand} " + " / ".join("-" if r is None else f"{r:.2f}" for r in values) for hand, values in ratios.items()
    )
    return "\n".join(
        [
            f"**Held and verified {verdict}**: physics holds {span(every(default, 'held_of_verified'))} of the "
            f"verified grasps (target 90%; the paper model {span(every(paper, 'held_of_verified'))}), and "
            f"{span(every(default, 'verified_fraction'))} of the starts are verified (target 80%; the paper model "
            f"{span(every(paper, 'verified_fraction'))}).",
            f"**Penetration**, the deepest verified grasp per hand: {deepest}; the verifier allows 0.1 mm more.",
            f"**Margins.** Median strength margins {span(every(default, 'median_strength_margin'), '.2f')}, friction "
            f"needed {span(every(default, 'median_friction_margin'), '.2f')} of mu. The largest strength margin any "
            f"start reached: {largest}.",
            f"**Speed is {pace}** (drawing / cutting / screw driving, times the paper model's median): {speeds}.",
        ]
    )


if __name__ == "__main__":
    parser = sweep_parser(__doc__.splitlines()[0], "margins")
    parser.add_argument("--hands", default=",".join(HANDS), help="comma-separated, of: " + ", ".join(HANDS))
    parser.add_argument("--neighbour-starts", type=int, default=42, help="starts per task of the neighbours")
    parser.add_argument("--routes", default=None, help="comma-separated routes to run (default: all)")
    parser.add_argument("--keep", action="store_true", help="keep the saved figures of the routes not run")
    args = parser.parse_args()
    if args.table:
        print_saved(args.name, markdown_table)
        raise SystemExit(0)
    chosen = [h.strip() for h in args.hands.split(",") if h.strip()]
    check_prerequisites(chosen)
    np.seterr(all="ignore")
    only = [r.strip() for r in args.routes.split(",")] if args.routes else None
    main(args.starts, args.neighbour_starts, chosen, args.name, only, args.keep)
