"""Long stages report progress when stderr is not a terminal: a line at intervals and one at the end, none when
the stage fails."""

from __future__ import annotations

import io

import pytest

from grasptask.errors import BadInputError
from grasptask.progress import INTERVAL_ENV, Progress, interval_s, progress


def test_a_log_gets_a_line_per_interval_with_counts_and_time_left(monkeypatch):
    monkeypatch.setenv(INTERVAL_ENV, "0")
    log = io.StringIO()
    with Progress(4, "synthesize drawing", "starts", initial=1, stream=log) as shown:
        shown.update(1, verified=2, failing=0)
        shown.update(1, verified=2, failing=1)
        shown.update(1, verified=3, failing=1)
    lines = log.getvalue().splitlines()
    assert lines[0].startswith("synthesize drawing: 2/4 starts (50%), verified 2, failing 0, ")
    assert "left" in lines[0] and "left" not in lines[-1]
    assert lines[-1].startswith("synthesize drawing: 4/4 starts (100%), verified 3, failing 1, ")
    assert len(lines) == 3  # two at the interval, the last at the end


def test_the_default_interval_keeps_a_log_short(monkeypatch):
    monkeypatch.delenv(INTERVAL_ENV, raising=False)
    log = io.StringIO()
    with Progress(1000, "fit-task", "rec", stream=log) as shown:
        for _ in range(1000):
            shown.update()
    assert log.getvalue().splitlines() == [log.getvalue().splitlines()[-1]]
    assert log.getvalue().startswith("fit-task: 1000/1000 rec (100%)")


def test_a_failed_stage_prints_no_last_line(monkeypatch):
    monkeypatch.delenv(INTERVAL_ENV, raising=False)
    log = io.StringIO()
    with pytest.raises(RuntimeError), Progress(3, "physics", "grasps", stream=log) as shown:
        shown.update()
        raise RuntimeError("stop")
    assert log.getvalue() == ""


def test_progress_over_items_yields_them_all(monkeypatch, capsys):
    monkeypatch.setenv(INTERVAL_ENV, "0")
    assert list(progress(range(3), "report", "figures")) == [0, 1, 2]
    assert capsys.readouterr().err.splitlines()[-1].startswith("report: 3/3 figures (100%)")


@pytest.mark.parametrize("text", ["soon", "-1", "inf", "nan"])
def test_a_bad_interval_is_one_line(monkeypatch, text):
    monkeypatch.setenv(INTERVAL_ENV, text)
    with pytest.raises(BadInputError, match=INTERVAL_ENV):
        interval_s()


def test_a_timed_stage_counts_its_set_up_in_the_time_elapsed_but_not_in_the_time_left(monkeypatch):
    """A sweep that took 30 s said "9 s elapsed": the model building before the first start was left out."""
    import time

    from grasptask.progress import timed_stage

    clock = [100.0]
    monkeypatch.setattr(time, "monotonic", lambda: clock[0])
    monkeypatch.setenv(INTERVAL_ENV, "0")
    log = io.StringIO()

    @timed_stage
    def stage() -> None:
        clock[0] += 20.0  # building models, scenes
        with Progress(4, "physics drawing", "grasps", stream=log) as shown:
            clock[0] += 10.0
            shown.update(1)
            clock[0] += 10.0
            shown.update(1)

    stage()
    lines = log.getvalue().splitlines()
    assert "30 s elapsed" in lines[0] and "about 30 s left" in lines[0]  # 10 s a grasp, three to go
    assert "40 s elapsed" in lines[-1] and len(lines) == 3
    with Progress(1, "alone", stream=io.StringIO()) as outside:  # no stage: from the bar's own start
        assert outside.began == outside.counting


def test_a_long_set_up_says_what_it_prepares_and_a_quick_one_stays_quiet(monkeypatch):
    import time

    from grasptask import progress as progress_module

    monkeypatch.setattr(progress_module, "SAY_PREPARING_AFTER_S", 0.05)
    said: list[str] = []
    with progress_module.preparing("building the scenes ...", said.append):
        time.sleep(0.3)
    with progress_module.preparing("refused at once", said.append):
        pass
    time.sleep(0.1)
    assert said == ["building the scenes ..."]


@pytest.mark.parametrize(
    ("count", "word", "said"),
    [(1, "start", "1 start"), (2, "start", "2 starts"), (0, "grasp", "0 grasps"), (1, "distinct optimum",
     "1 distinct optimum"), (3, "distinct optimum", "3 distinct optima"), (2, "optimum", "2 optima")],
)  # fmt: skip
def test_counts_are_said_in_the_singular_where_there_is_one(count, word, said):
    from grasptask.stages import plural

    assert plural(count, word) == said


def test_a_log_never_goes_quiet_while_a_start_runs(monkeypatch):
    """A sweep whose starts take minutes printed only when one finished (90 s, then 2.7 min, ...): the heartbeat
    says what is running, for how long and how many are done, every interval nothing else was said."""
    import time

    from grasptask.progress import finished, working

    monkeypatch.setenv(INTERVAL_ENV, "0.2")
    log = io.StringIO()
    with Progress(3, "synthesize cutting", "starts", stream=log) as shown:
        working("worker 0", "start 17")
        time.sleep(0.9)
        finished("worker 0")
        shown.update(1, verified=1, failing=0)
        time.sleep(0.05)
    lines = log.getvalue().splitlines()
    beats = [line for line in lines if "running: start 17 for" in line]
    assert len(beats) >= 2, lines
    assert beats[0].startswith("synthesize cutting: 0/3 starts (0%)") and "elapsed" in beats[0]
    time.sleep(0.5)  # the stage is over: nothing more is said
    assert log.getvalue().splitlines() == lines


def test_a_long_set_up_is_said_again_with_its_time(monkeypatch):
    import time

    from grasptask import progress as progress_module

    monkeypatch.setenv(INTERVAL_ENV, "0.2")
    monkeypatch.setattr(progress_module, "SAY_PREPARING_AFTER_S", 0.05)
    said: list[str] = []
    with progress_module.preparing("synthesize cutting: building the NLP in 2 workers ...", said.append):
        time.sleep(1.0)
    assert said[0] == "synthesize cutting: building the NLP in 2 workers ..."
    again = [line for line in said[1:] if "still at it" in line]
    assert len(again) >= 2, said


def test_a_sweeps_log_says_which_start_runs_between_the_starts_it_finishes(monkeypatch, tasks, tmp_path, cli):
    monkeypatch.setenv(INTERVAL_ENV, "0.3")
    result = cli("synthesize", "--tasks", tasks, "--task", "drawing", "--out", tmp_path / "g", "--starts", "2",
                 "--workers", "1")  # fmt: skip
    assert result.exit_code == 0, result.output
    beats = [line for line in result.output.splitlines() if "; running: start" in line]
    assert beats and all(line.startswith("synthesize drawing: ") for line in beats), result.output
