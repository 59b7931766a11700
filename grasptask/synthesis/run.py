"""``grasptask synthesize``: a sweep of starts for one task, written as it goes and summarised at the end.

Each finished start is appended as one JSON line to ``<out>/<task>/solutions.jsonl`` (flushed and synced), so
an interrupted sweep loses nothing and ``--resume`` skips the starts already there. At the end the lines
become ``solutions.parquet``; the distinct verified optima go to ``optima.parquet`` and the counts, timings,
solver versions and model size to ``run.json``.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from tqdm import tqdm

from grasptask.errors import BadInputError
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.io.config import load_yaml
from grasptask.io.reference import PaperSynthesis, read_paper_synthesis
from grasptask.synthesis import sweep
from grasptask.synthesis.backends import STATUSES
from grasptask.synthesis.clustering import cluster
from grasptask.synthesis.config import load_solver_config
from grasptask.synthesis.starts import make_starts, subset


@dataclass
class SynthesisOptions:
    hand: Path
    object: Path
    tasks: Path
    task: str
    out: Path
    solver_config: Path
    grasp_config: Path
    starts: int | None = None
    seed: int = 0
    workers: int = 1
    executor: str = "pool"
    scheduler: str | None = None
    backend: str = "casadi"
    resume: bool = False
    extra: dict = field(default_factory=dict)


def _read_done(path: Path) -> list[dict]:
    if not path.exists():
        return []
    rows = []
    for line in path.read_text().splitlines():
        try:
            rows.append(json.loads(line))
        except json.JSONDecodeError:
            break  # a line cut short by an interruption; the start is simply solved again
    return rows


def _jsonable(row: dict) -> dict:
    return {k: (v.item() if hasattr(v, "item") else v) for k, v in row.items()}


def run_synthesize(options: SynthesisOptions, echo=print) -> dict:
    from grasptask.grasp.settings import load_grasp_settings
    from grasptask.hand import load_hand
    from grasptask.objects import load_object
    from grasptask.synthesis.model import build_model
    from grasptask.task.model import load_task_models

    models = load_task_models(options.tasks)
    if options.task not in models:
        raise BadInputError(options.tasks, f"no task '{options.task}' (has: {', '.join(models)})")
    solver = load_solver_config(options.solver_config)
    hand = load_hand(options.hand)
    obj = load_object(options.object)
    object_config = load_yaml(options.object)
    job = sweep.Job(
        str(options.hand),
        str(options.object),
        str(options.tasks),
        options.task,
        options.backend,
        solver,
        str(options.grasp_config),
    )
    grasp_settings = load_grasp_settings(options.grasp_config)
    size = build_model(hand, obj, models[options.task], grasp_settings, solver.bounds, solver.regularisation).size()
    paper = read_paper_synthesis()
    starts = subset(make_starts(obj.bounds(), options.seed), options.starts)
    folder = options.out / options.task
    folder.mkdir(parents=True, exist_ok=True)
    log = folder / "solutions.jsonl"
    if not options.resume and log.exists():
        log.unlink()
    done = _read_done(log)
    finished = {row["start_id"] for row in done}
    todo = [s for s in starts if s.start_id not in finished]
    echo(
        f"{options.task}: {len(starts)} starts, {len(finished)} already done, model {size['variables']} variables"
        f" x {size['constraints']} constraints (paper: {paper.variables} x {paper.constraints})"
    )
    wall_start = time.perf_counter()
    bar = tqdm(total=len(starts), initial=len(finished), desc=f"synthesize {options.task}", unit="start", disable=None)
    counts = {
        "verified": sum(r.get("verified", False) for r in done),
        "failing": sum(not r.get("verified", False) for r in done),
    }
    with open(log, "a") as handle, sweep.stop_on_sigint():

        def on_result(row: dict) -> None:
            handle.write(json.dumps(_jsonable(row)) + "\n")
            handle.flush()
            os.fsync(handle.fileno())
            done.append(row)
            counts["verified" if row.get("verified") else "failing"] += 1
            bar.set_postfix(counts)
            bar.update(1)

        try:
            if options.executor == "dask":
                if not options.scheduler:
                    raise BadInputError("synthesize", "--executor dask needs --scheduler ADDRESS")
                sweep.run_dask(job, todo, options.scheduler, on_result, solver.time_limit + solver.hang_grace_s)
            elif options.workers <= 1 and options.executor == "serial":
                sweep.run_serial(job, todo, on_result)
            else:
                sweep.run_pool(job, todo, max(1, options.workers), on_result, solver.time_limit + solver.hang_grace_s)
        finally:
            bar.close()
    wall = time.perf_counter() - wall_start
    return _summarise(options, done, size, wall, object_config.get("symmetry"), list(hand.grasping), paper)


def _summarise(
    options: SynthesisOptions, rows: list[dict], size: dict, wall: float, symmetry, fingers, paper: PaperSynthesis
) -> dict:
    import casadi
    import pyomo.version

    solutions = pd.DataFrame(rows).sort_values("start_id").reset_index(drop=True)
    solutions["verified"] = solutions["verified"].fillna(False).astype(bool)
    optima = cluster(solutions, fingers, symmetry)
    seconds = solutions["seconds"].astype(float)
    status_counts = {s: int((solutions["status"] == s).sum()) for s in STATUSES}
    run = {
        "task": options.task,
        "object": str(options.object),
        "hand": str(options.hand),
        "grasp_config": str(options.grasp_config),
        "backend": options.backend,
        "executor": options.executor,
        "workers": options.workers,
        "starts": int(len(solutions)),
        "status_counts": status_counts,
        "verified": int(solutions["verified"].sum()),
        "verified_fraction": float(solutions["verified"].mean()) if len(solutions) else 0.0,
        "distinct_optima": int(len(optima)),
        "best_Q": float(optima["Q"].min()) if len(optima) else None,
        "seconds_per_start": {
            "median": float(seconds.median()),
            "p90": float(np.percentile(seconds, 90)),
            "mean": float(seconds.mean()),
            "sd": float(seconds.std(ddof=1)) if len(seconds) > 1 else 0.0,
        },
        "sweep_wall_seconds_this_run": wall,
        "model_size": size,
        "paper": {
            "variables": paper.variables,
            "constraints": paper.constraints,
            "seconds_per_solution_mean": paper.mean_s,
            "seconds_per_solution_sd": paper.sd_s,
            "distinct_optima": paper.optima.get(options.task),
        },
        "versions": {"casadi": casadi.__version__, "pyomo": pyomo.version.version},
    }
    folder = options.out / options.task
    config = {k: str(v) for k, v in vars(options).items() if k != "out"}
    inputs = [options.tasks, options.hand, options.object, options.solver_config, options.grasp_config]
    with StagedOutput(folder, Provenance.of("synthesize", config, inputs, options.seed)) as staged:
        staged.write_parquet("solutions.parquet", solutions)
        staged.write_parquet("optima.parquet", optima)
        staged.write_json("run.json", run)
    return run
