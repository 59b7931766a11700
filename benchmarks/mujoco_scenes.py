"""Exported MuJoCo scenes for every shipped hand and the zoo's published hands, on the tool and a zoo scan: a
short drawing sweep of each, its optima exported with ``grasptask export --mujoco``, the export folder copied to
another place, and every scene there loaded by MuJoCo with no edit and replayed with the docs' own code
(docs/guide/mujoco.md). Per hand and object: how many scenes loaded, how many replays gave the physics check's
verdict, how many phases (settling and the task's twelve wrenches) it judged alike, and the largest difference
between a replayed phase's worst translation and the check's, over the phases the check held.

    python benchmarks/mujoco_scenes.py [--starts N] [--hands human3,allegro,...] [--objects tool,ycb_mug]
    python benchmarks/mujoco_scenes.py --table

A hand and object whose sweep verifies nothing are swept again with four times the starts, and a hand that then
has nothing to export from the mug tries the power drill. Target: every scene
loads from the copy, and every replay gives the check's verdict. Results are saved after
every hand and object (benchmarks/results/mujoco_scenes.json), so an interrupted run keeps what it did.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT), str(ROOT / "tests")]
from common import demonstration_tasks, print_saved, save, sweep_parser  # noqa: E402
from hands import HANDS, hand_path  # noqa: E402

NAME = "mujoco_scenes"
OBJECTS = {
    "tool": ROOT / "configs/objects/tool.yaml",
    "ycb_mug": ROOT.parent / "shared/zoo/objects/025_mug/textured.obj",
    "ycb_power_drill": ROOT.parent / "shared/zoo/objects/035_power_drill/textured.obj",
}
#: the objects a run takes unless --objects says otherwise, and the scan a hand tries when the first scan gives it
#: nothing to export (a parallel-jaw gripper's 80 mm stroke around the mug's body)
DEFAULT_OBJECTS, OTHER_SCAN = ("tool", "ycb_mug"), "ycb_power_drill"
DEFAULT_HANDS = ("human3", "barrett", "allegro", "mesh_allegro", "parallel_jaw", "shadow", "inspire")
TASK = "drawing"
#: a hand and object whose first sweep verifies nothing are swept again with this many times the starts
MORE = 4


def check_prerequisites(hands: list[str], objects: list[str]) -> None:
    import mujoco  # noqa: F401

    for name in hands:
        if name not in HANDS:
            raise SystemExit(f"unknown hand '{name}' (known: {', '.join(HANDS)})")
        if HANDS[name][0] is not None and not HANDS[name][0].is_file():
            raise SystemExit(f"{HANDS[name][0]}: not found")
    for name in objects:
        if name not in OBJECTS or not OBJECTS[name].is_file():
            raise SystemExit(f"object '{name}': not known or not found (known: {', '.join(OBJECTS)})")


def grasptask(*args: object) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "grasptask.cli", *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, env={**os.environ, "OPENBLAS_NUM_THREADS": "1"})


def scenes_of(hand: str, obj: str, tasks: Path, work: Path, starts: int) -> dict:
    """One hand on one object: sweep, export with --mujoco, copy, load and replay every scene."""
    import mujoco
    from docs_replay import docs_replay

    folder = work / f"{hand}_{obj}"
    path, fingers = HANDS[hand]
    path = hand_path(hand, work) if path is None else path
    choice = ["--fingers", ",".join(fingers)] if fingers else []
    began = time.perf_counter()
    for tried in (starts, MORE * starts):  # a sweep that verified nothing has nothing to export: more starts once
        sweep = grasptask("synthesize", "--tasks", tasks, "--task", TASK, "--hand", path, "--object", OBJECTS[obj],
                          "--out", folder, "--starts", tried, "--workers", 2, "--anyway", *choice)  # fmt: skip
        if sweep.returncode != 3:
            break
    if sweep.returncode != 0:
        return {"error": sweep.stderr.strip().splitlines()[-1], "starts": tried}
    exported = grasptask("export", folder / TASK / "solutions.parquet", "--out", folder / "export", "--mujoco")
    if exported.returncode != 0:
        return {"error": exported.stderr.strip().splitlines()[-1], "sweep_exit": sweep.returncode}
    copy = shutil.copytree(folder / "export", work / "elsewhere" / f"{hand}_{obj}")
    shutil.rmtree(folder / "export")
    listing = json.loads((copy / "grasps.json").read_text())["grasps"]
    replay, entries = docs_replay(), []
    for grasp in listing:
        scene = copy / grasp["name"]
        entry = {"name": grasp["name"], "held": grasp["held"]}
        try:
            mujoco.MjModel.from_xml_path(str(scene / "scene.xml"))
        except ValueError as error:
            entries.append({**entry, "loads": False, "error": str(error).splitlines()[0]})
            continue
        held, worst = replay(scene)
        entries.append({**entry, "loads": True, "replay_held": bool(held), **phases_compared(worst, scene)})
    return {
        "scenes": len(entries),
        "loaded": sum(e["loads"] for e in entries),
        "replay_agrees": sum(e.get("replay_held") == e["held"] for e in entries),
        "held": sum(bool(e["held"]) for e in entries),
        "starts": tried,
        "seconds": time.perf_counter() - began,
        "grasps": entries,
    }


def phases_compared(worst: dict, scene: Path) -> dict:
    """The replay's phases against the check's: how many of the task's (settling included) each judged the same
    (within the thresholds or past them), and the largest gap in worst translation over those the check held
    (past a threshold the object flies off, and where it ends says nothing)."""
    check = json.loads((scene / "check.json").read_text())
    limit = check["thresholds"]

    def within(translation: float, rotation: float) -> bool:
        return bool(translation <= limit["max_translation_m"] and rotation <= limit["max_rotation_deg"])

    ours = {p: (m["translation_m"], m["rotation_deg"]) for p, m in check["phases"].items()}
    task = [p for p in ours if not p.startswith("dexgraspbench")]
    held = [p for p in task if within(*ours[p])]
    gaps = [abs(worst[p][0] - ours[p][0]) for p in held]
    return {
        "phases": len(task),
        "phases_agree": int(sum(within(*worst[p]) == within(*ours[p]) for p in task)),
        "max_translation_gap_held_m": float(max(gaps, default=0.0)),
    }


def summary(results: dict) -> str:
    """What the run says, one line each: scenes loaded, verdicts and phases the replay gave alike, and how far
    apart the replay and the check went where the check held the object."""
    grasps = [g for cell in results["runs"].values() for g in cell.get("grasps", [])]
    loaded = [g for g in grasps if g.get("loads")]
    gaps = sorted(g["max_translation_gap_held_m"] for g in loaded)
    nothing = [key for key, cell in results["runs"].items() if "error" in cell]
    return "\n".join(
        [
            f"{len(loaded)} of {len(grasps)} exported scenes loaded from a copy of their folder; the replay gave the "
            f"check's verdict on {sum(g['replay_held'] == g['held'] for g in loaded)} of them",
            f"{sum(g['phases_agree'] for g in loaded)} of {sum(g['phases'] for g in loaded)} phases (settling and "
            "the task's wrenches) judged alike, within the thresholds or past them",
            f"where the check held the object, the replay's worst translation within {1e6 * gaps[len(gaps) // 2]:.1f}"
            f" um of the check's for the median scene, and up to {1e3 * gaps[-1]:.2f} mm where the object slid",
            "nothing to export (no verified grasp): " + (", ".join(nothing) or "none"),
        ]
        if gaps
        else ["no scene exported"]
    )


def markdown_table(results: dict) -> str:
    lines = ["| hand | object | scenes | loaded from a copy | replay's verdict agrees | held | phases judged alike | "
             "largest gap in a held phase, um |", "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for key, cell in results["runs"].items():
        hand, obj = key.split("/")
        if "error" in cell:
            lines.append(f"| {hand} | {obj} | - | - | - | - | {cell['error']} |")
            continue
        loaded = [g for g in cell["grasps"] if g.get("loads")]
        gap = f"{1e6 * max(g['max_translation_gap_held_m'] for g in loaded):.1f}" if loaded else "-"
        phases = f"{sum(g['phases_agree'] for g in loaded)} / {sum(g['phases'] for g in loaded)}"
        counts = " | ".join(str(cell[key]) for key in ("scenes", "loaded", "replay_agrees", "held"))
        lines.append(f"| {hand} | {obj} | {counts} | {phases} | {gap} |")
    return "\n".join(lines)


def main() -> None:
    parser = sweep_parser(__doc__, NAME)
    parser.add_argument("--hands", default=",".join(DEFAULT_HANDS))
    parser.add_argument("--objects", default=",".join(DEFAULT_OBJECTS))
    parser.set_defaults(starts=4)
    args = parser.parse_args()
    if args.table:
        print_saved(NAME, markdown_table)
        return
    hands, objects = args.hands.split(","), args.objects.split(",")
    check_prerequisites(hands, [*objects, OTHER_SCAN])
    results: dict = {"task": TASK, "starts": args.starts, "runs": {}}
    with tempfile.TemporaryDirectory() as scratch:
        work = Path(scratch)
        print("task models from the bundled simulator ...", flush=True)
        tasks = demonstration_tasks(work / "tasks")
        for hand in hands:
            for obj in objects:
                cell = scenes_of(hand, obj, tasks, work, args.starts)
                results["runs"][f"{hand}/{obj}"] = cell
                if "error" in cell and obj.startswith("ycb") and obj != OTHER_SCAN:
                    print(f"{hand} on {obj}: {cell['error']}; trying {OTHER_SCAN}", flush=True)
                    obj = OTHER_SCAN
                    cell = results["runs"][f"{hand}/{obj}"] = scenes_of(hand, obj, tasks, work, args.starts)
                said = cell.get("error") or (
                    f"{cell['loaded']}/{cell['scenes']} scenes loaded, {cell['replay_agrees']} replays agree, "
                    f"{cell['held']} held, {cell['seconds']:.0f} s"
                )
                print(f"{hand} on {obj}: {said}", flush=True)
                save(NAME, results)
    print(markdown_table(results))


if __name__ == "__main__":
    main()
