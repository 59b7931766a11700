"""The pipeline runner: stages in order, skipped when unchanged, rerun downstream of a change, stop on failure."""

import shutil

import pytest
import yaml

from grasptask.cli import run_stage
from grasptask.pipeline.runner import load_pipeline, run_pipeline
from tests.conftest import wrench_samples


def write_pipeline(tmp_path, recording_dir, bad=False):
    spec = {
        "name": "t",
        "state": str(tmp_path / "state.json"),
        "stages": [
            {
                "name": "fit",
                "run": "fit-task",
                "args": [str(recording_dir / "rec.csv"), "--task", "drawing", "--out", str(tmp_path / "tasks")],
                "outputs": [str(tmp_path / "tasks" / "ellipsoids.parquet")],
            },
            {
                "name": "distances",
                "run": "distances",
                "args": [str(tmp_path / "tasks" / "ellipsoids.parquet"), "--out", str(tmp_path / "dist")],
                "outputs": [str(tmp_path / "dist" / "distances.parquet")],
            },
        ],
    }
    path = tmp_path / "pipeline.yaml"
    path.write_text(yaml.safe_dump(spec))
    return path


def test_runs_then_skips_then_reruns_after_a_change(tmp_path, recording_factory):
    from grasptask.task.recordings import write_recording

    recording_factory("rec.csv")
    spec = load_pipeline(write_pipeline(tmp_path, tmp_path))
    first = run_pipeline(spec, run_stage, echo=lambda _: None)
    assert first.ran == ["fit", "distances"] and first.failed is None
    second = run_pipeline(spec, run_stage, echo=lambda _: None)
    assert second.skipped == ["fit", "distances"]
    write_recording(tmp_path / "rec.csv", wrench_samples(seed=9))
    third = run_pipeline(spec, run_stage, echo=lambda _: None)
    assert third.ran == ["fit", "distances"]
    shutil.rmtree(tmp_path / "dist")
    fourth = run_pipeline(spec, run_stage, echo=lambda _: None)
    assert fourth.skipped == ["fit"] and fourth.ran == ["distances"]
    assert run_pipeline(spec, run_stage, force=True, echo=lambda _: None).ran == ["fit", "distances"]


def test_a_failing_stage_stops_the_pipeline_with_its_exit_code(tmp_path):
    (tmp_path / "rec.csv").write_text("")
    spec = load_pipeline(write_pipeline(tmp_path, tmp_path))
    messages = []
    outcome = run_pipeline(spec, run_stage, echo=messages.append)
    assert outcome.failed == "fit" and outcome.exit_code == 2
    assert outcome.ran == [] and not (tmp_path / "dist").exists()
    assert any("failed with exit code 2" in m for m in messages)


def test_pipeline_cli_and_bad_pipeline_file(tmp_path, cli):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nstages:\n  - run: simulate\n")
    result = cli("pipeline", "run", bad)
    assert result.exit_code == 2 and "outputs" in result.output


@pytest.mark.parametrize("name", ["demo", "paper"])
def test_bundled_pipelines_parse_and_end_with_the_report(name, cli):
    spec = load_pipeline(f"pipelines/{name}.yaml")
    assert [s.name for s in spec.stages] == [
        "simulate", "fit-task", "distances",
        "synthesize-drawing", "synthesize-cutting", "synthesize-screwdriving",
        "physics-drawing", "physics-cutting", "physics-screwdriving",
        "export-drawing", "export-cutting", "export-screwdriving", "report",
    ]  # fmt: skip
    assert spec.final_message == f"report: results/{name}/report/index.html"
    starts = [s.args[s.args.index("--starts") + 1] for s in spec.stages if "--starts" in s.args]
    assert starts == (["4", "4", "4"] if name == "demo" else [])  # the paper runs all 126
    for stage in spec.stages:  # every stage's arguments are ones its command accepts
        result = cli(*stage.run, *stage.args, "--help")
        assert result.exit_code == 0, result.output
    # the default configs a synthesis or physics stage reads are in its key, so that editing one re-runs it
    read = {"synthesize": ["solver.yaml"], "physics": ["physics.yaml"]}
    for stage in spec.stages:
        if stage.run[0] in read:
            names = {str(p) for p in stage.input_paths()}
            grasp = "grasp_paper.yaml" if name == "paper" else "grasp.yaml"  # the paper's model has no margin
            for config in [*read[stage.run[0]], grasp, "hands/human.yaml", "objects/tool.yaml"]:
                assert f"configs/{config}" in names, (stage.name, config)


def test_a_run_ends_with_the_time_it_took(tmp_path, recording_factory):
    """`make demo` and `make paper` print their time, so that the docs need quote none that goes stale."""
    recording_factory("rec.csv")
    spec = load_pipeline(write_pipeline(tmp_path, tmp_path))
    messages: list[str] = []
    run_pipeline(spec, run_stage, echo=messages.append)
    assert messages[-1].startswith("pipeline t: 2 stages ran, 0 skipped, in ") and messages[-1].endswith(" min")
