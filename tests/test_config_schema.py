"""One schema per config file: an unknown key, a wrong type and a value out of range give the same kind of one
line, naming the file and the key; the shipped files set only what differs from the schema's defaults."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import yaml

from grasptask.errors import BadInputError
from grasptask.grasp.settings import GraspSettings, load_grasp_settings
from grasptask.physics.settings import PhysicsSettings, load_physics_settings
from grasptask.pipeline.runner import load_pipeline
from grasptask.synthesis.config import IPOPT_DEFAULTS, SolverConfig, load_solver_config

LOADERS = {
    "solver": (load_solver_config, "first_posture", 0.3),
    "grasp": (load_grasp_settings, "friction_scale", 0.5),
    "physics": (load_physics_settings, "settle_s", 0.2),
}


@pytest.mark.parametrize("kind", sorted(LOADERS))
@pytest.mark.parametrize(
    "value, problem",
    [
        ("unknown", "unknown field 'no_such_key' (allowed: "),
        ("text", "must be a valid number, got 'abc'"),
        ("bool", "must be a valid number, got True"),
        ("negative", "must be greater than"),
        ("nan", "must be a finite number, got nan"),
    ],
)
def test_every_config_file_refuses_bad_keys_in_one_line_naming_file_and_key(tmp_path, kind, value, problem):
    load, key, _ = LOADERS[kind]
    text = {
        "unknown": "no_such_key: 1\n",
        "text": f"{key}: abc\n",
        "bool": f"{key}: true\n",
        "negative": f"{key}: -1\n",
        "nan": f"{key}: .nan\n",
    }[value]
    path = tmp_path / f"{kind}.yaml"
    path.write_text(text)
    with pytest.raises(BadInputError) as caught:
        load(path)
    line = str(caught.value)
    assert "\n" not in line and line.startswith(f"{path}: ") and problem in line
    if value != "unknown":
        assert f"field '{key}': " in line


@pytest.mark.parametrize("kind", sorted(LOADERS))
def test_a_config_sets_only_what_it_changes(tmp_path, kind):
    load, key, changed = LOADERS[kind]
    path = tmp_path / f"{kind}.yaml"
    path.write_text(f"# only one key\n{key}: {changed}\n")
    loaded = load(path)
    defaults = {"solver": SolverConfig(), "grasp": GraspSettings(), "physics": PhysicsSettings()}[kind]
    assert loaded == dataclasses.replace(defaults, **{key: changed})


def test_the_shipped_configs_set_only_what_differs_from_the_defaults():
    schemas = {
        "solver.yaml": SolverConfig(),
        "grasp.yaml": GraspSettings(),
        "grasp_paper.yaml": GraspSettings(),
        "physics.yaml": PhysicsSettings(),
    }
    for name, defaults in schemas.items():
        data = yaml.safe_load(Path("configs", name).read_text()) or {}
        for key, value in data.items():
            assert getattr(defaults, key) != value, f"configs/{name}: '{key}' repeats its default"
    assert load_solver_config("configs/solver.yaml").ipopt == IPOPT_DEFAULTS


def test_ipopt_options_are_set_over_the_defaults(tmp_path):
    path = tmp_path / "solver.yaml"
    path.write_text("ipopt: {max_wall_time: 30.0, linear_solver: mumps}\n")
    ipopt = load_solver_config(path).ipopt
    assert ipopt == {**IPOPT_DEFAULTS, "max_wall_time": 30.0, "linear_solver": "mumps"}


@pytest.mark.parametrize(
    "text, problem",
    [
        ("name: x\nstages:\n  - run: simulate\n", "missing field 'stages[1].outputs'"),
        ("name: x\nstages: []\n", "field 'stages': "),
        ("name: x\nstages:\n  - {run: simulate, outputs: [o], output: [p]}\n", "unknown field 'stages[1].output'"),
        ("name: x\nstages:\n  - {run: simulate, outputs: o}\n", "field 'stages[1].outputs': must be a valid list"),
        ("stages:\n  - {run: simulate, outputs: [o]}\n", "missing field 'name'"),
        ("name: x\nstage: []\n", "unknown field 'stage' (allowed: description, final_message, name, stages, state)"),
    ],
)
def test_a_bad_pipeline_file_is_one_line_naming_the_key(tmp_path, text, problem):
    path = tmp_path / "pipeline.yaml"
    path.write_text(text)
    with pytest.raises(BadInputError) as caught:
        load_pipeline(path)
    assert "\n" not in str(caught.value) and problem in str(caught.value)
