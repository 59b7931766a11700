"""``grasptask synthesize``: a sweep of starts for one task, written as it goes and summarised at the end.

Each finished start is appended as one JSON line to ``<out>/<task>/solutions.jsonl`` (flushed and synced), so
an interrupted sweep loses nothing and ``--resume`` skips the starts already there. At the end the lines
become ``solutions.parquet``; the distinct verified optima go to ``optima.parquet`` and the counts, timings,
solver versions and model size (as the workers report it) to ``run.json``.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from tqdm import tqdm

from grasptask.errors import BadInputError
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.io.reference import PaperSynthesis, read_paper_synthesis
from grasptask.io.solutions import STATUSES
from grasptask.objects.surface import Symmetry
from grasptask.paths import DEFAULT_GRASP_CONFIG, DEFAULT_HAND, DEFAULT_OBJECT, DEFAULT_SOLVER_CONFIG

EXECUTORS = ("pool", "serial", "dask")
BACKENDS = ("casadi", "cyipopt")


@dataclass(frozen=True, kw_only=True)
class SynthesisOptions:
    """What a sweep is run on and how; checked when made, so a bad combination fails before any work."""

    tasks: Path
    task: str
    out: Path
    hand: Path = DEFAULT_HAND
    object: Path = DEFAULT_OBJECT
    solver_config: Path = DEFAULT_SOLVER_CONFIG
    grasp_config: Path = DEFAULT_GRASP_CONFIG
    starts: int | None = None
    seed: int = 0
    workers: int = 1
    executor: str = "pool"
    scheduler: str | None = None
    backend: str = "casadi"
    resume: bool = False

    def __post_init__(self) -> None:
        for name in ("tasks", "out", "hand", "object", "solver_config", "grasp_config"):
            object.__setattr__(self, name, Path(getattr(self, name)))  # strings from a notebook are welcome
        if self.executor not in EXECUTORS:
            raise BadInputError("synthesize", f"unknown executor '{self.executor}' (known: {', '.join(EXECUTORS)})")
        if self.backend not in BACKENDS:
            raise BadInputError("synthesize", f"unknown solver '{self.backend}' (known: {', '.join(BACKENDS)})")
        if self.workers < 1 or (self.starts is not None and self.starts < 1):
            raise BadInputError("synthesize", "--workers and --starts must be at least 1")
        if self.executor == "serial" and self.workers != 1:
            raise BadInputError(
                "synthesize",
                f"--executor serial solves in this process, one start at a time: drop --workers {self.workers}",
            )
        if self.executor == "dask" and not self.scheduler:
            raise BadInputError("synthesize", "--executor dask needs --scheduler ADDRESS")
        if self.executor != "dask" and self.scheduler:
            raise BadInputError("synthesize", "--scheduler is for --executor dask")

    @property
    def folder(self) -> Path:
        return self.out / self.task


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


def _previous_model_size(folder: Path) -> dict[str, int] | None:
    """The model size an earlier run of this folder recorded, for a resumed sweep with nothing left to solve."""
    try:
        return json.loads((folder / "run.json").read_text()).get("model_size")
    except (OSError, json.JSONDecodeError):
        return None


def run_synthesize(options: SynthesisOptions, echo: Callable[[str], Any] = print) -> dict:
    """Solve the task's starts, verify every solution, and write ``solutions.parquet``, ``optima.parquet`` and
    ``run.json`` under ``options.folder``; the run summary."""
    from grasptask.grasp.settings import load_grasp_settings
    from grasptask.hand import load_hand
    from grasptask.objects import load_object
    from grasptask.synthesis import sweep
    from grasptask.synthesis.config import load_solver_config
    from grasptask.synthesis.starts import make_starts, subset
    from grasptask.task.model import load_task_models

    models = load_task_models(options.tasks)
    if options.task not in models:
        raise BadInputError(options.tasks, f"no task '{options.task}' (has: {', '.join(models)})")
    solver = load_solver_config(options.solver_config)
    load_grasp_settings(options.grasp_config)
    hand = load_hand(options.hand)
    obj = load_object(options.object)
    job = sweep.Job(
        hand_path=str(options.hand),
        object_path=str(options.object),
        tasks_path=str(options.tasks),
        task=options.task,
        backend=options.backend,
        solver=solver,
        settings_path=str(options.grasp_config),
    )
    paper = read_paper_synthesis()
    starts = subset(make_starts(obj.bounds(), options.seed), options.starts)
    folder = options.folder
    folder.mkdir(parents=True, exist_ok=True)
    log = folder / "solutions.jsonl"
    if not options.resume and log.exists():
        log.unlink()
    done = _read_done(log)
    finished = {row["start_id"] for row in done}
    todo = [s for s in starts if s.start_id not in finished]
    echo(f"{options.task}: {len(starts)} starts, {len(finished)} already done")
    model_size = None if todo else _previous_model_size(folder)
    wall_start = time.perf_counter()
    bar = tqdm(total=len(starts), initial=len(finished), desc=f"synthesize {options.task}", unit="start", disable=None)
    counts = {
        "verified": sum(r.get("verified", False) for r in done),
        "failing": sum(not r.get("verified", False) for r in done),
    }

    def on_model(size: dict[str, int]) -> None:
        nonlocal model_size
        if model_size is None:
            model_size = size
            with bar.external_write_mode():
                echo(
                    f"model {size['variables']} variables x {size['constraints']} constraints"
                    f" (paper: {paper.variables} x {paper.constraints})"
                )

    with open(log, "a") as handle, sweep.stop_on_sigint():

        def on_result(row: dict) -> None:
            handle.write(json.dumps(_jsonable(row)) + "\n")
            handle.flush()
            os.fsync(handle.fileno())
            done.append(row)
            counts["verified" if row.get("verified") else "failing"] += 1
            bar.set_postfix(counts)
            bar.update(1)

        hang_after = solver.time_limit + solver.hang_grace_s
        try:
            if options.executor == "dask":
                assert options.scheduler is not None  # checked by SynthesisOptions
                sweep.run_dask(job, todo, options.scheduler, on_result, hang_after, on_model)
            elif options.executor == "serial":
                sweep.run_serial(job, todo, on_result, on_model)
            else:
                sweep.run_pool(job, todo, options.workers, on_result, hang_after, on_model)
        finally:
            bar.close()
    wall = time.perf_counter() - wall_start
    return summarise(
        options,
        done,
        model_size=model_size,
        wall_seconds=wall,
        symmetry=obj.symmetry,
        fingers=list(hand.grasping),
        paper=paper,
    )


def summarise(
    options: SynthesisOptions,
    rows: list[dict],
    *,
    model_size: dict[str, int] | None,
    wall_seconds: float,
    symmetry: Symmetry | None,
    fingers: list[str],
    paper: PaperSynthesis,
) -> dict:
    """Write the sweep's ``solutions.parquet``, ``optima.parquet`` and ``run.json`` from its rows; the run
    summary."""
    import casadi
    import pyomo.version

    from grasptask.synthesis.clustering import cluster

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
        "sweep_wall_seconds_this_run": wall_seconds,
        "model_size": model_size,
        "paper": {
            "variables": paper.variables,
            "constraints": paper.constraints,
            "seconds_per_solution_mean": paper.mean_s,
            "seconds_per_solution_sd": paper.sd_s,
            "distinct_optima": paper.optima.get(options.task),
        },
        "versions": {"casadi": casadi.CasadiMeta.version(), "pyomo": pyomo.version.version},
    }
    config = {k: str(v) for k, v in asdict(options).items() if k != "out"}
    inputs = [options.tasks, options.hand, options.object, options.solver_config, options.grasp_config]
    with StagedOutput(options.folder, Provenance.of("synthesize", config, inputs, options.seed)) as staged:
        staged.write_parquet("solutions.parquet", solutions)
        staged.write_parquet("optima.parquet", optima)
        staged.write_json("run.json", run)
    return run
