"""The physics check (issue 18): MuJoCo scenes built from the project's own hands, and the protocol's verdicts
on grasps whose outcome is known."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pandas as pd
import pytest
from grasp_fixtures import ONE_SIDE, TETRAHEDRON, drawing_like_task, gripper_grasp

from grasptask.hand import forward, load_hand
from grasptask.objects import load_object
from grasptask.physics import PhysicsSettings, build_scene, check_grasp, load_physics_settings
from grasptask.physics.controller import BoxLeastSquares, IndependentMotors
from grasptask.physics.scene import object_body

SETTINGS = load_physics_settings()
HANDS = ["configs/hands/human.yaml", "configs/hands/barrett_bh8_282.urdf", "configs/hands/allegro.yaml"]


def held(directions, effort_nm: float, task=None):
    hand, grasp, ball = gripper_grasp(directions, effort_nm)
    body = object_body(ball, SETTINGS)
    scene = build_scene(hand, ball, body, grasp, 0.5, SETTINGS)
    return check_grasp(scene, task or drawing_like_task(1.0), body.mass_kg, SETTINGS)


def test_the_shipped_config_is_the_documented_defaults():
    assert load_physics_settings() == PhysicsSettings()


@pytest.mark.parametrize("path", HANDS)
def test_the_scene_puts_every_collision_sphere_where_the_hands_kinematics_does(path):
    """MuJoCo's forward kinematics of the built scene against the project's, at a random posture; and the
    actuators give exactly the joint torques of the hand's force capability."""
    from tests.grasp_fixtures import ball_grasp

    hand = load_hand(path).grasping_hand()
    rng = np.random.default_rng(1)
    q = hand.apply_coupling(rng.uniform(hand.lower, hand.upper))
    _, ball = ball_grasp()
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    rotation *= np.sign(np.linalg.det(rotation))
    from grasptask.grasp.grasp import Grasp

    grasp = Grasp(rotation, np.array([0.05, -0.02, 0.1]), q)
    scene = build_scene(hand, ball, object_body(ball, SETTINGS), grasp, 0.5, SETTINGS)
    data = mujoco.MjData(scene.model)
    data.qpos[scene.hand_qpos] = q
    data.ctrl[:] = rng.uniform(0, 1, scene.model.nu)
    mujoco.mj_forward(scene.model, data)
    centres, _ = forward(hand, q, grasp.palm_rotation, grasp.palm_position).collision_spheres()
    spheres = [g for g in range(scene.model.ngeom) if scene.model.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE]
    placed = data.geom_xpos[spheres]
    gaps = np.linalg.norm(placed[:, None, :] - centres[0][None], axis=2).min(axis=0)
    assert gaps.max() < 1e-9  # every sphere of the project's kinematics has its MuJoCo geom
    np.testing.assert_allclose(data.qfrc_actuator[scene.hand_dof], scene.actuation @ data.ctrl, atol=1e-12)


def test_four_pads_around_a_ball_hold_it_against_the_task():
    result = held(TETRAHEDRON, effort_nm=2.0)
    assert result.passed and result.benchmark_passed, result.record()
    assert result.worst("task").translation_m < 1e-3


def test_pads_all_on_one_side_lose_the_ball():
    result = held(ONE_SIDE, effort_nm=2.0)
    assert not result.passed and not result.benchmark_passed


def test_the_same_grasp_without_strength_drops_the_ball_under_the_task_wrench():
    result = held(TETRAHEDRON, effort_nm=1e-3)
    assert not result.passed
    assert result.settle.within(SETTINGS.max_translation_m, SETTINGS.max_rotation_deg)  # it is the load that
    assert result.failed_test is not None and result.failed_test.startswith("task")  # drops it, not closing


def test_the_check_is_deterministic():
    first, second = held(TETRAHEDRON, 2.0).record(), held(TETRAHEDRON, 2.0).record()
    first.pop("physics_seconds"), second.pop("physics_seconds")
    np.testing.assert_equal(first, second)  # NaN (no failed test) equal to NaN


def test_the_projection_onto_the_capability_is_the_box_least_squares_solution():
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(3)
    actuation = rng.normal(size=(9, 14))
    wanted = rng.normal(size=9) * 3
    ours = BoxLeastSquares.of(actuation.T @ actuation, 3000).solve(actuation.T @ wanted, np.zeros(14))
    theirs = lsq_linear(actuation, wanted, bounds=(0, 1)).x
    assert np.linalg.norm(actuation @ ours - wanted) <= np.linalg.norm(actuation @ theirs - wanted) + 1e-6
    assert ours.min() >= 0 and ours.max() <= 1


def test_independent_motors_are_projected_exactly():
    """Motors that drive their own joints (one of them two, as a mimic pair does) get the box least-squares
    optimum in closed form; tendons that share joints are not taken for motors."""
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(5)
    push = np.zeros((7, 4))
    for motor, joints in enumerate(([0], [1, 2], [3, 4], [5, 6])):
        push[joints, motor] = rng.uniform(0.2, 2.0, size=len(joints))
    actuation = np.hstack([push, -push])
    projection = IndependentMotors.of(actuation)
    assert projection is not None
    for scale in (0.3, 3.0):  # inside the box, and beyond it
        wanted = rng.normal(size=7) * scale
        ours = projection.solve(actuation.T @ wanted, np.zeros(8))
        theirs = lsq_linear(actuation, wanted, bounds=(0, 1)).x
        residual = np.linalg.norm(actuation @ ours - wanted)
        assert residual == pytest.approx(np.linalg.norm(actuation @ theirs - wanted), abs=1e-9)
        assert ours.min() >= 0 and ours.max() <= 1
    shared = push.copy()
    shared[0, 1] = 0.5  # motor 1 reaches joint 0 as well: no longer separable
    assert IndependentMotors.of(np.hstack([shared, -shared])) is None
    assert IndependentMotors.of(rng.uniform(size=(7, 8))) is None


def test_a_sweep_with_no_verified_grasp_summarises_to_no_rates(tmp_path):
    """synthesize --physics on a sweep where the verifier accepted nothing: physics checked nothing, and the
    summary says so instead of failing on the columns no grasp wrote."""
    import pandas as pd

    from grasptask.io.artifacts import Provenance, StagedOutput
    from grasptask.stages.physics import TRACE_COLUMNS, write_physics_results

    table = pd.DataFrame({"start_id": [0, 1], "verified": [False, False], "Q": [float("nan")] * 2})
    with StagedOutput(tmp_path / "out", Provenance.of("test", {}, [])) as staged:
        result = write_physics_results(staged, table, "drawing", SETTINGS, pd.DataFrame(columns=TRACE_COLUMNS), None)
    assert result["solved"] == result["verified"] == 0 and result["physics_pass_rate_of_verified"] is None
    assert result["seconds_per_grasp_median"] is None and result["failed_wrenches_of_verified"] == {}
    assert (tmp_path / "out" / "physics_summary.json").is_file()


@pytest.fixture(scope="module")
def sweep(simulated, tmp_path_factory):
    from click.testing import CliRunner

    from grasptask.cli import main

    out = tmp_path_factory.mktemp("physics-sweep")
    tasks = simulated[0] / "tasks" / "task_models.json"
    result = CliRunner().invoke(
        main,
        ["synthesize", "--tasks", str(tasks), "--task", "drawing", "--out", str(out), "--starts", "3",
         "--executor", "serial", "--physics"],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    return tasks, out / "drawing"


def test_synthesize_with_physics_records_the_second_judge_on_verified_starts(sweep):
    solutions = pd.read_parquet(sweep[1] / "solutions.parquet")
    assert solutions["verified"].any()
    verified = solutions[solutions["verified"]]
    assert verified["physics_passed"].notna().all()
    assert (verified["physics_worst_translation_m"] >= 0).all()


def test_the_physics_command_judges_every_solved_grasp(cli, sweep, tmp_path):
    tasks, folder = sweep
    result = cli("physics", folder / "solutions.parquet", "--tasks", tasks, "--task", "drawing", "--out", tmp_path)
    assert result.exit_code == 0, result.output
    table = pd.read_parquet(tmp_path / "physics.parquet")
    solutions = pd.read_parquet(folder / "solutions.parquet")
    assert list(table["start_id"]) == list(solutions["start_id"])
    summary = json.loads((tmp_path / "physics_summary.json").read_text())
    assert sum(summary["agreement"].values()) == int(solutions["palm_x"].notna().sum())
    with_synthesis = solutions.set_index("start_id")["physics_passed"].dropna()
    alone = table.set_index("start_id")["physics_passed"].loc[with_synthesis.index]
    assert (with_synthesis.astype(bool) == alone.astype(bool)).all()  # the same check, the same verdict


def test_physics_refuses_a_table_from_another_hand(cli, sweep, tmp_path):
    tasks, folder = sweep
    result = cli(
        "physics", folder / "solutions.parquet", "--tasks", tasks, "--task", "drawing", "--out", tmp_path / "o",
        "--hand", "configs/hands/allegro.yaml",
    )  # fmt: skip
    assert result.exit_code == 2
    assert len(result.output.strip().splitlines()) == 1 and "solutions.parquet" in result.output
    assert not (tmp_path / "o").exists()


def test_physics_refuses_a_task_the_models_lack(cli, sweep, tmp_path):
    tasks, folder = sweep
    result = cli(
        "physics", folder / "solutions.parquet", "--tasks", tasks, "--task", "juggling", "--out", tmp_path / "o"
    )
    assert result.exit_code == 2
    assert "juggling" in result.output and len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_a_bad_physics_config_is_one_line(cli, sweep, tmp_path):
    tasks, folder = sweep
    config = tmp_path / "physics.yaml"
    config.write_text("timestep_s: -1\n")
    result = cli(
        "physics", folder / "solutions.parquet", "--tasks", tasks, "--task", "drawing", "--out", tmp_path / "o",
        "--physics-config", config,
    )  # fmt: skip
    assert result.exit_code == 2 and "timestep_s" in result.output
    assert not (tmp_path / "o").exists()


def test_the_settings_object_is_validated_once(tmp_path: Path):
    config = tmp_path / "p.yaml"
    config.write_text("control_period_s: 0.0001\n")
    from grasptask.errors import BadInputError

    with pytest.raises(BadInputError, match="control_period_s"):
        load_physics_settings(config)
    assert replace(PhysicsSettings(), squeeze_m=0.001).squeeze_m == 0.001


def test_a_non_convex_mesh_becomes_convex_parts_that_fill_it():
    import trimesh

    from grasptask.objects.mesh_object import MeshObject

    arm = trimesh.creation.box([0.08, 0.02, 0.02])
    leg = trimesh.creation.box([0.02, 0.08, 0.02])
    leg.apply_translation([0.03, 0.03, 0.0])
    shape = trimesh.boolean.union([arm, leg])
    body = object_body(MeshObject(shape, mass_kg=0.2), SETTINGS)
    assert len(body.parts) >= 2 and body.mass_kg == 0.2
    assert sum(p.volume for p in body.parts) == pytest.approx(shape.volume, rel=0.1)


def test_a_formula_objects_body_follows_its_normals_closely():
    """The paper's cylinder as MuJoCo sees it: facets on its side within 3 degrees of the true normals, so that a
    grasp turned about the axis (a symmetry of the object) meets the same surface."""
    tool = load_object("configs/objects/tool.yaml")
    hull = object_body(tool, SETTINGS).parts[0]
    centres = hull.triangles_center
    side = np.abs(centres[:, 2]) < 0.08
    cosines = (hull.face_normals[side] * tool.normal(centres[side])).sum(axis=1)
    assert np.degrees(np.arccos(np.clip(cosines, -1, 1))).max() < 3.0
