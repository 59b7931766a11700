"""Fault injection: nothing finished is lost and nothing lands outside --out, under concurrent runs, resumes that
do not match, cut-short logs, kill -9 of the parent or a worker, SIGTERM, a full disk and a read-only folder.

Sweeps run as real subprocesses (``python -m grasptask.cli``) so that signals and kills are the real ones.
"""

import json
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from processes import alive, wait_for

from grasptask.errors import BadInputError
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.io.locking import lock_path
from grasptask.io.sweep_log import read_log

TINY = Path("tests/data/solver_tiny.yaml")  # rows and files are checked here, not grasps
#: the exit codes of a sweep that ran to its end: 3 when none of its starts verified, as TINY's 30 iterations make
#: likely
ENDED = (0, 3)


def command(tasks, out, *extra):
    return [
        sys.executable, "-m", "grasptask.cli", "synthesize", "--tasks", str(tasks), "--task", "drawing",
        "--out", str(out), "--solver-config", str(TINY), *map(str, extra),
    ]  # fmt: skip


def start_sweep(tasks, out, *extra):
    return subprocess.Popen(command(tasks, out, *extra), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def run_sweep(tasks, out, *extra, timeout=300):
    return subprocess.run(command(tasks, out, *extra), capture_output=True, text=True, timeout=timeout)


def log_rows(out) -> list[dict]:
    path = Path(out) / "drawing" / "solutions.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def workers_of(pid: int) -> list[int]:
    """The pool workers (spawned processes) among a process's children."""
    try:
        children = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    except OSError:
        return []
    found = []
    for child in map(int, children):
        try:
            if b"spawn_main" in Path(f"/proc/{child}/cmdline").read_bytes():
                found.append(child)
        except OSError:
            pass
    return found


def one_error_line(result) -> str:
    lines = [line for line in (result.stderr + result.stdout).splitlines() if line.strip()]
    error = [line for line in lines if line.startswith("error:")]
    assert result.returncode == 2 and len(error) == 1, result.stderr + result.stdout
    assert "Traceback" not in result.stderr
    return error[0]


def children_cpu_s() -> float:
    """The CPU time (user and system) of every child process this one has waited for."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def dead_pid() -> int:
    process = subprocess.Popen(["true"])
    process.wait()
    return process.pid


def test_a_second_run_on_a_folder_in_use_is_refused(tasks, tmp_path):
    first = start_sweep(tasks, tmp_path, "--starts", "2", "--executor", "serial")
    wait_for(lambda: lock_path(tmp_path / "drawing").exists(), what="the first run's lock")
    os.kill(first.pid, signal.SIGSTOP)  # still running, and holding its lock, however long the others take
    try:
        for extra in ((), ("--resume",)):
            second = run_sweep(tasks, tmp_path, "--starts", "2", "--executor", "serial", *extra)
            assert "in use by another run" in one_error_line(second)
    finally:
        os.kill(first.pid, signal.SIGCONT)
    assert first.wait(timeout=1800) in ENDED, first.stderr  # a guard against a hang, not a measure of speed
    rows = log_rows(tmp_path)
    assert len(rows) == 2 and len({r["start_id"] for r in rows}) == 2  # each start once
    assert not lock_path(tmp_path / "drawing").exists()


def test_resuming_a_finished_sweep_solves_nothing_and_keeps_it(tasks, tmp_path):
    assert run_sweep(tasks, tmp_path, "--starts", "1", "--executor", "serial").returncode in ENDED
    before = (tmp_path / "drawing" / "solutions.jsonl").read_bytes()
    result = run_sweep(tasks, tmp_path, "--starts", "1", "--executor", "serial", "--resume")
    assert result.returncode in ENDED, result.stderr
    assert (tmp_path / "drawing" / "solutions.jsonl").read_bytes() == before


def test_a_stale_lock_of_a_dead_process_is_taken_over(tasks, tmp_path):
    lock = lock_path(tmp_path / "drawing")
    lock.parent.mkdir(parents=True, exist_ok=True)
    lock.write_text(json.dumps({"pid": dead_pid(), "start": "1", "host": os.uname().nodename, "purpose": "x"}))
    result = run_sweep(tasks, tmp_path, "--starts", "1", "--executor", "serial")
    assert result.returncode in ENDED, result.stderr
    assert not lock.exists()


def test_resume_refuses_another_run(tasks, tmp_path):
    assert run_sweep(tasks, tmp_path, "--starts", "3", "--executor", "serial").returncode in ENDED
    before = (tmp_path / "drawing" / "solutions.jsonl").read_bytes()
    other_solver = tmp_path / "solver.yaml"
    other_solver.write_text(TINY.read_text().replace("max_iter: 30", "max_iter: 29"))
    for extra, expected in (
        (("--seed", "1"), "seed (0, now 1)"),
        (("--solver-config", other_solver), "solver config"),
        (("--starts", "4"), "not among the 4"),
        (("--surface-starts", "2"), "another surface starts"),
    ):
        result = run_sweep(tasks, tmp_path, "--starts", "3", "--executor", "serial", "--resume", *extra)
        assert expected in one_error_line(result)
    assert (tmp_path / "drawing" / "solutions.jsonl").read_bytes() == before


def test_a_cut_short_last_line_is_dropped_and_every_start_stays_unique(tasks, tmp_path):
    assert run_sweep(tasks, tmp_path, "--starts", "2", "--executor", "serial").returncode in ENDED
    log = tmp_path / "drawing" / "solutions.jsonl"
    first = log.read_text().splitlines()[0]
    with open(log, "a") as handle:  # a duplicate row, then what a full disk leaves: half a line
        handle.write(first + "\n" + '{"start_id": 62, "status": "opt')
    result = run_sweep(tasks, tmp_path, "--starts", "3", "--executor", "serial", "--resume")
    assert result.returncode in ENDED, result.stderr
    assert "dropped an incomplete last line" in result.stdout and "kept the first" in result.stdout
    rows = log_rows(tmp_path)
    assert sorted(r["start_id"] for r in rows) == [0, 62, 125]
    assert len(pd.read_parquet(tmp_path / "drawing" / "solutions.parquet")) == 3


def test_nothing_is_touched_before_the_run_is_known_to_work(tasks, tmp_path):
    assert run_sweep(tasks, tmp_path, "--starts", "1", "--executor", "serial").returncode in ENDED
    folder = tmp_path / "drawing"
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    bad_ipopt = tmp_path / "bad_ipopt.yaml"
    bad_ipopt.write_text(TINY.read_text().replace("ipopt:\n", "ipopt:\n  mu_strategy: sideways\n"))
    began = children_cpu_s()
    for extra, expected in (
        (("--executor", "dask"), "needs --scheduler"),
        (("--solver-config", bad_ipopt), "ipopt.mu_strategy"),
        (("--executor", "dask", "--scheduler", "tcp://127.0.0.1:9"), "no Dask scheduler answered"),
        (("--starts", "100000"), "there are 126 starts"),
    ):
        assert expected in one_error_line(run_sweep(tasks, tmp_path, "--starts", "1", *extra))
    # refused before any work: what the four runs cost is their start-up, measured in their own CPU time so
    # that a busy machine (where they took 77 s of wall clock) does not fail it
    assert children_cpu_s() - began < 60
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    # an unreachable cluster leaves no empty log (nor an empty --out) behind in a new folder
    fresh = tmp_path / "fresh"
    one_error_line(run_sweep(tasks, fresh, "--executor", "dask", "--scheduler", "tcp://127.0.0.1:9"))
    assert not fresh.exists()


def test_kill_9_of_the_parent_then_resume(tasks, tmp_path):
    sweep = start_sweep(tasks, tmp_path, "--starts", "4", "--workers", "2")
    wait_for(lambda: len(log_rows(tmp_path)) >= 1, what="a finished start")
    workers = workers_of(sweep.pid)
    assert workers
    sweep.kill()
    sweep.wait()
    wait_for(lambda: not any(alive(w) for w in workers), timeout=40, what="the orphaned workers to exit")
    kept = [r["start_id"] for r in log_rows(tmp_path)]
    result = run_sweep(tasks, tmp_path, "--starts", "4", "--workers", "2", "--resume")
    assert result.returncode in ENDED, result.stderr
    rows = [r["start_id"] for r in log_rows(tmp_path)]
    assert rows[: len(kept)] == kept and sorted(rows) == [0, 42, 83, 125]


def test_kill_9_of_a_worker_is_recorded_and_the_sweep_goes_on(tasks, tmp_path):
    sweep = start_sweep(tasks, tmp_path, "--starts", "4", "--workers", "2")
    wait_for(lambda: len(workers_of(sweep.pid)) == 2 and len(log_rows(tmp_path)) >= 1, what="two busy workers")
    os.kill(workers_of(sweep.pid)[0], signal.SIGKILL)
    _, err = sweep.communicate(timeout=300)
    assert sweep.returncode in ENDED, err
    solutions = pd.read_parquet(tmp_path / "drawing" / "solutions.parquet")
    assert sorted(solutions["start_id"]) == [0, 42, 83, 125]
    assert (solutions["status"] == "crashed").sum() <= 1


@pytest.mark.parametrize("executor", ["serial", pytest.param("pool", marks=pytest.mark.slow)])
def test_sigterm_finishes_the_starts_in_progress_then_resume_completes(tasks, tmp_path, executor):
    extra = ("--executor", "serial") if executor == "serial" else ("--workers", "2")
    # six starts, so that the signal finds some not yet begun even when the first ones finish close together
    sweep = start_sweep(tasks, tmp_path, "--starts", "6", *extra)
    wait_for(lambda: len(log_rows(tmp_path)) >= 1, what="a finished start")
    workers = workers_of(sweep.pid)
    sweep.send_signal(signal.SIGTERM)
    out, err = sweep.communicate(timeout=120)
    assert sweep.returncode == 130, err
    assert not any(alive(w) for w in workers)  # the parent ended its workers before it exited
    assert "finishing the starts in progress" in out and "--resume" in err
    kept = log_rows(tmp_path)
    assert 1 <= len(kept) < 6 and all(r["status"] not in ("crashed", "hung") for r in kept)
    assert not lock_path(tmp_path / "drawing").exists()
    result = run_sweep(tasks, tmp_path, "--starts", "6", *extra, "--resume")
    assert result.returncode in ENDED, result.stderr
    assert sorted(r["start_id"] for r in log_rows(tmp_path)) == [0, 25, 50, 75, 100, 125]


@pytest.fixture
def small_disk(tmp_path):
    """A 3 MB tmpfs (root only): a full disk that the test can fill on purpose."""
    mount = tmp_path / "disk"
    mount.mkdir()
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root; the full-disk test runs where the suite runs as root")
    made = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=3m", "tmpfs", str(mount)], capture_output=True)
    if made.returncode != 0:
        pytest.skip(f"could not mount a tmpfs here: {made.stderr.decode().strip()}")
    yield mount
    subprocess.run(["umount", "-l", str(mount)], check=False)


def fill(folder: Path) -> Path:
    """Fill the filesystem under ``folder`` up to its last byte."""
    filler = folder / "filler"
    with open(filler, "wb", buffering=0) as handle:
        try:
            while True:
                handle.write(b"\0" * 4096)
        except OSError:
            pass
    return filler


def test_a_full_disk_keeps_the_finished_starts(tasks, small_disk):
    sweep = start_sweep(tasks, small_disk, "--starts", "3", "--executor", "serial")
    wait_for(lambda: len(log_rows(small_disk)) >= 1, what="a finished start")
    filler = fill(small_disk)
    _, err = sweep.communicate(timeout=120)
    assert sweep.returncode == 2 and "no space left on device" in err and "Traceback" not in err, err
    contents = read_log(small_disk / "drawing" / "solutions.jsonl")
    assert contents.rows and not contents.repairs  # every finished row kept, no fragment left
    filler.unlink()
    result = run_sweep(tasks, small_disk, "--starts", "3", "--executor", "serial", "--resume")
    assert result.returncode in ENDED, result.stderr
    assert sorted(r["start_id"] for r in log_rows(small_disk)) == [0, 62, 125]


def test_a_read_only_output_folder_is_one_line(tasks, small_disk, cli):
    subprocess.run(["mount", "-o", "remount,ro", str(small_disk)], check=True)
    result = cli("simulate", "--out", small_disk / "recordings")
    assert result.exit_code == 2 and "Read-only file system" in result.output
    assert len(result.output.strip().splitlines()) == 1
    result = run_sweep(tasks, small_disk, "--starts", "1", "--executor", "serial")
    assert "Read-only file system" in one_error_line(result)


def test_a_read_only_folder_is_found_before_the_work(simulated, small_disk, cli):
    """fit-task on a read-only --out: one line, before a recording is read (it was found at the commit)."""
    subprocess.run(["mount", "-o", "remount,ro", str(small_disk)], check=True)
    result = cli("fit-task", simulated[0] / "recordings" / "manifest.csv", "--out", small_disk / "tasks")
    assert result.exit_code == 2 and "Read-only file system" in result.output
    assert "fit-task:" not in result.output and len(result.output.strip().splitlines()) == 1


def test_a_full_disk_names_the_folder_it_was_writing(simulated, small_disk, cli):
    filler = fill(small_disk)
    result = cli("fit-task", simulated[0] / "recordings" / "manifest.csv", "--out", small_disk / "tasks")
    filler.unlink()
    error = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert result.exit_code == 2 and len(error) == 1 and "No space left on device" in error[0]
    assert str(small_disk) in error[0] and not error[0].startswith("error: fit-task:")
    assert not (small_disk / "tasks").exists()


@pytest.mark.parametrize("mask, mode", [(0o022, 0o755), (0o077, 0o700), (0o002, 0o775)])
def test_an_output_folder_is_made_as_the_umask_says(tmp_path, mask, mode):
    """Colleagues on a shared server read the results when the umask lets them: the staged folder that becomes
    --out was 0700 whatever the umask."""
    before = os.umask(mask)
    try:
        with StagedOutput(tmp_path / "out", Provenance.of("t", {})) as staged:
            staged.write_with("a.txt", lambda p: p.write_text("a"))
    finally:
        os.umask(before)
    assert (tmp_path / "out").stat().st_mode & 0o777 == mode


def test_a_stage_commit_is_all_or_nothing(tmp_path, monkeypatch):
    out = tmp_path / "out"
    with StagedOutput(out, Provenance.of("t", {})) as staged:
        staged.write_with("a.txt", lambda p: p.write_text("old a"))
        staged.write_with("b.txt", lambda p: p.write_text("old b"))
    with StagedOutput(out, Provenance.of("other", {})) as staged:
        staged.write_with("keep.txt", lambda p: p.write_text("other stage"))
    import grasptask.io.artifacts as artifacts

    def killed(a, b):
        raise KeyboardInterrupt  # a kill at the moment of the swap

    monkeypatch.setattr(artifacts, "exchange", killed)
    with pytest.raises(KeyboardInterrupt), StagedOutput(out, Provenance.of("t", {})) as staged:
        staged.write_with("a.txt", lambda p: p.write_text("new a"))
        staged.write_with("b.txt", lambda p: p.write_text("new b"))
    assert (out / "a.txt").read_text() == "old a" and (out / "b.txt").read_text() == "old b"
    monkeypatch.undo()
    with StagedOutput(out, Provenance.of("t", {})) as staged:
        staged.write_with("a.txt", lambda p: p.write_text("new a"))
        staged.write_with("b.txt", lambda p: p.write_text("new b"))
    assert [(out / n).read_text() for n in ("a.txt", "b.txt", "keep.txt")] == ["new a", "new b", "other stage"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no staging folder, no lock


def test_a_killed_stage_leaves_nothing_that_the_next_run_does_not_clean(tmp_path, simulated):
    results = simulated[0]
    out = tmp_path / "report"
    report = subprocess.Popen(
        [sys.executable, "-m", "grasptask.cli", "report", "--results", str(results), "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    wait_for(lambda: any(p.name.startswith(".report.staging-") for p in tmp_path.iterdir()), what="staging")
    report.kill()
    report.wait()
    assert not out.exists()
    assert any(p.name.startswith(".report.staging-") for p in tmp_path.iterdir())
    done = subprocess.run(
        [sys.executable, "-m", "grasptask.cli", "report", "--results", str(results), "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert done.returncode in ENDED, done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report"]


def test_artifact_names_from_inputs_stay_inside_the_output_folder(tmp_path):
    with pytest.raises(Exception, match="must stay inside"), StagedOutput(tmp_path / "o", Provenance.of("t", {})) as s:
        s.path("x/../../../escaped.png")
    assert not (tmp_path / "escaped.png").exists() and not (tmp_path / "o").exists()


def test_a_stop_gets_through_a_mask_the_parent_hands_down(tasks, tmp_path):
    """A process started with SIGINT and SIGTERM blocked (a test runner's thread hands its mask down) still
    stops on the first SIGINT, rather than solving on with the signal pending."""
    blocked = {signal.SIGINT, signal.SIGTERM}
    sweep = subprocess.Popen(
        command(tasks, tmp_path, "--executor", "serial", "--starts", "12"),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.pthread_sigmask(signal.SIG_BLOCK, blocked),
    )  # fmt: skip
    assert sweep.stdout is not None and "model" in sweep.stdout.readline() + sweep.stdout.readline()
    sweep.send_signal(signal.SIGINT)
    _, err = sweep.communicate(timeout=60)
    assert sweep.returncode == 130 and "interrupted" in err, err


def test_a_command_takes_sigint_even_where_the_parent_ignored_it(cli, tmp_path, monkeypatch):
    """A script's background job starts with SIGINT ignored; a command still stops on it, from its start (a sweep
    did only once its stop handler was in place, and a SIGINT before that was lost)."""
    import grasptask.stages

    seen = {}

    def distances(options):
        seen["handler"] = signal.getsignal(signal.SIGINT)
        seen["blocked"] = signal.pthread_sigmask(signal.SIG_BLOCK, set())
        raise BadInputError(options.ellipsoids, "seen")  # the command ends here, as on any bad input

    monkeypatch.setattr(grasptask.stages, "run_distances", distances, raising=False)
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        assert cli("distances", tmp_path / "e.parquet", "--out", tmp_path / "o").exit_code == 2
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        after = signal.signal(signal.SIGINT, previous)
    assert seen["handler"] is signal.default_int_handler and signal.SIGINT not in seen["blocked"]
    assert after is signal.SIG_IGN  # the caller's own handler is given back


def test_a_ctrl_c_before_any_start_is_solved_says_nothing_was_kept(tasks, tmp_path):
    """It said 'finished starts are kept in .../solutions.jsonl' of a folder that was never made."""
    sweep = start_sweep(tasks, tmp_path, "--executor", "serial")
    assert sweep.stdout is not None
    assert "already done" in sweep.stdout.readline()  # the inputs are read; the model is being built
    sweep.send_signal(signal.SIGINT)
    _, err = sweep.communicate(timeout=120)
    assert sweep.returncode == 130 and "nothing of this run was kept" in err and "--resume" not in err, err
    assert not log_rows(tmp_path)  # the sweep's log, if the folder was made before the stop, holds no start


def test_a_rerun_that_fails_on_a_full_disk_leaves_the_finished_sweep_resumable(tasks, small_disk):
    """A finished seed-0 sweep run again with another seed on a full disk: the rerun fails, and the finished
    sweep's log, sweep.json and results are as they were, so that --resume with seed 0 still takes it."""
    assert run_sweep(tasks, small_disk, "--starts", "2", "--executor", "serial").returncode in ENDED
    folder = small_disk / "drawing"
    before = {name: (folder / name).read_bytes() for name in ("solutions.jsonl", "sweep.json", "run.json")}
    filler = fill(small_disk)
    failed = run_sweep(tasks, small_disk, "--starts", "2", "--executor", "serial", "--seed", "5")
    assert failed.returncode == 2 and "Traceback" not in failed.stderr, failed.stderr
    assert {name: (folder / name).read_bytes() for name in before} == before
    assert not list(folder.glob(".*.new"))
    filler.unlink()
    resumed = run_sweep(tasks, small_disk, "--starts", "2", "--executor", "serial", "--resume")
    assert resumed.returncode in ENDED and "2 already done" in resumed.stdout, resumed.stderr


def test_a_rerun_stopped_part_way_leaves_the_finished_sweep_and_its_own_rows(tasks, tmp_path):
    """A seed-5 rerun over a finished seed-0 sweep stopped after its first rows: the seed-0 sweep's files are as
    they were (its --resume takes it), and the rerun's rows are kept beside them (its own --resume goes on)."""
    assert run_sweep(tasks, tmp_path, "--starts", "2", "--executor", "serial").returncode in ENDED
    folder = tmp_path / "drawing"
    names = ("solutions.jsonl", "sweep.json", "run.json", "solutions.parquet")
    before = {name: (folder / name).read_bytes() for name in names}
    rerun = start_sweep(tasks, tmp_path, "--starts", "4", "--executor", "serial", "--seed", "5")
    staged = folder / ".solutions.jsonl.new"
    wait_for(lambda: staged.is_file() and staged.read_text().count("\n") >= 1, what="the rerun's first row")
    rerun.send_signal(signal.SIGINT)
    _, err = rerun.communicate(timeout=120)
    assert rerun.returncode == 130 and ".solutions.jsonl.new" in err, err
    assert {name: (folder / name).read_bytes() for name in names} == before
    original = run_sweep(tasks, tmp_path, "--starts", "2", "--executor", "serial", "--resume")
    assert original.returncode in ENDED and "2 already done" in original.stdout, original.stderr
    kept = staged.read_text().count("\n")
    again = run_sweep(tasks, tmp_path, "--starts", "4", "--executor", "serial", "--seed", "5", "--resume")
    assert again.returncode in ENDED and f"{kept} already done" in again.stdout, again.stderr
    assert not staged.exists() and len(log_rows(tmp_path)) == 4
    assert json.loads((folder / "sweep.json").read_text())["definition"]["seed"] == 5


def test_a_rerun_stopped_before_its_first_row_leaves_the_finished_sweep(tasks, tmp_path):
    assert run_sweep(tasks, tmp_path, "--starts", "2", "--executor", "serial").returncode in ENDED
    folder = tmp_path / "drawing"
    before = {name: (folder / name).read_bytes() for name in ("solutions.jsonl", "sweep.json")}
    sweep = start_sweep(tasks, tmp_path, "--starts", "2", "--executor", "serial", "--seed", "5")
    assert sweep.stdout is not None and "already done" in sweep.stdout.readline()
    sweep.send_signal(signal.SIGINT)
    _, err = sweep.communicate(timeout=120)
    assert sweep.returncode == 130 and "the sweep that was here is kept as it was" in err, err
    assert {name: (folder / name).read_bytes() for name in before} == before


def test_a_pipeline_goes_on_with_a_sweep_stage_stopped_part_way(tasks, tmp_path):
    """A Ctrl-C during a pipeline's sweep stage: the next plain run resumes the sweep itself, with every row
    the first run finished kept, where it used to refuse the unfinished sweep with and without --force."""
    import yaml

    out = tmp_path / "grasps"
    args = ["--tasks", str(tasks), "--task", "drawing", "--out", str(out), "--solver-config", str(TINY),
            "--starts", "6", "--executor", "serial"]  # fmt: skip
    stage = {"name": "sweep", "run": "synthesize", "args": args, "outputs": [str(out / "drawing" / "run.json")]}
    pipeline = tmp_path / "pipeline.yaml"
    state = tmp_path / "state.json"
    pipeline.write_text(yaml.safe_dump({"name": "p", "state": str(state), "stages": [stage]}))
    command = [sys.executable, "-m", "grasptask.cli", "pipeline", "run", str(pipeline)]
    first = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for(lambda: len(log_rows(out)) >= 1, what="a finished start")
    first.send_signal(signal.SIGINT)
    first.communicate(timeout=120)
    assert first.returncode == 130
    kept = {r["start_id"]: r for r in log_rows(out)}
    assert 1 <= len(kept) < 6 and json.loads(state.read_text())["sweep"]["running"]
    again = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert again.returncode in ENDED, again.stderr
    assert "going on from there" in again.stdout and f"{len(kept)} already done" in again.stdout
    rows = {r["start_id"]: r for r in log_rows(out)}
    assert len(rows) == 6 and all(rows[k] == row for k, row in kept.items())


def test_a_rerun_whose_tables_fail_to_write_leaves_the_finished_sweep_whole(tasks, tmp_path, cli, monkeypatch):
    """A seed-5 rerun over a finished seed-0 sweep, every start solved, then a full disk while it writes its
    tables: it used to have moved its log and sweep.json (seed 5) in place already, beside the seed-0 run.json and
    tables, and --resume with seed 0 was refused ("run with another seed (5, now 0)"). The finished sweep stays
    whole until the rerun's results are all written; either sweep's --resume then goes on."""
    import errno

    import grasptask.io.artifacts

    args = ["synthesize", "--tasks", tasks, "--task", "drawing", "--out", tmp_path, "--solver-config", TINY,
            "--starts", "2", "--executor", "serial"]  # fmt: skip
    assert cli(*args).exit_code in ENDED
    folder = tmp_path / "drawing"
    names = ("solutions.jsonl", "sweep.json", "run.json", "solutions.parquet", "optima.parquet")
    before = {name: (folder / name).read_bytes() for name in names}

    def full_disk(*_, **__):
        raise OSError(errno.ENOSPC, "No space left on device")

    with monkeypatch.context() as patched:
        patched.setattr(grasptask.io.artifacts.pq, "write_table", full_disk)
        failed = cli(*args, "--seed", "5")
    assert failed.exit_code == 2 and "No space left on device" in failed.output, failed.output
    assert {name: (folder / name).read_bytes() for name in names} == before
    assert (folder / ".solutions.jsonl.new").read_text().count("\n") == 2  # the rerun's rows, kept to resume
    original = cli(*args, "--resume")
    assert original.exit_code in ENDED and "2 already done" in original.output, original.output
    rerun = cli(*args, "--seed", "5", "--resume")
    assert rerun.exit_code in ENDED and "2 already done" in rerun.output, rerun.output
    assert json.loads((folder / "sweep.json").read_text())["definition"]["seed"] == 5
    assert not list(folder.glob(".*.new")) and json.loads((folder / "run.json").read_text())["log_rows"] == 2
