"""The layout the other issues build on: the CLI over grasptask.stages only, a report that does not load the
solver stack, the NLP's equation map in its order, and options checked before any work."""

import ast
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyomo.environ as pyo

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand import load_hand
from grasptask.objects import load_object
from grasptask.synthesis.nlp import EQUATIONS, build_model
from grasptask.task.task_model import load_task_models


def test_the_cli_imports_only_the_stages_package():
    for module in Path("grasptask/cli").glob("*.py"):
        tree = ast.parse(module.read_text())
        imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
        imported |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
        below = {m for m in imported if m and m.startswith("grasptask") and not m.startswith("grasptask.cli")}
        assert below <= {"grasptask", "grasptask.stages"}, module


def test_the_report_does_not_load_the_solver_stack():
    code = (
        "import sys, pkgutil, importlib, grasptask.report\n"
        "for m in pkgutil.iter_modules(grasptask.report.__path__):\n"
        "    importlib.import_module('grasptask.report.' + m.name)\n"
        "import grasptask.stages.html_report\n"
        "print(sorted(m for m in ('casadi', 'pyomo', 'grasptask.synthesis.backends') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


AXIS = (np.array([0.0, 0.0, 1.0]), np.zeros(3))


def test_the_equation_families_create_their_components_in_the_paper_s_order(simulated):
    """The order of creation fixes the NL writer's column order, which the solver's path depends on."""
    tasks = load_task_models(simulated[0] / "tasks" / "task_models.json")
    model = build_model(load_hand(), load_object("configs/objects/tool.yaml"), tasks["drawing"], GraspSettings()).model
    names = [c.local_name for c in model.component_objects((pyo.Var, pyo.Constraint, pyo.Objective))]
    assert [f.__name__ for f in EQUATIONS] == [
        "palm_and_joints",
        "held_axis_rotation",
        "kinematics",
        "contacts_and_collisions",
        "cones_and_wrenches",
        "jacobians",
        "edge_torques",
        "force_closure",
        "task_forces_and_quality",
        "torque_feasibility",
        "objective",
    ]
    assert names == [
        "R_h", "d_h", "theta", "eq16_23_palm_orthonormal", "eq22_coupling",
        "frame", "eq2_frame", "p", "eq2_contact_point",
        "eq3_contact", "eq14_collision", "n", "t", "normal_definition", "tangent_definition", "eq2_rolling_contact",
        "pad_facing",
        "l", "l_torque", "eq24_cone_edge", "eq5_wrench",
        "J", "eq7_jacobian", "edge_torque", "eq7_edge_torque",
        "phi", "eq4_weights_sum", "eq4_force_closure",
        "force", "eq8_task_force",
        "lam", "act", "eq10_wrench", "eq10_torque", "eq10_normal",
        "eq12_objective",
    ]  # fmt: skip
    # the held turn (only when asked) comes right after the palm pose it holds
    held = build_model(
        load_hand(), load_object("configs/objects/tool.yaml"), tasks["drawing"], GraspSettings(), held_axis=AXIS
    ).model
    held_names = [c.local_name for c in held.component_objects((pyo.Var, pyo.Constraint, pyo.Objective))]
    assert held_names == names[:5] + ["held_reference", "held_axis_rotation"] + names[5:]


def test_executor_options_that_contradict_each_other_are_refused(cli, simulated, tmp_path):
    tasks = simulated[0] / "tasks" / "task_models.json"
    base = ("synthesize", "--tasks", tasks, "--task", "drawing", "--out", tmp_path)
    for extra, expected in (
        (("--executor", "serial", "--workers", "2"), "drop --workers 2"),
        (("--executor", "dask"), "needs --scheduler"),
        (("--scheduler", "tcp://127.0.0.1:1"), "for --executor dask"),
    ):
        result = cli(*base, *extra)
        assert result.exit_code == 2 and expected in result.output, result.output
        assert len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "drawing").exists()


def test_the_top_level_help_names_the_whole_pipeline(cli):
    shown = cli("--help").output
    for command in ("simulate", "fit-task", "distances", "synthesize", "verify", "physics", "export", "report"):
        assert command in shown.split("Options:")[0], command


def test_q_is_printed_with_three_significant_digits():
    from grasptask.cli.summaries import number

    assert number(0.00074) == "0.00074" and number(0.0018) == "0.0018" and number(None) == "n/a"


def test_a_mesh_given_as_a_hand_names_the_kinds_of_hand_file(cli, tmp_path, tasks):
    import trimesh

    mesh = tmp_path / "sugar_box.stl"
    trimesh.creation.box((0.09, 0.04, 0.175)).export(mesh)
    result = cli("synthesize", "--tasks", tasks, "--task", "drawing", "--out", tmp_path / "o", "--hand", mesh)
    assert result.exit_code == 2 and "URDF" in result.output and "MJCF" in result.output and "YAML" in result.output
    assert not (tmp_path / "o").exists()


def test_every_docs_page_the_code_names_exists():
    """Comments, docstrings, configs and benchmarks point readers at docs pages; a page moved or renamed would
    leave them pointing nowhere."""
    import re

    named = re.compile(r"docs/[\w./-]+\.md")
    sources = [p for folder in ("grasptask", "benchmarks", "tools", "tests", "configs", "pipelines")
               for p in Path(folder).rglob("*") if p.suffix in (".py", ".yaml", ".yml", ".md")]  # fmt: skip
    sources += [Path("Makefile"), Path("README.md"), Path("mkdocs.yml")]
    dangling = sorted(
        f"{path}: {page}"
        for path in sources
        for page in set(named.findall(path.read_text()))
        if not Path(page).is_file()
    )
    assert not dangling, dangling


def test_no_function_in_the_package_is_over_60_lines_and_no_cli_module_over_400():
    long = []
    for module in Path("grasptask").rglob("*.py"):
        for node in ast.walk(ast.parse(module.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.end_lineno - node.lineno >= 60:
                long.append(f"{module}:{node.lineno} {node.name} ({node.end_lineno - node.lineno + 1} lines)")
    assert not long, long
    assert all(len(m.read_text().splitlines()) <= 400 for m in Path("grasptask/cli").glob("*.py"))


def test_no_two_modules_share_a_name_and_none_is_named_as_a_package():
    names = [m.stem for m in Path("grasptask").rglob("*.py") if m.stem not in ("__init__", "__main__")]
    packages = {p.name for p in Path("grasptask").iterdir() if (p / "__init__.py").is_file()}
    assert sorted({n for n in names if names.count(n) > 1}) == []
    assert sorted(set(names) & packages) == []


def test_only_the_run_record_module_names_the_run_record_file():
    """A sweep's run.json is read in one place (records.run_record, imported by the sweep reader and written by
    synthesize: an import-linter contract); a path built from the bare name anywhere else would be a second
    reader."""
    naming = []
    for module in Path("grasptask").rglob("*.py"):
        for node in ast.walk(ast.parse(module.read_text())):
            if isinstance(node, ast.Constant) and node.value == "run.json":
                naming.append(str(module))
    assert naming == ["grasptask/records/run_record.py"]


def test_every_stage_command_runs_through_its_stage_and_options():
    """One contract, ``run_X(XOptions) -> XSummary``: every command but the group's own is registered with its
    options, its stage and what it says, and each options class refuses a bad value when it is made."""
    import click
    import pytest

    from grasptask import stages
    from grasptask.cli import main
    from grasptask.cli.commands import STAGE_COMMANDS
    from grasptask.errors import BadInputError

    def names(group: click.Group, prefix: str = "") -> set[str]:
        found: set[str] = set()
        for name, command in group.commands.items():
            if isinstance(command, click.Group):
                found |= names(command, f"{prefix}{name} ")
            else:
                found.add(prefix + name)
        return found

    assert names(main) == set(STAGE_COMMANDS)
    refused = [
        lambda: stages.SimulateOptions(out="o", format="xlsx"),
        lambda: stages.FitTaskOptions(inputs=[], out="o"),
        lambda: stages.FitTaskOptions(inputs=["r.csv"], out="o", torque_unit="kN.m"),
        lambda: stages.PhysicsOptions(solutions="s.parquet", out="o", workers=0),
        lambda: stages.PhysicsOptions(solutions="s.parquet", out="o", controller="pid"),
        lambda: stages.ReportOptions(results="r", screenshot="top.png"),
        lambda: stages.SynthesisOptions(tasks="t.json", task="drawing", out="o", starts=0),
    ]
    for make in refused:
        with pytest.raises(BadInputError):
            make()


def test_a_pipeline_runs_its_stages_without_going_back_into_the_cli(tmp_path, recording_factory, monkeypatch):
    """``pipeline run`` parses each stage's line as Click would, then calls the stage itself: the command group's
    entry point is never called again, and a stage's bad input is its exit code 2, as on the command line."""
    import yaml

    from grasptask.cli import main, run_stage
    from grasptask.pipeline.runner import load_pipeline, run_pipeline

    def no_reentry(*args, **kwargs):
        raise AssertionError("pipeline run went back into the CLI")

    monkeypatch.setattr(main, "main", no_reentry)
    recording = recording_factory("rec.csv")
    stages = [
        {"name": "fit", "run": "fit-task", "args": [str(recording), "--out", str(tmp_path / "tasks")],
         "outputs": [str(tmp_path / "tasks")]},
        {"name": "distances", "run": "distances",
         "args": [str(tmp_path / "tasks" / "ellipsoids.parquet"), "--out", str(tmp_path / "distances")],
         "outputs": [str(tmp_path / "distances")]},
        {"name": "bad", "run": "distances", "args": [str(tmp_path / "none.parquet"), "--out", str(tmp_path / "x")],
         "outputs": [str(tmp_path / "x")]},
    ]  # fmt: skip
    path = tmp_path / "pipeline.yaml"
    path.write_text(yaml.safe_dump({"name": "t", "state": str(tmp_path / "state.json"), "stages": stages}))
    outcome = run_pipeline(load_pipeline(path), run_stage, echo=lambda _: None)
    assert outcome.ran == ["fit", "distances"] and (tmp_path / "distances" / "distance_summary.json").is_file()
    assert outcome.failed == "bad" and outcome.exit_code == 2 and not (tmp_path / "x").exists()
