"""One schema per config file: an unknown key, a wrong type and a value out of range give the same kind of one
line, naming the file and the key; the shipped files set only what differs from the schema's defaults."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import yaml

from grasptask.errors import BadInputError
from grasptask.grasp.grasp_settings import GraspSettings, load_grasp_settings
from grasptask.hand.hand_config import ModelHandConfig
from grasptask.hand.hand_files import load_hand
from grasptask.objects.object_config import SCHEMAS
from grasptask.objects.object_files import load_object
from grasptask.physics.physics_settings import PhysicsSettings, load_physics_settings
from grasptask.pipeline.runner import load_pipeline
from grasptask.synthesis.solver_config import IPOPT_DEFAULTS, SolverConfig, load_solver_config
from grasptask.task.tool import ToolFile, load_tool

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
    for path in sorted(Path("configs/objects").glob("*.yaml")):
        data = yaml.safe_load(path.read_text())
        _sets_only_changes(path, data, SCHEMAS[data["type"]])
    _sets_only_changes(
        Path("configs/hands/allegro.yaml"),
        yaml.safe_load(Path("configs/hands/allegro.yaml").read_text()),
        ModelHandConfig,
    )
    for path in sorted(Path("configs/tools").glob("*.yaml")):
        _sets_only_changes(path, yaml.safe_load(path.read_text()), ToolFile)


def _plain(value):
    if dataclasses.is_dataclass(value):
        return {k: _plain(v) for k, v in dataclasses.asdict(value).items()}  # type: ignore[arg-type]
    return [_plain(v) for v in value] if isinstance(value, list | tuple) else value


def _sets_only_changes(path: Path, data: dict, schema: type) -> None:
    for field in dataclasses.fields(schema):
        if field.name in data and field.default is not dataclasses.MISSING:
            assert _plain(field.default) != _plain(data[field.name]), f"{path}: '{field.name}' repeats its default"


def test_ipopt_options_are_set_over_the_defaults(tmp_path):
    path = tmp_path / "solver.yaml"
    path.write_text("ipopt: {max_iter: 300, linear_solver: mumps}\n")
    ipopt = load_solver_config(path).ipopt
    assert ipopt == {**IPOPT_DEFAULTS, "max_iter": 300, "linear_solver": "mumps"}


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


@pytest.mark.parametrize(
    "kind, text, problem",
    [
        (
            "object",
            "type: superquadric\nsize_m: [0.01, 0.01, 0.1]\nexponents: [1, 1]\ncolour: red\n",
            "unknown field 'colour'",
        ),
        (
            "object",
            "type: mesh\nmesh: m.stl\ngrid_spacing_m: 0.1\n",
            "field 'grid_spacing_m': must be less than or equal",
        ),
        ("object", "type: mesh\nmesh: m.stl\nmass_kg: heavy\n", "field 'mass_kg': must be a valid number"),
        ("object", "type: mesh\nmesh: m.stl\ntask_frame: {origin_m: [0, 0, .nan]}\n", "task_frame"),
        (
            "object",
            "type: superquadric\nsize_m: [0.01, 0.01, 0.1]\nexponents: [1, 1]\npose: {position_m: [0, 3, 0]}\n",
            "field 'pose.position_m[2]': must be less than or equal to 2",
        ),
        ("object", "type: gp\nn_support: 4\n", "a gp object needs one of 'mesh' or 'points_csv'"),
        (
            "hand",
            "model: h.urdf\npads: {tip: {point_m: [0, 0], normal: [1, 0, 0], tangent: [0, 1, 0]}}\n",
            "field 'pads.tip.point_m'",
        ),
        (
            "object",
            "type: mesh\nmesh: m.stl\ntask_frame: {origin: [0, 0, 0]}\n",
            "unknown field 'task_frame.origin' (allowed: origin_m, rotation_rpy_deg)",
        ),
        (
            "hand",
            "model: h.urdf\npads: {FF_TIP: {point_m: [0, 0, 0], normal: [1, 0, 0], tangent: [0, 1, 0], radius_m: -1}}",
            "field 'pads.FF_TIP.radius_m': must be greater than or equal to 0",
        ),
        ("hand", "model: h.urdf\ncompliance_m: -0.001\n", "field 'compliance_m': must be greater than or equal to 0"),
        ("hand", "model: h.urdf\nfingertip: [a, b]\n", "unknown field 'fingertip' (allowed: approach, compliance_m,"),
        ("tool", "name: t\nsensor: {position_m: [0, 0, x]}\n", "field 'sensor.position_m[3]': must be a valid number"),
        (
            "tool",
            "name: t\ncolumns: {force_x: Fx}\n",
            "unknown field 'columns.force_x' (allowed: fx, fy, fz, t, tx, ty, tz)",
        ),
        ("tool", "name: t\nunits: {torque_unit: lbf.in}\n", "unknown unit 'lbf.in' in 'units.torque_unit'"),
        (
            "tool",
            "name: t\nsensor: {rotation_matrix: [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}\n",
            "field 'sensor': rotation_matrix must be a 3x3 rotation matrix",
        ),
    ],
)
def test_object_hand_and_tool_files_name_the_key_at_fault(tmp_path, kind, text, problem):
    path = tmp_path / f"{kind}.yaml"
    path.write_text(text)
    load = {"object": load_object, "hand": load_hand, "tool": load_tool}[kind]
    with pytest.raises(BadInputError) as caught:
        load(path)
    line = str(caught.value)
    assert "\n" not in line and line.startswith(f"{path}: ") and problem in line, line
