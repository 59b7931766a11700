"""A sweep's rows depend on its seed, hand, object and settings, never on how busy the machine is or on how
many workers solve it: every solve stops on its iterations, not on the clock."""

from __future__ import annotations

import os
import platform
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pandas as pd
import pytest

from grasptask.errors import BadInputError
from grasptask.stages import SynthesisOptions, run_synthesize
from grasptask.synthesis.solver_config import load_solver_config

#: a few iterations a start: rows stopped mid-way are the likeliest to show a difference of load, if there were one
TINY = Path("tests/data/solver_tiny.yaml")


def quiet(_: str) -> None:
    pass


@contextmanager
def busy_cores(count: int) -> Iterator[None]:
    """``count`` processes that keep a core busy each, for the duration."""
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(count)]
    try:
        yield
    finally:
        for spinner in spinners:
            spinner.kill()
            spinner.wait()


def rows(folder: Path) -> pd.DataFrame:
    """What a start's result is: its status, iterations, verdict, Q and grasp; not its seconds."""
    table = pd.read_parquet(folder / "cutting" / "solutions.parquet")
    grasp = [c for c in table.columns if c.startswith(("palm_", "q_", "contact_"))]
    kept = ["start_id", "status", "iterations", "verified", "Q", "verify_Q", *grasp]
    return table[kept].sort_values("start_id").reset_index(drop=True)


def test_a_sweeps_rows_are_the_same_with_two_workers_and_with_one_beside_busy_cores(tasks, tmp_path):
    """benchmarks/busy_machine.py runs twelve starts with 2 workers, 1, and 2 beside six busy processes."""
    common = {"tasks": tasks, "task": "cutting", "solver_config": TINY, "starts": 3}
    run_synthesize(SynthesisOptions(**common, out=tmp_path / "two", workers=2), echo=quiet)
    with busy_cores(2):
        run_synthesize(SynthesisOptions(**common, out=tmp_path / "busy", workers=1), echo=quiet)
    two = rows(tmp_path / "two")
    assert len(two) == 3 and two["status"].isin(["optimal", "acceptable", "infeasible", "max-iter"]).all()
    pd.testing.assert_frame_equal(rows(tmp_path / "busy"), two)


@pytest.mark.parametrize("option", ["max_wall_time", "max_cpu_time"])
def test_a_clock_limit_on_a_solve_is_refused(tmp_path, option):
    path = tmp_path / "solver.yaml"
    path.write_text(f"ipopt: {{{option}: 30.0}}\n")
    with pytest.raises(BadInputError, match=f"solver.yaml: field 'ipopt': {option} would stop a solve on"):
        load_solver_config(path)


def test_the_shipped_settings_stop_on_iterations_and_guard_hung_workers_far_above_any_solve():
    solver = load_solver_config("configs/solver.yaml")
    assert "max_wall_time" not in solver.ipopt and solver.ipopt["max_iter"] == 1500
    assert solver.hang_after_s >= 600


def test_a_benchmarks_results_say_which_libraries_and_commit_measured_them():
    """Nothing is pinned, so a fresh install takes the newest solver and physics libraries: a results file
    records their versions and the commit beside the machine."""
    import numpy as np

    from benchmarks.common import SOLVING_PACKAGES, machine

    root = Path(__file__).resolve().parents[1]
    facts = machine()
    assert facts["packages"]["numpy"] == np.__version__ and facts["packages"]["casadi"] is not None
    assert set(facts["packages"]) == set(SOLVING_PACKAGES)
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True).stdout.strip()
    assert facts["commit"] is None if not head else facts["commit"].startswith(head)


@pytest.mark.skipif(platform.machine() != "x86_64", reason="OpenBLAS's x86 kernels")
def test_a_benchmarks_results_say_which_blas_kernels_numpy_chose():
    """A scan's sweep turns on its inputs' last bits, which numpy's BLAS kernels change: a results file names
    them, as the processor chose them or as ``OPENBLAS_CORETYPE`` forced them."""
    root = Path(__file__).resolve().parents[1]
    code = "from benchmarks.common import machine; print(machine()['numpy_blas_kernels'])"
    env = {**os.environ, "OPENBLAS_CORETYPE": "Nehalem"}  # any x86-64 runs it
    forced = subprocess.run([sys.executable, "-c", code], cwd=root, env=env, capture_output=True, text=True, check=True)
    assert forced.stdout.strip() == "Nehalem"
