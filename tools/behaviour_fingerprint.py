"""Fingerprint of the synthesis behaviour, to show that a refactoring changed nothing.

It records the sha256 of the NL text that each task's NLP writes on the tool cylinder, and a fixed-seed
12-start drawing sweep solved in this process (status, IPOPT iterations, Q of every start). Run it on the
code before a change with ``--save``, and after it with ``--compare``:

    python tools/behaviour_fingerprint.py --tasks results/demo/tasks/task_models.json --save before.json
    python tools/behaviour_fingerprint.py --tasks results/demo/tasks/task_models.json --compare before.json

Exit code 0 when the NL texts are byte-identical and every start has the same status, the same iteration
count and the same Q to 1e-9; 1 otherwise, with each difference printed. IPOPT's path is sensitive to
rounding, so compare runs on the same machine and package versions; the wall-time limit is lifted so that no
start ends by the clock.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from grasptask.grasp.grasp_settings import load_grasp_settings  # noqa: E402
from grasptask.hand import load_hand  # noqa: E402
from grasptask.objects import load_object  # noqa: E402
from grasptask.paths import DEFAULT_GRASP_CONFIG, DEFAULT_HAND, DEFAULT_OBJECT, DEFAULT_SOLVER_CONFIG  # noqa: E402
from grasptask.synthesis.backends import write_nl  # noqa: E402
from grasptask.synthesis.context import Job, SolverContext  # noqa: E402
from grasptask.synthesis.nlp import build_model  # noqa: E402
from grasptask.synthesis.solver_config import load_solver_config  # noqa: E402
from grasptask.synthesis.starts import make_starts, subset  # noqa: E402
from grasptask.task.task_model import load_task_models  # noqa: E402

TASKS = ("drawing", "cutting", "screwdriving")
Q_TOLERANCE = 1e-9


def fingerprint(tasks_path: Path, n_starts: int = 12, seed: int = 0, nl_dir: Path | None = None) -> dict:
    solver = load_solver_config(DEFAULT_SOLVER_CONFIG)
    hand, obj = load_hand(DEFAULT_HAND), load_object(DEFAULT_OBJECT)
    settings = load_grasp_settings(DEFAULT_GRASP_CONFIG)
    models = load_task_models(tasks_path)
    nl = {}
    for task in TASKS:
        nlp = build_model(hand, obj, models[task], settings, solver.search_bounds, solver.regularisation)
        text, _ = write_nl(nlp.model)
        nl[task] = hashlib.sha256(text.encode()).hexdigest()
        if nl_dir is not None:
            nl_dir.mkdir(parents=True, exist_ok=True)
            (nl_dir / f"{task}.nl").write_text(text)
        print(f"{task}: NL sha256 {nl[task][:16]}", flush=True)
    job = Job.from_files(
        hand_path=str(DEFAULT_HAND),
        object_path=str(DEFAULT_OBJECT),
        tasks_path=str(tasks_path),
        task="drawing",
        solver=solver,
        settings=settings,
    )
    context = SolverContext(job)
    rows = []
    for start in subset(make_starts(obj.bounds(), seed), n_starts):
        row = context.solve(start)
        rows.append({k: row[k] for k in ("start_id", "status", "iterations", "Q", "verified")})
        print(f"start {row['start_id']}: {row['status']}, {row['iterations']} iterations, Q {row['Q']:.6g}", flush=True)
    return {"nl_sha256": nl, "drawing_sweep": {"seed": seed, "starts": rows}}


def differences(before: dict, after: dict) -> list[str]:
    found = []
    for task, digest in before["nl_sha256"].items():
        if after["nl_sha256"].get(task) != digest:
            found.append(f"{task}: the NL text differs")
    old, new = before["drawing_sweep"]["starts"], after["drawing_sweep"]["starts"]
    if [r["start_id"] for r in old] != [r["start_id"] for r in new]:
        return [*found, "the sweeps solved different starts"]
    for a, b in zip(old, new, strict=True):
        for key in ("status", "iterations", "verified"):
            if a[key] != b[key]:
                found.append(f"start {a['start_id']}: {key} {a[key]} -> {b[key]}")
        both_nan = math.isnan(a["Q"]) and math.isnan(b["Q"])
        if not both_nan and not abs(a["Q"] - b["Q"]) <= Q_TOLERANCE:
            found.append(f"start {a['start_id']}: Q {a['Q']!r} -> {b['Q']!r}")
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", type=Path, required=True, help="task_models.json from fit-task")
    parser.add_argument("--starts", type=int, default=12)
    parser.add_argument("--save", type=Path, help="write the fingerprint here")
    parser.add_argument("--compare", type=Path, help="compare with a saved fingerprint")
    parser.add_argument("--nl-dir", type=Path, help="also write each task's NL text here, for diffing")
    args = parser.parse_args()
    if not args.tasks.is_file():
        print(f"error: {args.tasks}: not found (run simulate and fit-task first)", file=sys.stderr)
        return 2
    result = fingerprint(args.tasks, args.starts, nl_dir=args.nl_dir)
    if args.save:
        args.save.write_text(json.dumps(result, indent=2) + "\n")
        print(f"saved {args.save}")
    if args.compare:
        found = differences(json.loads(args.compare.read_text()), result)
        for line in found:
            print(f"DIFFERENT: {line}")
        print("behaviour unchanged" if not found else f"{len(found)} difference(s)")
        return 1 if found else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
