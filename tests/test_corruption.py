"""Random corruptions of every kind of artifact the stages read: cut short, bytes flipped, values of the wrong
type. Whatever the damage, the command reading it either still succeeds (the damage left a valid file) or says
so in one line with exit code 2 and writes nothing: never a traceback, never a half-written output."""

import json
import os
import shutil
import tempfile
from pathlib import Path

import pandas as pd
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

FAST = Path("tests/data/solver_fast.yaml")


@pytest.fixture(scope="module")
def corpus(simulated, tmp_path_factory):
    """One good file of each kind, and a results folder with a finished two-start sweep."""
    from click.testing import CliRunner

    from grasptask.cli import main

    root = tmp_path_factory.mktemp("corpus")
    results = root / "results"
    results.mkdir()
    (results / "recordings").symlink_to(simulated[0] / "recordings", target_is_directory=True)
    shutil.copytree(simulated[0] / "tasks", results / "tasks")
    tasks = results / "tasks" / "task_models.json"
    out = CliRunner().invoke(
        main,
        ["synthesize", "--tasks", str(tasks), "--task", "drawing", "--out", str(results / "grasps"),
         "--solver-config", str(FAST), "--starts", "2", "--executor", "serial"],
    )  # fmt: skip
    assert out.exit_code == 0, out.output
    recordings = results / "recordings"
    first = pd.read_csv(recordings / "manifest.csv").iloc[0]
    recording_csv = root / "recording.csv"
    pd.read_parquet(recordings / first["path"]).iloc[:300].to_csv(recording_csv, index=False)
    pipeline = root / "pipeline.yaml"
    pipeline.write_text(
        yaml.safe_dump(
            {
                "name": "corpus",
                "state": str(root / "state.json"),
                "final_message": "done",
                "stages": [
                    {
                        "name": "fit",
                        "run": "fit-task",
                        "args": [str(recordings / "manifest.csv"), "--out", str(root / "pipeline-tasks")],
                        "inputs": [str(recordings)],
                        "outputs": [str(root / "pipeline-tasks" / "ellipsoids.parquet")],
                    },
                    {
                        "name": "distances",
                        "run": "distances",
                        "args": [str(root / "pipeline-tasks" / "ellipsoids.parquet"), "--out", str(root / "pt")],
                        "outputs": [str(root / "pt" / "distances.parquet")],
                    },
                ],
            }
        )
    )
    return {
        "results": results,
        "tasks": tasks,
        "solutions": results / "grasps" / "drawing" / "solutions.parquet",
        "files": {
            "recording.csv": recording_csv,
            "recording.parquet": recordings / first["path"],
            "manifest.csv": recordings / "manifest.csv",
            "tool.yaml": recordings / "sensorized_tool.yaml",
            "ellipsoids.parquet": results / "tasks" / "ellipsoids.parquet",
            "task_models.json": tasks,
            "solutions.parquet": results / "grasps" / "drawing" / "solutions.parquet",
            "hand.yaml": Path("configs/hands/human.yaml"),
            "object.yaml": Path("configs/objects/tool.yaml"),
            "grasp.yaml": Path("configs/grasp.yaml"),
            "solver.yaml": FAST,
            "pipeline.yaml": pipeline,
            "stats.csv": results / "tasks" / "stats.csv",
            "run.json": results / "grasps" / "drawing" / "run.json",
            "distances.parquet": results / "tasks" / "distances.parquet",
        },
    }


def command(kind: str, bad: Path, corpus: dict, work: Path) -> list:
    """The command that reads an artifact of ``kind`` (the corrupted copy at ``bad``), writing under ``work``."""
    out = work / "out"
    verify = ["verify", corpus["solutions"], "--tasks", corpus["tasks"], "--task", "drawing", "--out", out]
    if kind == "recording.csv" or kind == "recording.parquet":
        return ["fit-task", bad, "--task", "drawing", "--out", out]
    if kind == "manifest.csv":
        return ["fit-task", bad, "--out", out]
    if kind == "tool.yaml":
        return ["fit-task", corpus["files"]["recording.csv"], "--frame", "sensor", "--tool", bad, "--out", out]
    if kind == "ellipsoids.parquet":
        return ["distances", bad, "--out", out]
    if kind == "task_models.json":
        return ["verify", corpus["solutions"], "--tasks", bad, "--task", "drawing", "--out", out]
    if kind == "solutions.parquet":
        return ["verify", bad, "--tasks", corpus["tasks"], "--task", "drawing", "--out", out]
    if kind in ("hand.yaml", "object.yaml", "grasp.yaml"):
        option = {"hand.yaml": "--hand", "object.yaml": "--object", "grasp.yaml": "--grasp-config"}[kind]
        return [*verify, option, bad]
    if kind == "solver.yaml":
        return ["synthesize", "--tasks", corpus["tasks"], "--task", "drawing", "--out", out, "--solver-config", bad,
                "--starts", "1", "--executor", "serial"]  # fmt: skip
    if kind == "pipeline.yaml":
        return ["pipeline", "run", bad, "--dry-run"]
    # stats.csv, run.json, distances.parquet: read by the report from a copy of the results folder
    return ["report", "--results", bad, "--out", out]


def place(kind: str, data: bytes, corpus: dict, work: Path) -> Path:
    """Write the corrupted bytes where the command will read them; returns the path to pass."""
    if kind in ("stats.csv", "run.json", "distances.parquet"):
        results = work / "results"
        shutil.copytree(corpus["results"], results, symlinks=True)
        relative = corpus["files"][kind].relative_to(corpus["results"])
        (results / relative).write_bytes(data)
        return results
    if kind == "manifest.csv":  # beside its recordings, which it names relative to itself
        folder = work / "recordings"
        shutil.copytree(corpus["files"][kind].parent, folder)
        (folder / "manifest.csv").write_bytes(data)
        return folder / "manifest.csv"
    path = work / kind
    path.write_bytes(data)
    return path


def wrong_type(data: bytes, kind: str, draw) -> bytes:
    """A value somewhere in a JSON or YAML file replaced by one of the wrong type."""
    load, dump = (json.loads, json.dumps) if kind.endswith(".json") else (yaml.safe_load, yaml.safe_dump)
    tree = load(data.decode())
    leaves = []

    def walk(node, path):
        if isinstance(node, dict):
            for k, v in node.items():
                walk(v, [*path, k])
        elif isinstance(node, list) and node:
            for i, v in enumerate(node):
                walk(v, [*path, i])
        leaves.append(path)

    walk(tree, [])
    path = draw(st.sampled_from(leaves))
    value = draw(st.sampled_from(["text", None, [], {"x": 1}, -1, 1e308, True]))
    if not path:
        return dump(value).encode()
    node = tree
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return dump(tree).encode()


@st.composite
def corruption(draw, kind: str, original: bytes) -> bytes:
    how = draw(st.sampled_from(["truncate", "flip"] + (["type"] if kind.endswith((".json", ".yaml")) else [])))
    if how == "truncate":
        return original[: draw(st.integers(0, max(0, len(original) - 1)))]
    if how == "type":
        return wrong_type(original, kind, draw)
    data = bytearray(original)
    for _ in range(draw(st.integers(1, 8))):
        data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
    return bytes(data)


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


KINDS = [
    "recording.csv", "recording.parquet", "manifest.csv", "tool.yaml", "ellipsoids.parquet", "task_models.json",
    "solutions.parquet", "hand.yaml", "object.yaml", "grasp.yaml", "solver.yaml", "pipeline.yaml", "stats.csv",
    "run.json", "distances.parquet",
]  # fmt: skip


#: a whole report each (a valid corruption of these makes one): make test-slow tries them
REPORT_KINDS = ("stats.csv", "distances.parquet")


@pytest.mark.parametrize("kind", [pytest.param(k, marks=pytest.mark.slow) if k in REPORT_KINDS else k for k in KINDS])
def test_a_corrupted_artifact_is_one_line_and_nothing_written(kind, corpus, cli):
    original = corpus["files"][kind].read_bytes()
    # a solver config left valid runs a start, a results folder left valid makes a whole report: fewer of those;
    # GRASPTASK_CORRUPTIONS=N tries N of each kind (a longer hunt)
    slow = kind in ("solver.yaml", "stats.csv", "run.json", "distances.parquet")
    examples = int(os.environ.get("GRASPTASK_CORRUPTIONS", 10)) // (10 if slow else 1)

    @settings(max_examples=examples, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
    @given(data=corruption(kind, original))
    def check(data):
        work = Path(tempfile.mkdtemp(prefix="corrupt-"))
        try:
            bad = place(kind, data, corpus, work)
            before = snapshot(work)
            result = cli(*command(kind, bad, corpus, work))
            assert result.exit_code in (0, 2), result.output
            if result.exit_code == 2:
                lines = [line for line in result.output.splitlines() if line.strip()]
                assert [line for line in lines if line.startswith("error:")] == lines[-1:], result.output
                assert snapshot(work) == before
        finally:
            shutil.rmtree(work, ignore_errors=True)

    check()
