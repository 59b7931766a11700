"""Grasp synthesis: for drawing, cutting and screw driving on the sensorized-tool cylinder, 126 starts each on 2
workers: seconds per start (median, p90), the fraction of starts ending in a verified grasp, distinct optima and
the wall time of the whole sweep; the cyipopt backend's median on a subset of the same starts, as a ratio; an
in-run baseline, the same starts solved without placement (IPOPT from the far-away start), as ratios; and
whether the optima differ between tasks as the paper's Section 7.3 describes.

    python benchmarks/synthesis.py [--starts N] [--cyipopt-starts N] [--baseline-starts N] [--reference-starts N]
                                   [--solver YAML] [--seed N]      # writes benchmarks/results/synthesis.json

``--seed`` is the starts' jitter (``grasptask synthesize --seed``): a task's best Q can rest on one or two of
its 126 starts, and other seeds tell how often a route finds it.

Targets: median <= 1 s per start (paper: 459 +- 186 s), >= 80% verified, whole 3 x 126 sweep < 10 minutes; and
the fast route's: median <= 0.3 s per task, >= 90% verified, the sweep <= 3 minutes, distinct optima >= the
paper's. Those seconds depend on the machine (the same code's medians were up to 2x apart on two machines), so
the route before the geometric phase (commit 8ae7ea6, taken from git) also solves some of the same starts, each
task's right after its sweep: the speed-up over it is a ratio measured on one machine, beside the ratio that
0.3 s asks of that route's medians on the first machine (BEFORE_MEDIANS_S). The prerequisites (the solver
config, cyipopt for its comparison, git and the earlier commit) are checked before anything runs; each task's
figures are printed and the results saved as soon as its sweep is done.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from scipy.stats import bootstrap

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT)]
from common import check_solver, demonstration_tasks, save, solver_option, time_shares  # noqa: E402

from grasptask.io.config_schema import load_yaml  # noqa: E402
from grasptask.records.reference import read_paper_synthesis  # noqa: E402
from grasptask.records.solutions import contacts_from_row, palm_normal_from_row  # noqa: E402
from grasptask.stages import SynthesisOptions, run_synthesize  # noqa: E402

PAPER_GRASP = Path(__file__).resolve().parents[1] / "configs" / "grasp_paper.yaml"
PAPER_HAND = Path(__file__).resolve().parents[1] / "configs" / "hands" / "human_paper.yaml"
TASKS = ("drawing", "cutting", "screwdriving")
#: the route before the geometric phase, the held turn and eq. 10 on four axes: its commit, and its medians
#: (s per start) on the first 2-core machine, which the 0.3 s target was set against
BEFORE_COMMIT = "8ae7ea6"
BEFORE_MEDIANS_S = {"drawing": 0.9608, "cutting": 0.5584, "screwdriving": 0.7279}


def grasp_shape(optima: pd.DataFrame) -> dict:
    """Section 7.3 descriptors of the best (lowest-Q) optimum: where along the handle the fingers hold it, how
    far around the axis they spread, and how parallel the palm is to the handle."""
    if optima.empty:
        return {}
    best = optima.iloc[0]
    fingers = ("thumb", "index", "middle")
    contacts = contacts_from_row(best, list(fingers))
    azimuth = np.sort(np.arctan2(contacts[:, 1], contacts[:, 0]))
    gaps = np.diff(np.concatenate([azimuth, azimuth[:1] + 2 * np.pi]))
    palm_normal = palm_normal_from_row(best)
    return {
        "Q": float(best["Q"]),
        "mean_abs_contact_z_m": float(np.abs(contacts[:, 2]).mean()),
        "contact_spread_around_axis_deg": float(np.degrees(2 * np.pi - gaps.max())),
        "palm_normal_along_axis": float(abs(palm_normal[2])),
    }


def median_interval(seconds: np.ndarray) -> list[float]:
    """A 95% bootstrap interval of the median over the starts. IPOPT's iteration count on a start changes with
    rounding-level changes of its initial point (107 of drawing's 126 starts changed when placement's arithmetic
    was reordered), so which starts happen to be fast varies between otherwise equal runs."""
    result = bootstrap((seconds,), np.median, confidence_level=0.95, method="percentile", random_state=0)
    interval = result.confidence_interval
    return [float(interval.low), float(interval.high)]


def check_prerequisites(solver: Path, cyipopt_starts: int, reference_starts: int = 0) -> None:
    """Fail in one line, before any sweep, on what would otherwise fail minutes into the run."""
    check_solver(solver)
    if reference_starts:
        try:
            found = subprocess.run(["git", "-C", str(ROOT), "cat-file", "-e", f"{BEFORE_COMMIT}^{{commit}}"]).returncode
        except FileNotFoundError:  # no git
            found = 1
        if found:
            raise SystemExit(
                f"commit {BEFORE_COMMIT} (the route before the geometric phase) is not in this clone: "
                "fetch the history, or pass --reference-starts 0"
            )
    if cyipopt_starts:
        try:
            import cyipopt  # noqa: F401
        except ImportError:
            raise SystemExit(
                "cyipopt is not installed: run `make setup-cyipopt`, or pass --cyipopt-starts 0 to skip that comparison"
            ) from None


class ReferenceCode:
    """The route before the geometric phase, taken out of git into ``folder``, with the task models its own
    simulator and fit made (as its benchmark did); :meth:`sweep` solves a subset of one task's starts in a
    subprocess."""

    def __init__(self, folder: Path):
        self.code = folder / "code"
        self.code.mkdir(parents=True)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", BEFORE_COMMIT], capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(self.code)], input=archive.stdout, check=True)
        self.env = {**os.environ, "PYTHONPATH": str(self.code), "OPENBLAS_NUM_THREADS": "1"}
        self.cli("simulate", "--out", str(folder / "rec"), "--format", "parquet")
        self.cli("fit-task", str(folder / "rec" / "manifest.csv"), "--out", str(folder / "tasks"))
        self.tasks, self.out = folder / "tasks" / "task_models.json", folder / "grasps"

    def cli(self, *args: str) -> None:
        command = [sys.executable, "-m", "grasptask.cli", *args]
        subprocess.run(command, cwd=self.code, env=self.env, check=True, stdout=subprocess.DEVNULL)

    def sweep(self, task: str, starts: int, seed: int) -> pd.DataFrame:
        print(f"{task}: the route before the geometric phase ({BEFORE_COMMIT}) on {starts} starts")
        self.cli(
            "synthesize", "--tasks", str(self.tasks), "--task", task, "--out", str(self.out),
            "--starts", str(starts), "--seed", str(seed), "--workers", "2",
        )  # fmt: skip
        return pd.read_parquet(self.out / task / "solutions.parquet")


def main(
    n_starts: int | None,
    cyipopt_starts: int,
    baseline_starts: int,
    solver: Path,
    name: str,
    seed: int = 0,
    reference_starts: int = 0,
) -> dict:
    """The sweeps, each task's figures printed and the results saved as soon as each sweep is done."""
    results: dict = {"solver_config": str(solver), "seed": seed, "tasks": {}}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        tasks = demonstration_tasks(tmp)
        unplaced = tmp / "solver_unplaced.yaml"
        unplaced.write_text(yaml.safe_dump({**load_yaml(solver), "placement": False}))

        def options(task, out, backend="casadi", starts=n_starts, workers=2, config=solver):
            return SynthesisOptions(
                tasks=tasks,
                task=task,
                out=out,
                solver_config=config,
                grasp_config=PAPER_GRASP,  # the paper's contact model and hand, whose Section 7.3 the run checks
                hand=PAPER_HAND,
                starts=starts,
                workers=workers,
                backend=backend,
                seed=seed,
            )

        reference = ReferenceCode(tmp / "reference") if reference_starts else None
        sweeps = 0.0
        for task in TASKS:
            began = time.perf_counter()
            run = run_synthesize(options(task, tmp / "grasps"), echo=print).run
            sweeps += time.perf_counter() - began
            optima = pd.read_parquet(tmp / "grasps" / task / "optima.parquet")
            results["tasks"][task] = {
                "starts": run["starts"],
                "median_s_per_start": run["seconds_per_start"]["median"],
                "median_95pct_bootstrap_s": median_interval(
                    pd.read_parquet(tmp / "grasps" / task / "solutions.parquet")["seconds"].to_numpy()
                ),
                "p90_s_per_start": run["seconds_per_start"]["p90"],
                "verified_fraction": run["verified_fraction"],
                "distinct_optima": run["distinct_optima"],
                "best_Q": run["best_Q"],
                "all_axes_starts": run.get("all_axes_starts", 0),
                "status_counts": run["status_counts"],
                "sweep_wall_s": run["sweep_wall_seconds_this_run"],
                "best_optimum": grasp_shape(optima),
                # what a user waits for, and where the sweep's time went by kind of start (issue: five times sooner)
                "throughput": run.get("throughput"),
                "time_shares": time_shares(tmp / "grasps" / task),
            }
            print(task_line(task, results["tasks"][task]))
            if reference is not None:  # right after the sweep, so that both see the machine as it is now
                results["tasks"][task]["route_before_geometric_phase"] = beside_default(
                    reference.sweep(task, reference_starts, seed), solutions(tmp / "grasps", task)
                )
            save(name, results)
        # the three tasks' sweeps one after the other, as a user runs them
        results["whole_sweep_wall_s"] = sweeps

        def against_default(task: str, name: str, options_: SynthesisOptions) -> dict:
            """A variant's run on a subset of the starts, beside the default run on the same starts."""
            run_synthesize(options_, echo=print)
            return beside_default(solutions(tmp / name, task), solutions(tmp / "grasps", task))

        for task in TASKS:
            if baseline_starts:
                results["tasks"][task]["baseline_without_placement"] = against_default(
                    task, "unplaced", options(task, tmp / "unplaced", starts=baseline_starts, config=unplaced)
                )
            if cyipopt_starts:
                results["tasks"][task]["cyipopt"] = against_default(
                    task, "cyipopt", options(task, tmp / "cyipopt", "cyipopt", cyipopt_starts)
                )
            if baseline_starts or cyipopt_starts or reference_starts:
                print(comparison_line(task, results["tasks"][task]))
                save(name, results)
    shapes = {t: results["tasks"][t]["best_optimum"] for t in TASKS}
    if all(shapes.values()):
        results["section_7_3"] = {
            "screwdriving_holds_nearer_the_middle_than_drawing": shapes["screwdriving"]["mean_abs_contact_z_m"]
            < shapes["drawing"]["mean_abs_contact_z_m"],
            "cutting_palm_more_parallel_to_the_handle_than_screwdriving": shapes["cutting"]["palm_normal_along_axis"]
            < shapes["screwdriving"]["palm_normal_along_axis"],
            "drawing_grasp_near_one_end": shapes["drawing"]["mean_abs_contact_z_m"] > 0.04,
        }
    paper = read_paper_synthesis()
    medians = [results["tasks"][t]["median_s_per_start"] for t in TASKS]
    verified = [results["tasks"][t]["verified_fraction"] for t in TASKS]
    wall = results["whole_sweep_wall_s"]
    results["targets"] = {
        **met(medians, verified, wall, median_s=1.0, fraction=0.8, sweep_s=600),
        "paper_seconds_per_solution": paper.seconds,
        "ratio_paper_mean_vs_our_median": paper.mean_s / float(np.median(medians)),
    }
    # the speed targets set against the route before the geometric phase
    results["targets_fast"] = {
        **met(medians, verified, wall, median_s=0.3, fraction=0.9, sweep_s=180),
        "paper_distinct_optima": paper.optima,
        "distinct_optima_met": all(results["tasks"][t]["distinct_optima"] >= paper.optima.get(t, 0) for t in TASKS),
    }
    if reference_starts:
        results["targets_fast"]["as_ratios"] = ratio_targets(results["tasks"])
    return results


def solutions(folder: Path, task: str) -> pd.DataFrame:
    return pd.read_parquet(folder / task / "solutions.parquet")


def beside_default(variant: pd.DataFrame, default: pd.DataFrame) -> dict:
    """A variant's sweep of a subset of the starts, beside the default sweep's rows for the same starts."""
    same = default[default["start_id"].isin(variant["start_id"])]
    median = float(variant["seconds"].median())
    return {
        "starts": len(variant),
        "median_s_per_start": median,
        "verified_fraction": float(variant["verified"].mean()),
        "default_median_same_starts_s": float(same["seconds"].median()),
        "default_verified_fraction_same_starts": float(same["verified"].mean()),
        "ratio_median_vs_default": median / float(same["seconds"].median()),
        # the starts' seconds in all, which on the same workers is what a sweep's wall time follows
        "ratio_total_vs_default": float(variant["seconds"].sum() / same["seconds"].sum()),
    }


def ratio_targets(tasks: dict) -> dict:
    """The 0.3 s target as the ratio it asks of the earlier route's median per task, beside the ratio measured
    in this run (the shipped route's median over the earlier route's, on the same starts)."""
    ratios = {}
    for task, figures in tasks.items():
        asked = 0.3 / BEFORE_MEDIANS_S[task]
        measured = figures["route_before_geometric_phase"]["ratio_median_vs_default"] ** -1
        ratios[task] = {"asked": asked, "measured": measured, "met": measured <= asked}
    return ratios


def met(medians: list, verified: list, wall_s: float, median_s: float, fraction: float, sweep_s: float) -> dict:
    """Targets on every task's median and verified fraction and on the whole sweep's wall time, and whether met."""
    return {
        "median_s_per_start": median_s,
        "median_met": max(medians) <= median_s,
        "verified_fraction": fraction,
        "verified_met": min(verified) >= fraction,
        "whole_sweep_s": sweep_s,
        "whole_sweep_met": wall_s <= sweep_s,
    }


def task_line(task: str, t: dict) -> str:
    low, high = t["median_95pct_bootstrap_s"]
    kinds = (t.get("time_shares") or {"kinds": {}})["kinds"].items()  # absent from results saved before it
    shares = ", ".join(f"{kind} {v['share']:.0%}" for kind, v in kinds if v["share"] is not None)
    return (
        f"{task}: {t['starts']} starts, median {t['median_s_per_start']:.2f} s (95% bootstrap {low:.2f}-{high:.2f}, "
        f"p90 {t['p90_s_per_start']:.2f}), {t['verified_fraction']:.0%} verified, {t['distinct_optima']} distinct "
        f"optima, best Q {t['best_Q']:.5f}, {t['sweep_wall_s']:.0f} s; time: {shares}"
    )


def comparison_line(task: str, t: dict) -> str:
    cy, base = t.get("cyipopt", {}), t.get("baseline_without_placement", {})
    ref = t.get("route_before_geometric_phase", {})
    nan = float("nan")
    reference = (
        f"; the route before the geometric phase on {ref['starts']} starts: median {ref['median_s_per_start']:.2f} s, "
        f"{ref['verified_fraction']:.0%} verified (shipped, same starts: {ref['default_median_same_starts_s']:.2f} "
        f"s, x{1 / ref['ratio_median_vs_default']:.2f})"
        if ref
        else ""
    )
    return (
        f"{task}: cyipopt median {cy.get('median_s_per_start', nan):.2f} s on {cy.get('starts', 0)} of the starts "
        f"(x{cy.get('ratio_median_vs_default', nan):.2f} CasADi's); without placement on {base.get('starts', 0)} "
        f"starts: median {base.get('median_s_per_start', nan):.2f} s, {base.get('verified_fraction', nan):.0%} "
        f"verified (placed, same starts: {base.get('default_median_same_starts_s', nan):.2f} s, "
        f"{base.get('default_verified_fraction_same_starts', nan):.0%}){reference}"
    )


def markdown_table(r: dict) -> str:
    """The results as the docs show them: one row per task, then the sweep's wall time and the paper's figure."""
    lines = [
        "| task | median s per start (95% interval) | p90 s | verified | distinct optima | best Q "
        "| the route before the geometric phase, same starts |",
        "|---|---|---|---|---|---|---|",
    ]
    for task, t in r["tasks"].items():
        low, high = t["median_95pct_bootstrap_s"]
        ref = t.get("route_before_geometric_phase")
        before = f"{ref['median_s_per_start']:.2f} s ({1 / ref['ratio_median_vs_default']:.1f}x slower)" if ref else "-"
        best_q = t.get("best_Q", t["best_optimum"].get("Q", float("nan")))
        lines.append(
            f"| {task} | {t['median_s_per_start']:.2f} ({low:.2f}-{high:.2f}) | {t['p90_s_per_start']:.2f} | "
            f"{t['verified_fraction']:.0%} | {t['distinct_optima']} | {best_q:.5f} | {before} |"
        )
    targets = r["targets"]
    lines += [
        "",
        f"The three sweeps took {r['whole_sweep_wall_s'] / 60:.1f} min on 2 workers. The paper reports "
        f"{targets['paper_seconds_per_solution']} per solution, {targets['ratio_paper_mean_vs_our_median']:.0f}x "
        "the median here.",
    ]
    return "\n".join(lines)


def report(r: dict) -> str:
    lines = [task_line(task, t) for task, t in r["tasks"].items()]
    lines += [
        comparison_line(task, t)
        for task, t in r["tasks"].items()
        if "cyipopt" in t or "baseline_without_placement" in t or "route_before_geometric_phase" in t
    ]
    lines.append(f"whole sweep on 2 workers: {r['whole_sweep_wall_s'] / 60:.1f} min (target < 10 min)")
    if "targets_fast" in r:
        lines.append(f"targets against the route before the geometric phase: {r['targets_fast']}")
    lines.append(f"Section 7.3: {r.get('section_7_3')}")
    targets = r["targets"]
    lines.append(
        f"paper: {targets['paper_seconds_per_solution']} per solution, "
        f"ours x{targets['ratio_paper_mean_vs_our_median']:.0f} faster (median)"
    )
    return "\n".join(lines)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--starts", type=int, default=None, help="starts per task (default: all 126)")
    parser.add_argument("--cyipopt-starts", type=int, default=12, help="starts per task for the cyipopt comparison")
    parser.add_argument("--baseline-starts", type=int, default=24, help="starts per task solved without placement")
    parser.add_argument("--reference-starts", type=int, default=42, help="starts per task solved by the earlier route")
    solver_option(parser)
    parser.add_argument("--seed", type=int, default=0, help="seed of the starts' jitter (default: 0, as shipped)")
    args = parser.parse_args()
    check_prerequisites(args.solver, args.cyipopt_starts, args.reference_starts)
    results = main(
        args.starts,
        args.cyipopt_starts,
        args.baseline_starts,
        args.solver,
        "synthesis",
        args.seed,
        args.reference_starts,
    )
    print(report(results))
    print(f"saved {save('synthesis', results)}")
