"""Timing helpers shared by the benchmark scripts: medians of repeated runs, JSON output, machine facts."""

from __future__ import annotations

import json
import os
import platform
import statistics
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).resolve().parent / "results"
DEFAULT_SOLVER = Path(__file__).resolve().parents[1] / "configs" / "solver.yaml"


def median_seconds(function: Callable[[], object], repeats: int) -> tuple[float, list[float]]:
    """Median wall time of ``repeats`` calls, and every time."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times), times


def cpu() -> dict:
    """The processor's name and widest vector extension, from /proc/cpuinfo (None where there is none): the
    same code's medians differed up to 2x between two machines of this workplace, so a results file says which."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return {"model": None, "simd": None}
    fields = dict(line.split(":", 1) for line in lines if ":" in line)
    fields = {key.strip(): value.strip() for key, value in fields.items()}
    flags = set(fields.get("flags", "").split())
    simd = next((name for name in ("avx512f", "avx2", "avx", "sse4_2") if name in flags), None)
    return {"model": fields.get("model name"), "simd": simd}


#: the libraries whose version changes a solve or a physics verdict (none is pinned)
SOLVING_PACKAGES = ("casadi", "cyipopt", "pyomo", "numpy", "scipy", "trimesh", "coacd", "mujoco", "quadprog")


def packages() -> dict:
    """Each of :data:`SOLVING_PACKAGES`' installed version (None where it is not installed): a fresh install
    takes the newest, so a results file says which it was measured with."""
    from importlib import metadata

    def version(name: str) -> str | None:
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            return None

    return {name: version(name) for name in SOLVING_PACKAGES}


def commit() -> str | None:
    """The checkout's commit, with "+changes" when files differ from it (None outside a git checkout)."""
    root = Path(__file__).resolve().parents[1]
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, check=True)
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                               capture_output=True, text=True, check=True)  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return None
    return head.stdout.strip() + ("+changes" if dirty.stdout.strip() else "")


def blas_kernels() -> str | None:
    """The kernels numpy's OpenBLAS chose for this CPU (``OPENBLAS_CORETYPE`` overrides them): a scan's sweep
    depends on its inputs' last bits, and these change them (docs/design/objects.md)."""
    import numpy  # noqa: F401  (loads the library threadpoolctl reads)
    from threadpoolctl import threadpool_info

    return next((pool.get("architecture") for pool in threadpool_info() if pool["user_api"] == "blas"), None)


def machine() -> dict:
    return {
        "cpus": os.cpu_count(),
        "cpu": cpu(),
        "numpy_blas_kernels": blas_kernels(),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "openblas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
        "packages": packages(),
        "commit": commit(),
    }


def save(name: str, payload: dict) -> Path:
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / f"{name}.json"
    path.write_text(json.dumps({**payload, "machine": machine()}, indent=2) + "\n")
    return path


def demonstration_tasks(folder: Path, seed: int = 0) -> Path:
    """The bundled simulator's 105 recordings (of ``seed``) fitted into task models: their task_models.json."""
    from grasptask.stages import FitTaskOptions, SimulateOptions, run_fit_task, run_simulate

    root = Path(__file__).resolve().parents[1]
    simulated = SimulateOptions(out=folder / "rec", config=root / "configs/simulate.yaml", seed=seed, format="parquet")
    run_simulate(simulated)
    run_fit_task(FitTaskOptions(inputs=[folder / "rec" / "manifest.csv"], out=folder / "tasks"))
    return folder / "tasks" / "task_models.json"


def finished_sweep(folder: Path) -> tuple[dict, Any]:
    """A finished sweep's run.json and solutions table."""
    import pandas as pd

    return json.loads((folder / "run.json").read_text()), pd.read_parquet(folder / "solutions.parquet")


def save_and_print(name: str, results: dict, table: Callable[[dict], str]) -> None:
    print(f"saved {save(name, results)}")
    print(table(results))


def sweep_parser(description: str, name: str) -> Any:
    """The options every sweep benchmark takes: --starts and --table. Each benchmark writes one results file,
    benchmarks/results/NAME.json, which git keeps the history of."""
    import argparse

    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--starts", type=int, default=None, help="starts per task (default: all 126)")
    parser.add_argument("--table", action="store_true", help=f"print the saved {name}.json as a table")
    parser.set_defaults(name=name)
    return parser


def solver_option(parser: Any) -> None:
    parser.add_argument("--solver", type=Path, default=DEFAULT_SOLVER, help="solver settings (YAML)")


def check_solver(path: Path) -> None:
    """One line and exit, before any sweep, when the solver config cannot be read."""
    from grasptask.errors import BadInputError
    from grasptask.synthesis.solver_config import load_solver_config

    try:
        load_solver_config(path)
    except (BadInputError, OSError) as exc:
        raise SystemExit(f"solver config: {exc}") from None


def print_saved(name: str, table: Callable[[dict], str]) -> None:
    print(table(json.loads((RESULTS / f"{name}.json").read_text())))


def ratios_to(entries: dict, reference: str, key: str) -> None:
    """Each sweep's median over the ``reference`` entry's median for the same task, stored as ``key`` (None
    when the reference lacks that task)."""
    base = entries.get(reference, {}).get("tasks", {})
    for entry in entries.values():
        for task, figures in entry["tasks"].items():
            median = base.get(task, {}).get("median_s_per_start")
            figures[key] = figures["median_s_per_start"] / median if median else None


def first_attempt_figures(solutions: Any) -> dict:
    """What the sweep would have been without the retry postures, from the same run: the first attempt's median
    seconds and verified fraction, and how many starts were retried (columns absent: no retries were made)."""
    from grasptask.records.solutions import retried

    if "first_attempt_seconds" not in solutions:
        return {"median_s_per_start": None, "verified_fraction": None, "retried_starts": 0}
    seconds = solutions["first_attempt_seconds"].fillna(solutions["seconds"])
    verified = solutions["first_attempt_verified"].fillna(False).astype(bool)
    return {
        "median_s_per_start": float(seconds.median()),
        "verified_fraction": float(verified.mean()),
        "retried_starts": int(retried(solutions).sum()),
    }


def time_shares(folder: Path) -> dict:
    """Where a finished sweep's solver time went, by kind of start: verified at its first attempt as solved,
    verified after the verifier's feedback or the all-axes solve, verified on a retry posture, never verified;
    and, across those, verified starts that solved to an optimum an earlier start (by start id) had already
    found. Per kind: starts, summed seconds and their share of the sweep's; and the median iterations of all starts
    (a start's seconds include placement and every attempt; objects.py's sweep figures give ms per iteration)."""
    import numpy as np
    import pandas as pd

    from grasptask.objects import load_object
    from grasptask.records.solutions import retried, solved_with_all_axes
    from grasptask.synthesis.clustering import labels

    run, solutions = finished_sweep(folder)
    solutions = solutions.sort_values("start_id").reset_index(drop=True)
    verified = solutions["verified"].fillna(False).astype(bool).to_numpy()
    again = retried(solutions)
    rescued = solved_with_all_axes(solutions) | (solutions.get("feedback_rounds", 0) > 0)
    refound = np.zeros(len(solutions), dtype=bool)
    if verified.any():
        symmetry = load_object(run["object"], say=lambda _: None, **(run.get("object_options") or {})).symmetry
        label = labels(solutions[verified], list(run["fingers"]), symmetry)
        refound[np.flatnonzero(verified)] = pd.Series(label).duplicated().to_numpy()  # an earlier start's optimum
    kinds = {
        "verified_first_attempt": verified & ~again & ~rescued,
        "verified_after_feedback": verified & ~again & rescued,
        "verified_on_retry": verified & again,
        "never_verified": ~verified,
        "refound_optimum": refound,
    }
    seconds = solutions["seconds"].to_numpy(dtype=float)
    total = float(np.nansum(seconds))
    shares = {
        kind: {
            "starts": int(mask.sum()),
            "seconds": float(np.nansum(seconds[mask])),
            "share": float(np.nansum(seconds[mask]) / total) if total else None,
        }
        for kind, mask in kinds.items()
    }
    iterations = solutions["iterations"].to_numpy(dtype=float)
    return {"kinds": shares, "median_iterations": float(np.median(iterations))}


def held(sweep: Path, tasks: Path, task: str, out: Path) -> dict:
    """The physics judge on one sweep's grasps: the share of the verified ones it holds, and for each verified one
    it drops, why (the pad that slipped, its friction use, MuJoCo's normal against the object's there)."""
    from grasptask.stages import PhysicsOptions, run_physics

    began = time.perf_counter()
    options = PhysicsOptions(solutions=sweep / "solutions.parquet", out=out, workers=2, tasks=tasks, task=task)
    table = run_physics(options).table
    solved = table[table["physics_passed"].notna()]
    verified = solved[solved["verified"].astype(bool)]
    return {
        "held_of_verified": float(verified["physics_passed"].astype(bool).mean()) if len(verified) else None,
        "seconds_per_grasp_median": float(solved["physics_seconds"].median()) if len(solved) else None,
        "wall_s": time.perf_counter() - began,
        "dropped": [
            {
                "start_id": int(row["start_id"]),
                "why": row["physics_why"],
                "slip_friction_use": _figure(row["physics_slip_friction_use"]),
                "slip_normal_off_deg": _figure(row["physics_slip_normal_off_deg"]),
            }
            for _, row in verified[~verified["physics_passed"].astype(bool)].iterrows()
        ],
    }


def _figure(value: float) -> float | None:
    """A figure for JSON: None for NaN."""
    return None if value != value else round(float(value), 4)


def held_cell(figures: dict) -> str:
    """A table cell for :func:`held`'s share of a sweep's figures: "-" where physics did not run or had nothing to
    hold."""
    share = figures.get("physics", {}).get("held_of_verified")
    return "-" if share is None else f"{share:.0%}"


def first_attempt_cell(figures: dict | None) -> str:
    """A table cell for :func:`first_attempt_figures`: "-" for a sweep without retries."""
    if not figures or figures["median_s_per_start"] is None:
        return "-"
    return f"{figures['median_s_per_start']:.2f}, {figures['verified_fraction']:.0%}"


def span(values: list, form: str = ".0%") -> str:
    """The range of the figures given, as the docs print it ("93-100%"); None figures left out."""
    shown = [v for v in values if v is not None]
    if not shown:
        return "-"
    low, high = format(min(shown), form), format(max(shown), form)
    return low if low == high else f"{low.rstrip('%')}-{high}"
