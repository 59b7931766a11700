"""Nothing lost, nothing left behind: the pipeline's state under concurrent runs, signals and a full disk; an
output folder that holds exactly what its last run made; children and scratch folders that do not outlive a
killed parent; paths that mean the same from any working directory."""

import errno
import json
import os
import signal
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import pandas as pd
import pytest
import yaml
from processes import alive, held_lock, wait_for

from grasptask.cli import run_stage
from grasptask.errors import BadInputError
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.pipeline import runner
from grasptask.pipeline.runner import load_pipeline, run_pipeline


def _pipeline(tmp_path: Path, recording: Path, extra_stage: dict | None = None) -> Path:
    stages = [
        {
            "name": "fit",
            "run": "fit-task",
            "args": [str(recording), "--task", "drawing", "--out", str(tmp_path / "tasks")],
            "outputs": [str(tmp_path / "tasks" / "ellipsoids.parquet")],
        },
        {
            "name": "distances",
            "run": "distances",
            "args": [str(tmp_path / "tasks" / "ellipsoids.parquet"), "--out", str(tmp_path / "dist")],
            "outputs": [str(tmp_path / "dist" / "distances.parquet")],
        },
    ]
    if extra_stage is not None:
        stages.append(extra_stage)
    path = tmp_path / "pipeline.yaml"
    path.write_text(yaml.safe_dump({"name": "t", "state": str(tmp_path / "state.json"), "stages": stages}))
    return path


def quiet(_: str) -> None:
    pass


def test_a_stop_after_a_stage_committed_but_before_the_state_was_saved_needs_no_force(tmp_path, recording_factory):
    """A Ctrl-C in the gap between a stage's commit and the state's save: the next plain run recognises the
    stage's outputs as its own and goes on, where it used to refuse them until --force."""
    spec = load_pipeline(_pipeline(tmp_path, recording_factory("rec.csv")))

    def interrupted_after_commit(stage):
        run_stage(stage)
        raise KeyboardInterrupt  # the signal arrives as the stage returns

    with pytest.raises(KeyboardInterrupt):
        run_pipeline(spec, interrupted_after_commit, echo=quiet)
    messages: list[str] = []
    again = run_pipeline(spec, run_stage, echo=messages.append)
    assert again.failed is None and again.skipped == ["fit"] and again.ran == ["distances"]
    assert any("finished before the last run stopped" in m for m in messages)


def test_a_full_disk_at_the_state_save_needs_no_force(tmp_path, recording_factory, monkeypatch):
    spec = load_pipeline(_pipeline(tmp_path, recording_factory("rec.csv")))
    saves = []
    real_save = runner._save_state

    def full_after_the_first_stage(path, state):
        saves.append(1)
        if len(saves) == 2:  # the first save marks 'fit' running; the second records it done
            raise OSError(errno.ENOSPC, "No space left on device")
        real_save(path, state)

    monkeypatch.setattr(runner, "_save_state", full_after_the_first_stage)
    with pytest.raises(OSError):
        run_pipeline(spec, run_stage, echo=quiet)
    monkeypatch.setattr(runner, "_save_state", real_save)
    again = run_pipeline(spec, run_stage, echo=quiet)
    assert again.failed is None and again.skipped == ["fit"] and again.ran == ["distances"]


def test_a_stage_that_failed_before_touching_its_outputs_leaves_its_record_as_it_was(tmp_path, recording_factory):
    """A stage refused before it ran (a bad input) is not left marked running: its last good record stands, so
    a rerun on the same inputs skips it, and one on new inputs runs it and what depends on it."""
    recording = recording_factory("rec.csv")
    spec = load_pipeline(_pipeline(tmp_path, recording))
    assert run_pipeline(spec, run_stage, echo=quiet).failed is None
    before = json.loads((tmp_path / "state.json").read_text())
    recording.write_text("")  # the next fit fails on it
    assert run_pipeline(spec, run_stage, echo=quiet).failed == "fit"
    assert json.loads((tmp_path / "state.json").read_text()) == before
    recording_factory("rec.csv", seed=1)  # another recording: fit reruns, and distances after it
    again = run_pipeline(spec, run_stage, echo=quiet)
    assert again.ran == ["fit", "distances"]


def test_a_second_run_of_the_same_pipeline_is_refused_while_the_first_runs(tmp_path, recording_factory):
    spec = load_pipeline(_pipeline(tmp_path, recording_factory("rec.csv")))
    with held_lock(spec.state_path, "pipeline run"):
        with pytest.raises(BadInputError, match="pipeline run"):
            run_pipeline(spec, run_stage, echo=quiet)
        assert not (tmp_path / "tasks").exists()
    assert run_pipeline(spec, run_stage, echo=quiet).ran == ["fit", "distances"]  # the dead holder's lock is stale


def _cli(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "grasptask.cli", *map(str, args)], capture_output=True, text=True, timeout=300, cwd=cwd
    )


def test_a_pipeline_that_runs_itself_is_one_line_not_a_recursion(tmp_path, recording_factory):
    path = tmp_path / "pipeline.yaml"
    stage = {"name": "again", "run": "pipeline run", "args": [str(path)], "outputs": [str(tmp_path / "never")]}
    _pipeline(tmp_path, recording_factory("rec.csv"), stage)
    result = _cli("pipeline", "run", path)
    assert result.returncode == 2 and "RecursionError" not in result.stderr
    assert "cannot run itself" in result.stderr and len(result.stderr.splitlines()) <= 2


def test_an_unknown_command_or_option_names_the_pipeline_and_stage(tmp_path, recording_factory):
    recording = recording_factory("rec.csv")
    for wrong in ({"run": "fit-taks", "args": []}, {"run": "distances", "args": ["--no-such-option"]}):
        stage = {"name": "broken", **wrong, "outputs": [str(tmp_path / "x")]}
        path = _pipeline(tmp_path, recording, stage)
        result = _cli("pipeline", "run", path)
        assert result.returncode == 2, result.stderr
        error = [line for line in result.stderr.splitlines() if line.startswith("error:")]
        assert len(error) == 1 and str(path) in error[0] and "stage 'broken'" in error[0]
        assert "Usage:" not in result.stderr + result.stdout


def test_a_declared_input_that_does_not_exist_is_named_before_the_stage_runs(tmp_path, recording_factory):
    missing = tmp_path / "nowhere.yaml"
    stage = {
        "name": "needs",
        "run": "distances",
        "args": [str(tmp_path / "tasks" / "ellipsoids.parquet"), "--out", str(tmp_path / "d2")],
        "inputs": [str(missing)],
        "outputs": [str(tmp_path / "d2" / "distances.parquet")],
    }
    spec = load_pipeline(_pipeline(tmp_path, recording_factory("rec.csv"), stage))
    with pytest.raises(BadInputError, match="nowhere.yaml does not exist"):
        run_pipeline(spec, run_stage, echo=quiet)
    assert not (tmp_path / "d2").exists()


def _stage(out: Path, command: str, files: dict[str, str]) -> None:
    with StagedOutput(out, Provenance.of(command, {})) as staged:
        for name, text in files.items():
            staged.write_with(name, lambda p, text=text: p.write_text(text))


def test_a_folder_holds_what_the_last_run_of_each_command_made(tmp_path):
    """An export of one optimum after an export of three leaves one; a report's figures likewise; another
    command's artifacts in the same folder and a file no stage staged (a sweep's log) stay."""
    out = tmp_path / "out"
    _stage(out, "export", {"grasps.json": "3", "optimum_00.json": "a", "optimum_01.json": "b", "optimum_02.json": "c"})
    _stage(out, "report", {"index.html": "r", "figures/one.png": "1", "figures/two.png": "2"})
    (out / "solutions.jsonl").write_text("{}\n")
    _stage(out, "export", {"grasps.json": "1", "optimum_00.json": "z"})
    _stage(out, "report", {"index.html": "r2", "figures/two.png": "2b"})
    names = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    assert names == [
        "figures/two.png", "grasps.json", "index.html", "optimum_00.json", "provenance.json", "solutions.jsonl"
    ]  # fmt: skip
    ledger = json.loads((out / "provenance.json").read_text())
    assert "optimum_01.json" not in ledger and ledger["optimum_00.json"]["command"] == "export"


def test_a_full_disk_names_the_path_not_the_command(tmp_path, monkeypatch):
    out = tmp_path / "out"

    def full(path):
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(OSError) as raised:
        with StagedOutput(out, Provenance.of("export", {})) as staged:
            staged.write_with("grasps.json", full)
    assert raised.value.filename == str(out) and not out.exists()


def _children(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def test_pool_workers_die_with_a_parent_killed_outright(tmp_path):
    """The physics check's pool (its initializer, as the stage starts it): kill -9 of the parent, and its
    workers follow within a second, not reparented to init for minutes."""
    parent = subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent("""
            import time
            from concurrent.futures import ProcessPoolExecutor
            from grasptask.stages.physics_check import _start_worker
            with ProcessPoolExecutor(2, initializer=_start_worker, initargs=(None,)) as pool:
                list(pool.map(abs, range(4)))
                print("ready", flush=True)
                time.sleep(120)
        """)],
        stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert parent.stdout is not None and parent.stdout.readline().strip() == "ready"
    workers = [c for c in _children(parent.pid) if alive(c)]
    assert len(workers) >= 2
    parent.kill()
    parent.wait()
    wait_for(lambda: not any(alive(w) for w in workers), 10, "the pool workers to die")


@pytest.mark.skipif(
    not (
        __import__("shutil").which("chromedriver")
        and (__import__("shutil").which("chromium") or __import__("shutil").which("chromium-browser"))
    ),
    reason="needs Chromium and chromedriver",
)
def test_a_killed_browser_check_leaves_no_browser_and_no_profile(tmp_path):
    """kill -9 of a report's browser check: chromedriver, every Chromium process, the profile and the browser's
    temporary files go with it."""
    page = tmp_path / "page.html"
    page.write_text("<html><body><script>while (true) {}</script></body></html>")  # never loads: the check waits
    # short: Chromium's profile holds a Unix socket, whose path may not pass 108 bytes (pytest's tmp_path is long)
    scratch = Path(tempfile.mkdtemp(prefix="gt-", dir="/tmp"))
    check = subprocess.Popen(
        [sys.executable, "-c", f"from grasptask.report.browser_check import check_page; check_page({str(page)!r})"],
        env={**os.environ, "TMPDIR": str(scratch)},
    )
    wait_for(lambda: any(scratch.glob("grasptask-chromium-*")) and len(_descendants(check.pid)) >= 3, 60, "a browser")
    browser = _descendants(check.pid)
    check.kill()
    check.wait()
    wait_for(lambda: not any(alive(p) for p in browser), 15, "the browser to die")
    wait_for(lambda: not any(scratch.iterdir()), 15, "the profile and the browser's temporary files to go")
    scratch.rmdir()


def _descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (by parent pid: a child started by another thread than a process's main one
    is not in its ``children`` list)."""
    parents = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            parents[int(stat.parent.name)] = int(stat.read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError):
            pass
    found, todo = [], [pid]
    while todo:
        parent = todo.pop()
        for child in (p for p, up in parents.items() if up == parent):
            found.append(child)
            todo.append(child)
    return found


def test_run_json_paths_read_from_another_working_directory(tmp_path, simulated):
    """An older sweep's run.json holds paths relative to where it ran: read from elsewhere, they are found
    beside it; a new one records them absolute."""
    from grasptask.records.sweeps import SweepFiles

    folder = tmp_path / "results" / "grasps" / "drawing"
    folder.mkdir(parents=True)
    tasks = tmp_path / "results" / "tasks" / "task_models.json"
    tasks.parent.mkdir(parents=True)
    tasks.write_text((simulated[0] / "tasks" / "task_models.json").read_text())
    (folder / "run.json").write_text(json.dumps({"task": "drawing", "tasks": "results/tasks/task_models.json"}))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    here = Path.cwd()
    os.chdir(elsewhere)
    try:
        found = SweepFiles.of(folder / "solutions.parquet")
    finally:
        os.chdir(here)
    assert found.tasks is not None and found.tasks.resolve() == tasks.resolve()


@pytest.mark.slow
def test_dask_workers_with_two_threads_solve_every_start_once_as_the_pool_does(tasks, tmp_path):
    """A Dask worker with two threads, as `dask worker` starts one on two cores: its solves take turns (two at
    once crashed the worker), every start is solved once, and each row is the local pool's."""
    from dask.distributed import LocalCluster

    from grasptask.stages import SynthesisOptions, run_synthesize

    common = {"tasks": tasks, "task": "drawing", "solver_config": Path("tests/data/solver_tiny.yaml"), "starts": 4}
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=True, dashboard_address=None) as cluster:
        options = SynthesisOptions(
            **common, out=tmp_path / "dask", executor="dask", scheduler=cluster.scheduler_address
        )
        run_synthesize(options, echo=quiet)
    run_synthesize(SynthesisOptions(**common, out=tmp_path / "pool", workers=2), echo=quiet)
    columns = ["start_id", "status", "verified", "palm_x", "Q"]
    on_dask = pd.read_parquet(tmp_path / "dask" / "drawing" / "solutions.parquet")[columns]
    on_pool = pd.read_parquet(tmp_path / "pool" / "drawing" / "solutions.parquet")[columns]
    assert sorted(on_dask["start_id"]) == sorted(on_pool["start_id"]) and on_dask["start_id"].is_unique
    pd.testing.assert_frame_equal(
        on_dask.sort_values("start_id").reset_index(drop=True), on_pool.sort_values("start_id").reset_index(drop=True)
    )


@pytest.mark.slow
def test_dask_says_when_no_worker_is_alive_and_stops_on_the_first_signal(tasks, tmp_path):
    """The only worker killed mid-sweep: the sweep says so within seconds, and the first SIGINT stops it."""
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=True, dashboard_address=None, scheduler_port=0) as cluster:
        worker = subprocess.Popen(
            [sys.executable, "-m", "dask", "worker", cluster.scheduler_address, "--nthreads", "1",
             "--no-dashboard"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        said = tmp_path / "said.txt"
        sweep = subprocess.Popen(
            [sys.executable, "-m", "grasptask.cli", "synthesize", "--tasks", str(tasks), "--task", "drawing",
             "--out", str(tmp_path / "out"), "--solver-config", "tests/data/solver_tiny.yaml", "--executor", "dask",
             "--scheduler", cluster.scheduler_address],
            stdout=said.open("w"), stderr=subprocess.STDOUT,
        )  # fmt: skip
        try:
            log = tmp_path / "out" / "drawing" / "solutions.jsonl"
            wait_for(lambda: log.exists() and log.read_text().count("\n") >= 1, 180, "a first solved start")
            worker.kill()
            worker.wait()
            wait_for(lambda: "no Dask worker alive" in said.read_text(), 60, "the sweep to say no worker is alive")
            sweep.send_signal(signal.SIGINT)
            assert sweep.wait(timeout=30) == 130
        finally:
            worker.kill()
            sweep.kill()
