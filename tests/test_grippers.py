"""Parallel-jaw grippers: prismatic jaws and a mimic loaded as published, flat pads that resist a twist about
their normal (the soft-finger contact), and a two-contact grasp judged before the sweep."""

from __future__ import annotations

import numpy as np
import pytest
from grasp_fixtures import first_verified
from hand_files import JAW_BOX_M, JAW_EFFORT_N, JAW_STROKE_M, write_jaw_gripper

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand import forward, load_hand
from grasptask.objects import load_object
from grasptask.records.solutions import grasp_from_row
from grasptask.synthesis.resistance import least_torque, unresistable
from grasptask.task.ellipsoid import Ellipsoid
from grasptask.task.task_model import TaskModel
from grasptask.verifier.verify import verify

TOOL = "configs/objects/tool.yaml"
ALLEGRO = "configs/hands/allegro.xml"


def test_a_published_gripper_loads_with_sliding_jaws_one_motor_and_flat_pads_facing_each_other(tmp_path):
    """No YAML: the two finger links are the fingertips; each jaw slides over its stroke; the second mimics the
    first, so one motor of the file's effort (N) closes both; each pad is its box's inner face."""
    hand = load_hand(write_jaw_gripper(tmp_path))
    assert list(hand.fingers) == ["panda_leftfinger", "panda_rightfinger"] and hand.palm_link == "panda_hand"
    left, right = (f.joints[0] for f in hand.fingers.values())
    assert left.sliding and right.sliding and (left.lower, left.upper) == (0.0, JAW_STROKE_M)
    assert right.coupled_to == left.name and right.ratio == 1.0
    capability = hand.capability
    assert capability.actuators == ("panda_finger_joint1+", "panda_finger_joint1-")
    np.testing.assert_allclose(capability.transmission, [[1.0, 1.0]])
    np.testing.assert_allclose(np.abs(capability.torque_map).max(), JAW_EFFORT_N)
    pose = forward(hand, hand.mid_range())
    normals = pose.pad_normals()[0]
    np.testing.assert_allclose(normals, [[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]], atol=1e-12)  # each faces the other
    pads = pose.contacts()[0]
    np.testing.assert_allclose(pads[:, 1], [JAW_STROKE_M / 2, -JAW_STROKE_M / 2], atol=1e-12)  # on the inner faces
    for finger in hand.fingers.values():
        assert finger.pad.flat
        np.testing.assert_allclose(sorted(finger.pad.half_extents), sorted(np.array(JAW_BOX_M)[[0, 2]] / 2))


def test_mesh_jaws_get_flat_pads_facing_each_other_too(tmp_path):
    """The same jaws as STL meshes with rounded edges: the flat part of each inner face is its pad."""
    hand = load_hand(write_jaw_gripper(tmp_path, pads="mesh"))
    normals = forward(hand, hand.mid_range()).pad_normals()[0]
    np.testing.assert_allclose(normals, [[0.0, -1.0, 0.0], [0.0, 1.0, 0.0]], atol=1e-6)
    assert all(f.pad.flat and f.tip_mesh is not None for f in hand.fingers.values())


def test_the_hand_command_shows_the_jaws_in_millimetres(cli, tmp_path):
    result = cli("hand", write_jaw_gripper(tmp_path))
    assert result.exit_code == 0, result.output
    assert "panda_finger_joint1 [0, 40] mm, sliding" in result.output and "a flat face 50.0 x 20.0 mm" in result.output


@pytest.fixture(scope="module")
def jaw_grasp(tmp_path_factory, simulated):
    """A verified screw-driving grasp of the tool by the published gripper, and what made it."""
    path = write_jaw_gripper(tmp_path_factory.mktemp("jaws"))
    tasks = str(simulated[0] / "tasks" / "task_models.json")
    row, context = first_verified(str(path), TOOL, tasks, "screwdriving")
    hand = load_hand(path).grasping_hand()
    return hand, grasp_from_row(row, hand.joint_names), context.job.task, context


def test_the_gripper_grasps_the_tool_with_each_contact_on_its_pads_inner_face(jaw_grasp):
    hand, grasp, task, _ = jaw_grasp
    verdict = verify(grasp, hand, load_object(TOOL), task, GraspSettings())
    assert verdict.ok, verdict.failures
    pose = forward(hand, grasp.joint_angles, grasp.palm_rotation, grasp.palm_position)
    for j, (name, finger) in enumerate(hand.fingers.items()):
        placed = pose.fingers[name]
        rotation, origin = placed.link_rotations[0, -1], placed.joint_positions[0, 0]
        offset = rotation.T @ (verdict.contacts[j] - origin) - finger.pad.point
        assert abs(offset @ finger.pad.normal) <= 0.5e-3  # on the face's plane, within the face
        assert abs(offset @ finger.pad.tangent) <= finger.pad.half_extents[0]
        assert abs(offset @ finger.pad.across) <= finger.pad.half_extents[1]
        assert -(rotation @ finger.pad.normal) @ verdict.normals[j] >= np.cos(np.radians(1.0))


def _twist(axis: np.ndarray, size: float) -> TaskModel:
    """A task that is a twist of ``size`` (N.m) about ``axis`` and next to nothing else."""
    wrench = np.concatenate([np.zeros(3), axis])
    shape = size**2 * np.outer(wrench, wrench) + 1e-10 * np.eye(6)
    return TaskModel("twist", 1, Ellipsoid.from_matrix(shape))


def test_a_two_pad_grasp_resists_a_twist_about_the_pads_normal_up_to_its_limit_and_not_beyond(jaw_grasp):
    """Only the pads' torsional friction resists a twist about the line between them: at most the margin's
    mu_t times the normal forces, whose sum the one motor limits to its capped effort. The verifier's LP holds
    0.8 of that and not 1.2, and with no torsional friction holds none."""
    hand, grasp, _, _ = jaw_grasp
    settings, tool = GraspSettings(), load_object(TOOL)
    normal = verify(grasp, hand, tool, _twist(np.array([0.0, 0.0, 1.0]), 1e-3), settings).normals[0]
    limit = settings.friction_scale * settings.torsional_friction_m * settings.motor_activation_max * JAW_EFFORT_N
    for share, held in ((0.8, True), (1.2, False)):
        verdict = verify(grasp, hand, tool, _twist(normal, share * limit), settings)
        assert ("torque_feasibility" not in verdict.failures) is held, (share, verdict.torque_effort)
    np.testing.assert_allclose(verify(grasp, hand, tool, _twist(normal, 0.5 * limit), settings).torque_effort,
                               0.5 * settings.motor_activation_max, rtol=0.03)  # fmt: skip
    point = GraspSettings(torsional_friction_m=0.0)
    assert "torque_feasibility" in verify(grasp, hand, tool, _twist(normal, 0.1 * limit), point).failures


def test_two_point_contacts_are_refused_before_the_sweep_with_the_axis_and_run_with_anyway(cli, simulated, tmp_path):
    """The Allegro's index and thumb are two spheres: a task with torque about every axis is refused before
    anything is solved or written, naming the least torque axis; --anyway solves it, and a sweep that verifies
    nothing exits 3 with its why."""
    tasks = simulated[0] / "tasks" / "task_models.json"
    args = ["synthesize", "--tasks", tasks, "--task", "drawing", "--hand", ALLEGRO, "--fingers", "ff_tip,th_tip",
            "--starts", "1", "--executor", "serial", "--solver-config", "tests/data/solver_tiny.yaml"]  # fmt: skip
    refused = cli(*args, "--out", tmp_path / "refused")
    assert refused.exit_code == 2 and not (tmp_path / "refused").exists()
    assert "two point contacts (ff_tip and th_tip) cannot resist a torque about the line joining them" in (
        refused.output
    )
    assert "in the task frame, its least; no start can hold it: solve anyway with --anyway" in refused.output
    anyway = cli(*args, "--out", tmp_path / "anyway", "--anyway")
    assert anyway.exit_code == 3, anyway.output
    assert "solving anyway (--anyway)" in anyway.output and "drawing: no grasp verified (exit code 3)" in (
        anyway.output
    )
    assert (tmp_path / "anyway" / "drawing" / "solutions.parquet").is_file()


def test_the_refusal_names_the_tasks_least_torque_axis_and_spares_soft_pads_and_three_fingers(tmp_path):
    hand = load_hand(ALLEGRO)
    task = TaskModel("t", 1, Ellipsoid.from_matrix(np.diag([1.0, 1.0, 1.0, 4e-4, 9e-4, 1e-4])))
    extent, axis = least_torque(task)
    np.testing.assert_allclose([extent, abs(axis[2])], [1e-2, 1.0], rtol=1e-9)
    pair = hand.with_grasping(["ff_tip", "th_tip"]).grasping_hand()
    said = unresistable(pair, task, GraspSettings())
    assert said is not None and "at least 0.01 N.m about (0.00, 0.00, 1.00)" in said
    three = hand.with_grasping(["ff_tip", "mf_tip", "th_tip"]).grasping_hand()
    assert unresistable(three, task, GraspSettings()) is None
    jaws = load_hand(write_jaw_gripper(tmp_path)).grasping_hand()
    assert unresistable(jaws, task, GraspSettings()) is None  # flat pads twist
    assert unresistable(jaws, task, GraspSettings(torsional_friction_m=0.0)) is not None
    flat = TaskModel("t", 1, Ellipsoid.from_matrix(np.diag([1.0, 1.0, 1.0, 4e-4, 9e-4, 0.0])))
    assert unresistable(pair, flat, GraspSettings()) is None  # no torque about z: the line can lie along it


def test_the_physics_check_holds_a_twist_about_the_pads_normal_within_the_verifiers_limit_and_not_twice_it(
    jaw_grasp,
):
    """MuJoCo's pads (condim 4, the grasp config's torsional friction) under the grip controller, which plans
    each flat pad's twist within it: half the twist the verifier's LP holds at its margin is held, and twice it is
    dropped with the jaws' one motor at its limit. At the limit itself MuJoCo's soft torsional friction lets the
    tool creep about 5 degrees, the pass threshold: held on one grasp, dropped on another (a finding, not tuned)."""
    from grasptask.physics.judge import Holding
    from grasptask.physics.physics_settings import PhysicsSettings

    hand, grasp, _, _ = jaw_grasp
    settings, tool = GraspSettings(), load_object(TOOL)
    normal = verify(grasp, hand, tool, _twist(np.array([0.0, 0.0, 1.0]), 1e-3), settings).normals[0]
    limit = settings.friction_scale * settings.torsional_friction_m * settings.motor_activation_max * JAW_EFFORT_N
    torsion = settings.torsional_friction_m
    holding = Holding.of(tool, settings.friction_coefficient, PhysicsSettings(), pad_torsion=torsion)
    held = holding.hold(hand, grasp, _twist(normal, 0.5 * limit)).record()
    assert held["physics_passed"], held["physics_why"]
    dropped = holding.hold(hand, grasp, _twist(normal, 2 * limit)).record()
    assert not dropped["physics_passed"] and dropped["physics_failed_wrench"].startswith("task")
    assert dropped["physics_failed_peak_activation"] >= 0.99, dropped["physics_why"]  # the motor at its limit


def test_the_force_problem_holds_a_twist_about_the_pads_normal_up_to_its_limit_and_not_beyond(jaw_grasp):
    """The search's force problem at the same grasp: eq. 10's QP applies 0.8 of the verifier's limit with no
    residual and leaves one at 1.2; eq. 8's task forces balance a twist only with the pads' twists."""
    from grasptask.synthesis.force_problem import ForceProblem

    hand, grasp, _, context = jaw_grasp
    settings, solver = GraspSettings(), context.job.solver
    context.nlp.initialise(grasp.palm_rotation, grasp.palm_position, grasp.joint_angles)
    geometry = context.nlp.geometry()
    assert list(geometry.soft) == [0, 1]
    normal = geometry.normals[0]
    limit = settings.friction_scale * settings.torsional_friction_m * settings.motor_activation_max * JAW_EFFORT_N
    joints = tuple(f.n_joints for f in hand.fingers.values())
    for share, closes in ((0.8, True), (1.2, False)):
        task = _twist(normal, share * limit)
        rho, bounds, weights = solver.force_slack_weight, solver.search_bounds, solver.regularisation
        problem = ForceProblem(hand.capability, joints, task, settings, rho, bounds, weights, soft=2)
        solution = problem.solve(geometry)
        assert solution.closes is closes, (share, np.abs(solution.wrench_residuals).max())
        assert np.abs(solution.slacks).max() <= 1e-5  # the task forces balance it with the twists
