from __future__ import annotations

import os
import tempfile

import numpy as np
import pytest
from click.testing import CliRunner

from grasptask.cli import main
from grasptask.stages import (
    DistanceOptions,
    FitTaskOptions,
    SimulateOptions,
    run_distances,
    run_fit_task,
    run_simulate,
)
from grasptask.task.recordings import write_recording

# the suite keeps its convex parts and distance grids in a folder of its own, not in the developer's ~/.cache
os.environ.setdefault("GRASPTASK_CACHE", tempfile.mkdtemp(prefix="grasptask-test-cache-"))


@pytest.fixture(scope="session")
def simulated(tmp_path_factory):
    """The bundled simulator's 105 recordings (seed 0, Parquet), fit-task and distances on them."""
    root = tmp_path_factory.mktemp("simulated")
    run_simulate(SimulateOptions(out=root / "recordings", format="parquet"))
    fitted = run_fit_task(FitTaskOptions(inputs=[root / "recordings" / "manifest.csv"], out=root / "tasks"))
    run_distances(DistanceOptions(ellipsoids=root / "tasks" / "ellipsoids.parquet", out=root / "tasks"))
    return root, fitted, fitted.stats


@pytest.fixture(scope="session")
def tasks(simulated):
    """The task models fitted to :func:`simulated`'s recordings."""
    return simulated[0] / "tasks" / "task_models.json"


@pytest.fixture
def cli():
    """Invoke ``grasptask`` in-process; returns the click Result."""
    runner = CliRunner()

    def invoke(*args):
        return runner.invoke(main, [str(a) for a in args], catch_exceptions=False)

    return invoke


def wrench_samples(n: int = 200, seed: int = 0, rate: float = 100.0) -> np.ndarray:
    """A well-conditioned ``(n, 7)`` recording: time plus six independent, non-zero wrench channels."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    scales = np.array([1.0, 0.7, 2.0, 0.02, 0.03, 0.01])
    wrenches = rng.standard_normal((n, 6)) * scales + np.array([0.1, 0, 1.5, 0, 0, 0])
    return np.column_stack([t, wrenches])


@pytest.fixture
def recording_factory(tmp_path):
    """Write a valid recording (CSV or Parquet) and return its path."""

    def make(name: str = "rec.csv", data: np.ndarray | None = None, seed: int = 0):
        path = tmp_path / name
        write_recording(path, wrench_samples(seed=seed) if data is None else data)
        return path

    return make
