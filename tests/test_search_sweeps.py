"""The search route's sweeps (SPEC section 12): the same rows with one worker, two and (`make test-slow`) Dask; a
sweep of one route not resumed by the other; sweeps started from a script, with and without a main guard, and
stopped by SIGTERM. Their search batches are of two starts, compiled once for the module (the compiled code is
kept in the test session's cache)."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def search_config(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("search") / "solver.yaml"
    path.write_text("search_round: 2\nsearch: {batch_size: 2}\n")
    return path


def _sweep(tasks: Path, out: Path, config: Path, workers: int, **executor: str) -> pd.DataFrame:
    from grasptask.stages import SynthesisOptions, run_synthesize

    given = {"solver_config": config, "starts": 4, "workers": workers, "route": "search", **executor}
    options = SynthesisOptions(tasks=tasks, task="drawing", out=out, **given)
    run_synthesize(options, echo=lambda _: None)
    return pd.read_parquet(out / "drawing" / "solutions.parquet")


#: what a row must say alike however the sweep was run
SAME = ["start_id", "status", "outcome", "basin", "polished_start", "search_iterations", "iterations", "Q", "search_Q"]


@pytest.fixture(scope="module")
def one_worker(tasks, tmp_path_factory, search_config) -> tuple[pd.DataFrame, Path]:
    """The search route's sweep of four starts in one worker: its rows and its folder."""
    out = tmp_path_factory.mktemp("one")
    return _sweep(tasks, out, search_config, 1), out


def test_the_search_routes_rows_are_the_same_with_one_worker_and_two(tasks, tmp_path, search_config, one_worker):
    one, folder = one_worker
    two = _sweep(tasks, tmp_path / "two", search_config, 2)
    pd.testing.assert_frame_equal(one[SAME], two[SAME])
    assert set(one["outcome"]) <= {"polished", "same-basin", "search-failed"}
    polished = one[one["outcome"] == "polished"]
    assert len(polished) >= 1 and polished["verified"].any()
    # every start is accounted for: a same-basin start names its basin's polished start
    joined = one[one["outcome"] == "same-basin"]
    assert set(joined["polished_start"]) <= set(polished["start_id"])
    run = __import__("json").loads((folder / "drawing" / "run.json").read_text())
    assert run["route"]["polished"] == len(polished)


@pytest.mark.slow  # `make test-slow`: two more processes that trace and load the search again
def test_the_search_routes_rows_are_the_same_with_dask(tasks, tmp_path, search_config, one_worker):
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        dask = _sweep(tasks, tmp_path / "dask", search_config, 1, executor="dask", scheduler=cluster.scheduler_address)
    pd.testing.assert_frame_equal(one_worker[0][SAME], dask[SAME])


@pytest.mark.parametrize("first", ["paper", "search"])
def test_a_route_refuses_to_resume_the_other_routes_sweep(tasks, tmp_path, search_config, first):
    from grasptask.errors import BadInputError
    from grasptask.stages import SynthesisOptions, run_synthesize

    folder = tmp_path / "out"
    common = {
        "tasks": tasks,
        "task": "drawing",
        "out": folder,
        "starts": 1,
        "executor": "serial",
        "solver_config": search_config,
    }
    run_synthesize(SynthesisOptions(**common, route=first), echo=lambda _: None)
    other = "search" if first == "paper" else "paper"
    with pytest.raises(BadInputError, match="another route"):
        run_synthesize(SynthesisOptions(**common, route=other, resume=True), echo=lambda _: None)


SCRIPT = """
from pathlib import Path
from grasptask.stages import SynthesisOptions, run_synthesize

run = run_synthesize(SynthesisOptions(tasks=Path({tasks!r}), task="drawing", out=Path({out!r}), starts={starts},
                                      workers=2, route={route!r}, solver_config=Path({config!r})))
print("finished", run.run["starts"])
"""


def _script(tmp_path: Path, tasks: Path, config: Path, route: str, guarded: bool, starts: int = 2) -> Path:
    body = SCRIPT.format(tasks=str(tasks), out=str(tmp_path / "out"), route=route, starts=starts, config=str(config))
    if guarded:
        body = "if __name__ == '__main__':\n" + textwrap.indent(body, "    ")
    path = tmp_path / "sweep_script.py"
    path.write_text(body)
    return path


def test_a_sweep_in_a_script_without_a_main_guard_is_refused_at_once(tasks, tmp_path, search_config):
    script = _script(tmp_path, tasks, search_config, "paper", guarded=False)
    began = time.monotonic()
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert time.monotonic() - began < 60
    assert done.returncode != 0
    last = done.stderr.strip().splitlines()[-1]
    assert "__main__" in last and "sweep_script.py" in last


def test_a_sweep_stops_on_sigterm_keeping_what_is_finished(tasks, tmp_path, search_config):
    """SIGTERM once the first round's rows are in: the sweep ends within seconds, those rows kept."""
    script = _script(tmp_path, tasks, search_config, "search", guarded=True, starts=12)
    log = tmp_path / "out" / "drawing" / "solutions.jsonl"
    process = subprocess.Popen([sys.executable, str(script)], stderr=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        deadline = time.monotonic() + 240
        while not (log.exists() and len(log.read_text().splitlines()) >= 2) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert process.poll() is None, "the sweep ended before it could be stopped"
        process.send_signal(signal.SIGTERM)
        stopped = time.monotonic()
        process.wait(timeout=60)
        assert time.monotonic() - stopped < 30
    finally:
        process.kill()
    assert process.returncode != 0
    assert process.stderr is not None and "--resume" in process.stderr.read()
    assert 2 <= len(log.read_text().splitlines()) < 12
    assert not (tmp_path / "out" / "drawing" / "solutions.parquet").exists()
