"""Hostile or wrong input: one line naming the file and field, exit code 2, nothing written, and no name taken
from an input ever becoming a path outside --out."""

import json
import shutil
import time
from pathlib import Path

import pandas as pd
import pytest
import yaml

from grasptask.cli import run_stage
from grasptask.errors import BadInputError
from grasptask.pipeline.runner import load_pipeline, run_pipeline

FAST = Path("tests/data/solver_fast.yaml")


def one_line(result) -> str:
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    return lines[0]


def relabelled(simulated, root: Path, names: dict[str, str]) -> Path:
    """The simulated recordings with their tasks renamed (and the others left out); returns the manifest."""
    recordings = root / "recordings"
    shutil.copytree(simulated[0] / "recordings", recordings)
    manifest = pd.read_csv(recordings / "manifest.csv")
    manifest = manifest[manifest["task"].isin(names)].copy()
    manifest["id"] = [f"{names[t]}_{i}" for i, t in zip(manifest["id"], manifest["task"], strict=True)]
    manifest["task"] = manifest["task"].map(names)
    manifest.to_csv(recordings / "manifest.csv", index=False)
    return recordings / "manifest.csv"


def test_task_labels_never_become_paths_outside_out(simulated, tmp_path, cli):
    escape = "x/../../../escaped"
    manifest = relabelled(simulated, tmp_path / "results", {"cutting": escape})
    assert cli("fit-task", manifest, "--out", tmp_path / "results" / "tasks").exit_code == 0
    result = cli("report", "--results", tmp_path / "results", "--out", tmp_path / "results" / "report")
    assert result.exit_code == 0, result.output
    everything = {p.name for p in tmp_path.parent.rglob("*escaped*")}
    # the report's own files for the task, their names made safe, inside the report's folder
    assert everything <= {"ellipsoids_x_.._.._.._escaped.png", "axes_x_.._.._.._escaped.md"}, everything
    assert all(p.is_relative_to(tmp_path / "results" / "report") for p in tmp_path.parent.rglob("*escaped*"))
    tasks = tmp_path / "results" / "tasks" / "task_models.json"
    line = one_line(cli("synthesize", "--tasks", tasks, "--task", escape, "--out", tmp_path / "grasps"))
    assert "cannot be a file or folder name" in line and not (tmp_path / "grasps").exists()


@pytest.mark.slow
def test_a_report_on_tasks_the_paper_does_not_have(simulated, tmp_path, cli):
    manifest = relabelled(simulated, tmp_path / "r", {"cutting": "scooping", "screwdriving": "wiping"})
    results = tmp_path / "r"
    assert cli("fit-task", manifest, "--out", results / "tasks").exit_code == 0
    assert cli("distances", results / "tasks" / "ellipsoids.parquet", "--out", results / "tasks").exit_code == 0
    synthesized = cli(
        "synthesize", "--tasks", results / "tasks" / "task_models.json", "--task", "wiping", "--out",
        results / "grasps", "--solver-config", FAST, "--starts", "2", "--executor", "serial",
    )  # fmt: skip
    assert synthesized.exit_code == 0, synthesized.output
    result = cli("report", "--results", results)
    assert result.exit_code == 0, result.output
    report = json.loads((results / "report" / "report.json").read_text())
    assert "own_groups" in report["tables"] and "synthesis_sweeps" in report["tables"]
    assert any("nothing compared" in n for n in report["notes"])


def write_models(path: Path, source: Path, change) -> Path:
    data = json.loads(source.read_text())
    change(data["tasks"]["drawing"])
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize(
    "change, expected",
    [
        (lambda m: m["S"][0].__setitem__(1, m["S"][0][1] + 1.0), "is not symmetric"),
        (lambda m: m.__setitem__("S", [row[:5] for row in m["S"][:5]]), "must be 6 x 6"),
        (lambda m: m.__setitem__("S", [[0.0] * 6 for _ in range(6)]), "is all zero"),
        (lambda m: m.__setitem__("S", [[-1.0 if i == j else 0.0 for j in range(6)] for i in range(6)]), "positive"),
        (lambda m: m.__setitem__("S", "six by six"), "not a matrix of numbers"),
    ],
)
def test_task_models_must_be_spd(tasks, tmp_path, cli, change, expected):
    bad = write_models(tmp_path / "models.json", tasks, change)
    line = one_line(cli("synthesize", "--tasks", bad, "--task", "drawing", "--out", tmp_path / "o"))
    assert "models.json" in line and "tasks.drawing.S" in line and expected in line
    assert not (tmp_path / "o").exists()


def test_ellipsoids_must_be_spd(simulated, tmp_path, cli):
    table = pd.read_parquet(simulated[0] / "tasks" / "ellipsoids.parquet")
    s = list(table.loc[4, "S"])
    s[1] += 5.0
    table.at[4, "S"] = s
    table.to_parquet(tmp_path / "e.parquet")
    line = one_line(cli("distances", tmp_path / "e.parquet", "--out", tmp_path / "o"))
    assert "row 5" in line and "'S'" in line and "not symmetric" in line


def test_a_yaml_alias_bomb_is_refused_at_once(tmp_path, recording_factory, cli):
    bomb = ["a: &a [x, x, x, x, x, x, x, x, x]"]
    for k, name in enumerate("bcdefghi"):
        previous = "abcdefghi"[k]
        bomb.append(f"{name}: &{name} [*{previous}, *{previous}, *{previous}, *{previous}, *{previous}]")
    tool = tmp_path / "tool.yaml"
    tool.write_text("\n".join(bomb) + "\nsensor: {position_m: [0, 0, 0]}\nignore_columns: *i\n")
    recording_factory("rec.csv")
    began = time.process_time()  # this process's CPU time: the same on a busy machine
    line = one_line(cli("fit-task", tmp_path / "rec.csv", "--frame", "sensor", "--tool", tool, "--out", tmp_path / "o"))
    assert time.process_time() - began < 5 and "tool.yaml" in line and "aliases" in line


def edited_hand(tmp_path: Path, edit) -> Path:
    data = yaml.safe_load(Path("configs/hands/human.yaml").read_text())
    edit(data)
    path = tmp_path / "hand.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize(
    "edit, expected",
    [
        (lambda d: d["fingers"]["index"]["base"].pop("position_m"), "fingers.index.base.position_m"),
        (lambda d: d["palm"].pop("radius_m"), "palm.radius_m"),
        (lambda d: d["fingers"]["thumb"]["joints"][1].__setitem__("max_deg", "ninety"), "joints[2].max_deg"),
        (lambda d: d["tendons"]["index"]["muscles"]["FDP"].__setitem__("arms_mm", [1, 2]), "FDP.arms_mm"),
    ],
)
def test_bad_hand_files(tasks, tmp_path, cli, edit, expected):
    hand = edited_hand(tmp_path, edit)
    line = one_line(cli("synthesize", "--tasks", tasks, "--task", "drawing", "--out", tmp_path / "o", "--hand", hand))
    assert "hand.yaml" in line and expected in line and not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    "text, expected",
    [
        (
            "exponents: [0.1, 1.0, 2.0]\nsize_m: [0.01, 0.01, 0.1]\n",
            "field 'exponents': tuple should have at most 2 items",
        ),
        ("exponents: [0.1, 1.0]\nsize_m: [0.01, wide, 0.1]\n", "size_m[2]"),
        ("exponents: [0.1, 1.0]\nsize_m: [0.01, 0.01, 0.1]\npose: {position_m: [0, 0]}\n", "pose.position_m"),
    ],
)
def test_bad_object_files(tasks, tmp_path, cli, text, expected):
    obj = tmp_path / "object.yaml"
    obj.write_text("type: superquadric\n" + text)
    line = one_line(cli("synthesize", "--tasks", tasks, "--task", "drawing", "--out", tmp_path / "o", "--object", obj))
    assert "object.yaml" in line and expected in line


def test_a_folder_given_for_a_file_says_so(tmp_path, cli):
    (tmp_path / "manifest.csv").mkdir()
    assert "is a folder" in one_line(cli("fit-task", tmp_path / "manifest.csv", "--out", tmp_path / "o"))


def simulate_pipeline(tmp_path: Path) -> Path:
    spec = {
        "name": "sim",
        "state": str(tmp_path / "state.json"),
        "stages": [
            {
                "name": "simulate",
                "run": "simulate",
                "args": ["--out", str(tmp_path / "recordings"), "--format", "csv"],
                "outputs": [str(tmp_path / "recordings")],
            }
        ],
    }
    path = tmp_path / "pipeline.yaml"
    path.write_text(yaml.safe_dump(spec))
    return path


def test_the_pipeline_never_overwrites_edited_or_foreign_outputs_without_force(tmp_path):
    spec = load_pipeline(simulate_pipeline(tmp_path))
    messages: list[str] = []
    assert run_pipeline(spec, run_stage, echo=messages.append).ran == ["simulate"]
    recording = next((tmp_path / "recordings" / "recordings").glob("*.csv"))
    recording.write_text(recording.read_text().replace("0.0", "0.5", 1))  # a user's edit
    edited = recording.read_text()
    with pytest.raises(BadInputError, match="changed since this pipeline made them.*--force"):
        run_pipeline(spec, run_stage, echo=messages.append)
    (tmp_path / "state.json").unlink()
    with pytest.raises(BadInputError, match="did not make it"):
        run_pipeline(spec, run_stage, echo=messages.append)
    assert recording.read_text() == edited
    assert run_pipeline(spec, run_stage, force=True, echo=messages.append).ran == ["simulate"]
    assert recording.read_text() != edited


@pytest.mark.parametrize("state", ["{not json", "[1, 2, 3]", '{"simulate": 7}'])
def test_an_unreadable_pipeline_state_is_one_line(tmp_path, cli, state):
    path = simulate_pipeline(tmp_path)
    (tmp_path / "state.json").write_text(state)
    line = one_line(cli("pipeline", "run", path))
    assert "state.json" in line and "not a pipeline state file" in line and "--force" in line
    assert not (tmp_path / "recordings").exists()


def test_the_bundled_pipelines_declare_every_output_of_a_sweep():
    for name in ("demo", "paper"):
        for stage in load_pipeline(f"pipelines/{name}.yaml").stages:
            if stage.run == ["synthesize"]:
                assert {o.name for o in stage.outputs} == {"solutions.parquet", "optima.parquet", "run.json"}


def test_recordings_outside_the_manifest_folder_are_read_and_their_resolved_path_recorded(
    tmp_path, cli, recording_factory
):
    recording = recording_factory("rec.csv")
    (tmp_path / "sub").mkdir()
    rows = [{"path": "../rec.csv", "task": "drawing", "subject": "1", "trial": 1, "grasp": "tripod"}]
    pd.DataFrame(rows).to_csv(tmp_path / "sub" / "manifest.csv", index=False)
    assert cli("fit-task", tmp_path / "sub" / "manifest.csv", "--out", tmp_path / "o").exit_code == 0
    ledger = json.loads((tmp_path / "o" / "provenance.json").read_text())
    assert str(recording.resolve()) in ledger["ellipsoids.parquet"]["inputs"]


def test_a_recording_with_capitalised_columns_says_what_the_file_has(tmp_path, recording_factory, cli):
    """'column fx: missing column' left the user guessing; the line now names the file's 'Fx' and the mapping."""
    path = recording_factory("rec.csv")
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0].replace("fx", "Fx"), *lines[1:]]) + "\n")
    result = cli("fit-task", path, "--out", tmp_path / "out")
    assert result.exit_code == 2 and "the file has 'Fx'" in result.output and "columns: {fx: Fx}" in result.output
    assert not (tmp_path / "out").exists()


def test_a_finite_value_too_large_to_compute_with_is_one_line(tmp_path, recording_factory, cli):
    """1e308 is finite, and ended in numpy's 'Eigenvalues did not converge' inside fit-task."""
    from tests.conftest import wrench_samples

    data = wrench_samples()
    data[4, 2] = 1e308
    path = recording_factory("rec.csv", data)
    result = cli("fit-task", path, "--out", tmp_path / "out")
    assert result.exit_code == 2 and "row 5" in result.output and "column 'fy'" in result.output
    assert "too large" in result.output and len(result.output.strip().splitlines()) == 1
