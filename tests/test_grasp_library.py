"""The grasp library (``synthesize --library DIR``): warm starts from the optima of the nearest task it holds for
the same hand, object and fingers, by the Log-Euclidean distance; sweeps add to it; one without it stays as it
was."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from grasptask.errors import BadInputError
from grasptask.records.grasp_library import add_to_library, nearest_entry, setup_key
from grasptask.task.ellipsoid import Ellipsoid
from grasptask.task.task_model import TaskModel, load_task_models


def _task(name: str, scale: np.ndarray) -> TaskModel:
    return TaskModel(name, 1, Ellipsoid.from_matrix(np.diag(scale)))


def _optima(q: list[float]) -> pd.DataFrame:
    rows = [{"palm_x": 0.1 * k, "q_j0": 0.2, "contact_thumb_x": 0.01, "normal_thumb_x": 1.0, "Q": v, "members": 3}
            for k, v in enumerate(q)]  # fmt: skip
    return pd.DataFrame(rows)


def test_the_nearest_task_of_the_same_setup_is_found_and_its_best_optimum_comes_first(tmp_path):
    setup = setup_key("hand-hash", "object-hash", ["thumb", "index"])
    add_to_library(tmp_path, setup, _task("writing", np.ones(6)), _optima([0.3, 0.1, 0.2]))
    add_to_library(tmp_path, setup, _task("hammering", np.full(6, 50.0)), _optima([0.05]))
    add_to_library(
        tmp_path, setup_key("other", "object-hash", ["thumb", "index"]), _task("near", np.ones(6)), _optima([0.01])
    )
    entry = nearest_entry(tmp_path, setup, _task("drawing", np.full(6, 1.2)))
    assert entry is not None and entry.task == "writing"
    assert entry.distance == pytest.approx(np.sqrt(6) * np.log(1.2))
    assert list(entry.optima["Q"]) == [0.1, 0.2, 0.3] and "members" not in entry.optima
    assert nearest_entry(tmp_path, setup_key("x", "y", ["a", "b"]), _task("drawing", np.ones(6))) is None


def test_a_second_sweep_of_a_task_replaces_its_entry_and_an_empty_one_keeps_it(tmp_path):
    setup = setup_key("h", "o", ["a", "b"])
    first = add_to_library(tmp_path, setup, _task("writing", np.ones(6)), _optima([0.3]))
    again = add_to_library(tmp_path, setup, _task("writing", np.ones(6)), _optima([0.2, 0.4]))
    assert first == again and add_to_library(tmp_path, setup, _task("writing", np.ones(6)), _optima([])) is None
    assert list(nearest_entry(tmp_path, setup, _task("writing", np.ones(6))).optima["Q"]) == [0.2, 0.4]
    assert [p.name for p in (tmp_path / setup).iterdir()] == [first.name]  # nothing half-written beside it


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d["optima"][0].update(palm_x=None), "row 1, column 'palm_x': not a finite number"),
        (lambda d: d.update(S=[[1.0]]), "field 'S'"),
        (lambda d: d.update(optima=[]), "field 'optima'"),
    ],
    ids=["a-missing-value", "a-broken-ellipsoid", "no-optima"],
)
def test_a_broken_library_entry_is_one_line_naming_it(tmp_path, change, message):
    setup = setup_key("h", "o", ["a", "b"])
    path = add_to_library(tmp_path, setup, _task("writing", np.ones(6)), _optima([0.3]))
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))
    with pytest.raises(BadInputError, match="column|field") as error:
        nearest_entry(tmp_path, setup, _task("writing", np.ones(6)))
    assert str(path) in str(error.value) and message in str(error.value)


def _add_scaled_task(data: dict, source: str, name: str, factor: float) -> None:
    data["tasks"][name] = {**data["tasks"][source], "S": (np.asarray(data["tasks"][source]["S"]) * factor).tolist()}


def test_a_sweep_warm_started_from_a_similar_task_finds_that_task_s_best_optimum(cli, tasks, tmp_path):
    """A sweep of drawing fills the library; a sweep of a similar task (drawing's ellipsoid 10% longer) with one
    start of its own, warm-started from drawing's optima, finds the best optimum that eight of its own starts
    find without the library."""
    models = load_task_models(tasks)
    similar = tmp_path / "similar_tasks.json"
    data = json.loads(tasks.read_text())
    _add_scaled_task(data, "drawing", "drawing_firmer", 1.1**2)
    similar.write_text(json.dumps(data))
    assert "drawing_firmer" in load_task_models(similar) and "drawing" in models
    library = tmp_path / "library"
    common = ["--tasks", similar, "--executor", "serial"]
    filled = cli(
        "synthesize", *common, "--task", "drawing", "--starts", "6", "--out", tmp_path / "a", "--library", library
    )
    assert filled.exit_code == 0, filled.output
    assert "nothing yet for this hand, object and fingers" in filled.output and "kept in" in filled.output
    alone = cli("synthesize", *common, "--task", "drawing_firmer", "--starts", "6", "--out", tmp_path / "b")
    assert alone.exit_code == 0, alone.output
    warm = cli(
        "synthesize",
        *common,
        "--task",
        "drawing_firmer",
        "--starts",
        "1",
        "--out",
        tmp_path / "c",
        "--library",
        library,
    )
    assert warm.exit_code == 0, warm.output
    assert "warm starts first, the optima of task 'drawing'" in warm.output
    best_alone = pd.read_parquet(tmp_path / "b" / "drawing_firmer" / "optima.parquet")["Q"].min()
    solutions = pd.read_parquet(tmp_path / "c" / "drawing_firmer" / "solutions.parquet")
    warm_rows = solutions[solutions["position"] == "library"]
    assert len(warm_rows) == len(pd.read_parquet(tmp_path / "a" / "drawing" / "optima.parquet"))
    assert warm_rows["start_id"].min() >= 1000 and warm_rows["verified"].all()
    best_warm = pd.read_parquet(tmp_path / "c" / "drawing_firmer" / "optima.parquet")["Q"].min()
    assert best_warm <= best_alone * 1.01, (best_warm, best_alone)
    run = json.loads((tmp_path / "c" / "drawing_firmer" / "run.json").read_text())
    assert run["library"]["from_task"] == "drawing" and run["library"]["distance"] > 0
    assert json.loads((tmp_path / "b" / "drawing_firmer" / "run.json").read_text())["library"] is None
    report = cli("report", "--results", tmp_path / "c", "--out", tmp_path / "report")
    assert report.exit_code == 0, report.output
    said = json.loads((tmp_path / "report" / "report.json").read_text())["summary"]
    assert any("warm starts from task 'drawing' of the grasp library" in line for line in said), said
