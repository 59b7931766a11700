"""The physics judge over full sweeps: for each hand and task of a folder of kept sweeps (from
``benchmarks/hands.py --keep DIR``), every solved grasp held in MuJoCo four ways, in one run:

- ``grip``: the grip controller at the hand's real strength and friction (the judge as shipped);
- ``spring``: the spring controller, the same grasps and scene (the controller the grip one replaced);
- ``strong``: grip, every actuator 10 times stronger and friction doubled. A grasp with room to spare must hold,
  so this is the judge's validity figure: at least 95% of the verified grasps. For a robot hand only the grasps
  whose own geometry sinks at most 1 mm into the object count; the deeper ones are reported apart;
- ``weak``: grip at 1% of the strength, which must hold none.

The judge starts every grasp with its fingers seated at rest on the object (``grasptask.physics.seating``): a
robot fingertip synthesized into the object by its compliance is first lifted out by the least joint motion.

Per protocol: the pass rate of the verified grasps and the seconds per grasp (median; each worker process is one
core); for ``grip`` also the 2x2 agreement with the analytic verifier, and the grasps' penetration, peak
activation and friction use.

    python benchmarks/hands.py --keep DIR --hands human3,allegro,barrett     # the sweeps, kept
    python benchmarks/physics.py --sweeps DIR [--hands human3,...] [--workers 2]  # other hands' figures kept
    python benchmarks/physics.py --table                                      # the saved results as a table

Targets: strong >= 95% per hand x task, weak 0%, grip's median at most 1.5 s per grasp. Results are saved after
every sweep (benchmarks/results/physics.json), so an interrupted run keeps what it did.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT)]
from common import RESULTS, print_saved, save, save_and_print, span, sweep_parser  # noqa: E402

TASKS = ("drawing", "cutting", "screwdriving")
#: (controller, strength, friction scale) of each protocol
PROTOCOLS = {
    "grip": ("grip", 1.0, 1.0),
    "spring": ("spring", 1.0, 1.0),
    "strong": ("grip", 10.0, 2.0),
    "weak": ("grip", 0.01, 1.0),
}
#: a robot grasp whose own geometry sinks deeper than this (mm) is reported apart from the strong-hand figure
PENETRATION_MM = 1.0
ROBOT_HANDS = ("allegro", "barrett")


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
    import quadprog  # noqa: F401

    if folder is None or not folder.is_dir():
        raise SystemExit("--sweeps DIR: a folder of sweeps kept by `python benchmarks/hands.py --keep DIR`")
    if not (folder / "tasks" / "task_models.json").is_file():
        raise SystemExit(f"{folder}/tasks/task_models.json: not found (hands.py --keep writes it)")
    found = sweeps_in(folder, hands)
    if not found:
        raise SystemExit(f"{folder}: no HAND/TASK/solutions.parquet")
    return found


def rate(flags: pd.Series) -> float | None:
    return float(flags.astype(bool).mean()) if len(flags) else None


def figures(table: pd.DataFrame, hand: str, protocol: str, wall_s: float) -> dict:
    """One protocol's figures over one sweep's verified grasps."""
    solved = table[table["physics_passed"].notna()]
    verified = solved[solved["verified"].astype(bool)]
    out: dict = {
        "verified": int(len(verified)),
        "held_of_verified": rate(verified["physics_passed"]),
        "seconds_per_grasp_median": float(np.median(solved["physics_seconds"])) if len(solved) else None,
        "wall_s": wall_s,
    }
    if protocol == "grip":
        from grasptask.physics.judge import agreement

        out["agreement"] = agreement(table)
        out["dexgraspbench_held_of_verified"] = rate(verified["dexgraspbench_passed"])
        for column in ("physics_initial_penetration_mm", "physics_peak_activation", "physics_friction_use"):
            values = verified[column].to_numpy(dtype=float)
            out[f"{column}_median"] = float(np.median(values)) if len(values) else None
        out["saturated_of_verified"] = rate(verified["physics_saturated"])
    if protocol == "strong":
        shallow = verified["physics_initial_penetration_mm"] <= PENETRATION_MM
        if hand in ROBOT_HANDS:
            deep = verified[~shallow]
            out["counted"] = int(shallow.sum())
            out["held_of_counted"] = rate(verified.loc[shallow, "physics_passed"])
            out["deeper"] = {
                "grasps": int(len(deep)),
                "held": rate(deep["physics_passed"]),
                "penetration_mm_median": float(deep["physics_initial_penetration_mm"].median()) if len(deep) else None,
                "penetration_mm_max": float(deep["physics_initial_penetration_mm"].max()) if len(deep) else None,
            }
        else:
            out["counted"], out["held_of_counted"] = int(len(verified)), out["held_of_verified"]
    return out


def main(folder: Path, found: list[tuple[str, str, Path]], workers: int, name: str) -> dict:
    from grasptask.stages import PhysicsOptions, run_physics

    results: dict = {"sweeps": str(folder), "workers": workers, "protocols": PROTOCOLS, "hands": {}}
    saved = RESULTS / f"{name}.json"
    if saved.is_file():  # the hands not judged again keep their figures, when they came from the same sweeps
        before = json.loads(saved.read_text())
        if before.get("sweeps") == str(folder):
            judged = {hand for hand, _, _ in found}
            results["hands"] = {h: v for h, v in before.get("hands", {}).items() if h not in judged}
    tasks_file = folder / "tasks" / "task_models.json"
    with tempfile.TemporaryDirectory() as scratch:
        for hand, task, sweep in found:
            entry = results["hands"].setdefault(hand, {}).setdefault(task, {})
            for protocol, (controller, strength, friction) in PROTOCOLS.items():
                began = time.perf_counter()
                out = Path(scratch) / hand / task / protocol
                inputs = PhysicsOptions(
                    solutions=sweep / "solutions.parquet", out=out, workers=workers, tasks=tasks_file, task=task,
                    controller=controller, strength=strength, friction_scale=friction,
                )  # fmt: skip
                table = run_physics(inputs).table
                entry[protocol] = figures(table, hand, protocol, time.perf_counter() - began)
                shown = entry[protocol]
                held = "-" if shown["held_of_verified"] is None else f"{shown['held_of_verified']:.0%}"
                print(
                    f"{hand} {task} {protocol}: {held} of {shown['verified']} verified held, "
                    f"{shown['seconds_per_grasp_median']:.2f} s per grasp ({shown['wall_s']:.0f} s)",
                    flush=True,
                )
                save(name, results)  # partial results survive an interruption
    save_and_print(name, results, markdown_table)
    print(summary(results))
    return results


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{value:.0%}"


def markdown_table(results: dict) -> str:
    lines = [
        "| hand | task | verified | grip | spring | strong (counted) | deeper, strong | weak | s per grasp (grip) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for hand, tasks in results["hands"].items():
        for task, p in tasks.items():
            if not all(k in p for k in PROTOCOLS):
                continue
            strong = p["strong"]
            deeper = strong.get("deeper")
            deep = "-" if not deeper else (
                f"{_pct(deeper['held'])} of {deeper['grasps']} ({deeper['penetration_mm_median']:.1f} mm)"
                if deeper["grasps"] else "none"
            )  # fmt: skip
            lines.append(
                f"| {hand} | {task} | {p['grip']['verified']} | {_pct(p['grip']['held_of_verified'])} | "
                f"{_pct(p['spring']['held_of_verified'])} | {_pct(strong['held_of_counted'])} "
                f"({strong['counted']}) | {deep} | {_pct(p['weak']['held_of_verified'])} | "
                f"{p['grip']['seconds_per_grasp_median']:.2f} |"
            )
    return "\n".join(lines)


def summary(results: dict) -> str:
    """What the run says, one line each, against the targets: the docs' prose is made from it."""
    judged = {
        hand: {task: p for task, p in tasks.items() if all(k in p for k in PROTOCOLS)}
        for hand, tasks in results["hands"].items()
    }
    pairs = [(f"{hand} {task}", p) for hand, tasks in judged.items() for task, p in tasks.items()]
    if not pairs:
        return "No sweep has been judged yet."
    strong = [p["strong"]["held_of_counted"] for _, p in pairs]
    weak = [p["weak"]["held_of_verified"] for _, p in pairs]
    short = [name for name, p in pairs if (p["strong"]["held_of_counted"] or 0) < 0.95]
    if any(v != 0 for v in weak):
        short.append("the weak hand")
    verdict = f"misses its validity target on {', '.join(short)}" if short else "is valid on every hand"
    grip = {hand: span([p["grip"]["held_of_verified"] for p in tasks.values()]) for hand, tasks in judged.items()}
    seconds = [p["grip"]["seconds_per_grasp_median"] for _, p in pairs]
    slow = [f"{name} ({s:.2f} s)" for (name, _), s in zip(pairs, seconds, strict=True) if s > 1.5]
    over = f"; over it: {', '.join(slow)}" if slow else ""
    agree = {key: sum(p["grip"]["agreement"][key] for _, p in pairs) for key in pairs[0][1]["grip"]["agreement"]}
    return "\n".join(
        [
            f"**The judge {verdict}.** With ten times the strength and twice the friction it holds {span(strong)} of "
            f"the verified grasps of every hand and task (target 95%); at 1% of the strength {span(weak)} (target "
            "none).",
            f"**At the real strength it holds {span([p['grip']['held_of_verified'] for _, p in pairs])}** of the "
            "verified grasps: " + "; ".join(f"{hand} {held}" for hand, held in grip.items()) + ". The spring "
            f"controller holds {span([p['spring']['held_of_verified'] for _, p in pairs])} of the same grasps.",
            f"**The grip controller takes {span(seconds, '.2f')} s per grasp** (median per hand and task, one core; "
            f"target 1.5 s{over}).",
            f"**Against the verifier** (grip, real strength, every sweep): {agree['verified_and_held']} grasps both "
            f"accept, {agree['verified_and_dropped']} only the verifier, {agree['rejected_and_held']} only physics, "
            f"{agree['rejected_and_dropped']} neither.",
        ]
    )


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
