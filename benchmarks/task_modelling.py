"""Speed of the task-modelling stages: fit-task on the 105 simulated recordings, fit-task throughput
on a 10-million-sample recording, and distances on 105 and 5,000 ellipsoids.

Each figure is the median of several runs. Baselines run in the same process: pandas' own CSV reader for
ingestion, and per-pair ``scipy.linalg.logm`` (two logs per pair instead of one per ellipsoid) for distances.

    python benchmarks/task_modelling.py            # prints a summary, writes benchmarks/results/task_modelling.json
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.linalg

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import median_seconds, save  # noqa: E402

from grasptask.stages import (  # noqa: E402
    DistanceOptions,
    FitTaskOptions,
    SimulateOptions,
    run_distances,
    run_fit_task,
    run_simulate,
)
from grasptask.task.distances import compute_distances  # noqa: E402
from grasptask.task.ellipsoid import second_moment  # noqa: E402
from grasptask.task.fit import ellipsoid_matrices, fit_entry  # noqa: E402
from grasptask.task.manifest import RecordingEntry  # noqa: E402
from grasptask.task.recordings import write_recording  # noqa: E402
from grasptask.task.spd import log_vectors, spd_exp  # noqa: E402

TARGET_SAMPLES_PER_S = 5e6
TARGET_DISTANCES_5000_S = 10.0


def big_recording(path: Path, n: int) -> None:
    rng = np.random.default_rng(0)
    t = np.arange(n) / 1000.0
    wrenches = rng.standard_normal((n, 6)) * [0.5, 0.5, 2.0, 0.01, 0.01, 0.003] + [0, 0, 1.5, 0, 0, 0]
    write_recording(path, np.column_stack([t, wrenches]))


def many_ellipsoids(table: pd.DataFrame, k: int) -> pd.DataFrame:
    """``k`` ellipsoids around the simulated ones: each a recorded one perturbed in log space."""
    rng = np.random.default_rng(1)
    logs = log_vectors(ellipsoid_matrices(table))
    pick = rng.integers(0, len(table), k)
    rows, cols = np.triu_indices(6)
    weights = np.where(rows == cols, 1.0, np.sqrt(2.0))
    vectors = logs[pick] + rng.normal(0, 0.1, (k, logs.shape[1]))
    log_matrices = np.zeros((k, 6, 6))
    log_matrices[:, rows, cols] = vectors / weights
    log_matrices[:, cols, rows] = vectors / weights
    out = table.iloc[pick].reset_index(drop=True).copy()
    out["id"] = [f"e{i}" for i in range(k)]
    out["S"] = list(spd_exp(log_matrices).reshape(k, 36))
    return out


def naive_pairwise_seconds(matrices: np.ndarray, pairs: int) -> float:
    """Seconds per pair for the textbook approach: logm of both matrices for every pair."""
    _, times = median_seconds(
        lambda: [
            np.linalg.norm(
                scipy.linalg.logm(matrices[i % len(matrices)])
                - scipy.linalg.logm(matrices[(i * 7 + 1) % len(matrices)])
            )
            for i in range(pairs)
        ],
        3,
    )
    return float(np.median(times)) / pairs


def main() -> dict:
    results: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for fmt in ("parquet", "csv"):
            run_simulate(SimulateOptions(out=tmp / f"rec_{fmt}", format=fmt))
            fit = FitTaskOptions(inputs=[tmp / f"rec_{fmt}" / "manifest.csv"], out=tmp / f"tasks_{fmt}")
            median, times = median_seconds(lambda fit=fit: run_fit_task(fit), 5)
            results[f"fit_task_105_{fmt}_s"] = {"median": median, "runs": times}
        table = pd.read_parquet(tmp / "tasks_parquet" / "ellipsoids.parquet")
        samples_105 = int(table["n_samples"].sum())
        results["samples_in_105_recordings"] = samples_105

        n = 10_000_000
        big = tmp / "big.parquet"
        big_recording(big, n)
        entry = RecordingEntry(id="big", path=big, task="t", subject="1", trial=1, grasp="free")
        median, times = median_seconds(lambda: fit_entry(entry), 3)
        results["fit_10M_parquet"] = {"samples": n, "median_s": median, "samples_per_s": n / median, "runs": times}
        median, times = median_seconds(lambda: run_fit_task(FitTaskOptions(inputs=[big], out=tmp / "big_out")), 3)
        results["fit_task_stage_10M_parquet"] = {
            "samples": n,
            "median_s": median,
            "samples_per_s": n / median,
            "note": "whole stage: reading, validation, ellipsoid, provenance hashes of the input, artifacts",
        }
        n_csv = 2_000_000
        big_csv = tmp / "big.csv"
        big_recording(big_csv, n_csv)
        csv_entry = RecordingEntry(id="bigcsv", path=big_csv, task="t", subject="1", trial=1, grasp="free")
        median, _ = median_seconds(lambda: fit_entry(csv_entry), 3)
        results["fit_2M_csv"] = {"samples": n_csv, "median_s": median, "samples_per_s": n_csv / median}

        def pandas_baseline():
            frame = pd.read_csv(big_csv)
            values = frame[["fx", "fy", "fz", "tx", "ty", "tz"]].to_numpy()
            return second_moment(values)

        median_baseline, _ = median_seconds(pandas_baseline, 3)
        results["baseline_pandas_csv_2M"] = {"median_s": median_baseline, "samples_per_s": n_csv / median_baseline}
        results["ratio_csv_ours_vs_pandas_default_reader"] = median_baseline / results["fit_2M_csv"]["median_s"]

        median, times = median_seconds(lambda: compute_distances(table).summary(), 5)
        results["distances_105_compute_s"] = {"median": median, "runs": times}
        small = DistanceOptions(ellipsoids=tmp / "tasks_parquet" / "ellipsoids.parquet", out=tmp / "d")
        median, _ = median_seconds(lambda: run_distances(small), 3)
        results["distances_105_stage_s"] = {"median": median, "note": "with distances.parquet, JSON and both PNGs"}

        large = many_ellipsoids(table, 5000)
        median, times = median_seconds(lambda: compute_distances(large).summary(), 3)
        results["distances_5000_compute_s"] = {"median": median, "runs": times}
        large_path = tmp / "large.parquet"
        large.to_parquet(large_path)
        median, _ = median_seconds(lambda: run_distances(DistanceOptions(ellipsoids=large_path, out=tmp / "dl")), 1)
        results["distances_5000_stage_s"] = {
            "median": median,
            "note": "single run; writes 25 million distance rows, heatmap and embedding",
        }

        per_pair = naive_pairwise_seconds(ellipsoid_matrices(table), 200)
        results["baseline_naive_logm_per_pair_s"] = per_pair
        results["baseline_naive_5000_estimated_s"] = per_pair * 5000 * 4999 / 2
        results["ratio_distances_5000_naive_vs_ours"] = (
            results["baseline_naive_5000_estimated_s"] / results["distances_5000_compute_s"]["median"]
        )

    results["targets"] = {
        "fit_task_samples_per_s": TARGET_SAMPLES_PER_S,
        "fit_10M_parquet_meets_target": results["fit_10M_parquet"]["samples_per_s"] >= TARGET_SAMPLES_PER_S,
        "distances_5000_s": TARGET_DISTANCES_5000_S,
        "distances_5000_meets_target": results["distances_5000_compute_s"]["median"] < TARGET_DISTANCES_5000_S,
        "paper": "the paper reports no timings for task modelling",
    }
    return results


def report(results: dict) -> str:
    r = results
    return "\n".join(
        [
            f"fit-task, 105 recordings ({r['samples_in_105_recordings']:,} samples): "
            f"{r['fit_task_105_parquet_s']['median']:.2f} s (Parquet), {r['fit_task_105_csv_s']['median']:.2f} s (CSV)",
            f"fit on 10M samples (Parquet): {r['fit_10M_parquet']['median_s']:.2f} s = "
            f"{r['fit_10M_parquet']['samples_per_s'] / 1e6:.1f} M samples/s (target >= 5); whole stage "
            f"{r['fit_task_stage_10M_parquet']['samples_per_s'] / 1e6:.1f} M samples/s",
            f"fit on 2M samples (CSV): {r['fit_2M_csv']['samples_per_s'] / 1e6:.1f} M samples/s; "
            f"pandas default reader {r['baseline_pandas_csv_2M']['samples_per_s'] / 1e6:.1f} M samples/s "
            f"(ours x{r['ratio_csv_ours_vs_pandas_default_reader']:.1f})",
            f"distances, 105 ellipsoids: {r['distances_105_compute_s']['median'] * 1e3:.1f} ms compute, "
            f"{r['distances_105_stage_s']['median']:.2f} s whole stage",
            f"distances, 5,000 ellipsoids: {r['distances_5000_compute_s']['median']:.2f} s compute (target < 10 s), "
            f"{r['distances_5000_stage_s']['median']:.1f} s whole stage; per-pair logm baseline would take "
            f"~{r['baseline_naive_5000_estimated_s'] / 3600:.1f} h (x{r['ratio_distances_5000_naive_vs_ours']:.0f})",
        ]
    )


if __name__ == "__main__":
    results = main()
    print(report(results))
    print(f"saved {save('task_modelling', results)}")
