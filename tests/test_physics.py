"""The physics check: MuJoCo scenes built from the project's own hands and from hand files, the grip
controller's QP and the exact actuator mapping, and the protocol's verdicts on grasps whose outcome is known."""

from __future__ import annotations

import json
import resource
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pandas as pd
import pytest
from grasp_fixtures import ONE_SIDE, TETRAHEDRON, drawing_like_task, gripper_grasp
from hand_files import GRIPPER_BALL_RADIUS_M, ball_centre, write_mesh_gripper
from hypothesis import given, settings
from hypothesis import strategies as st

from grasptask.grasp.grasp_pose import Grasp
from grasptask.hand import forward, load_hand
from grasptask.objects import Superquadric, load_object
from grasptask.physics.actuation import ActuatorMap, BoundedLeastSquares, IndependentMotors
from grasptask.physics.grip import GripController
from grasptask.physics.loads import task_tests
from grasptask.physics.physics_settings import PhysicsSettings, load_physics_settings
from grasptask.physics.protocol import _Run, check_grasp
from grasptask.physics.scene import build_scene, object_body
from grasptask.physics.sensing import hand_contacts, point_jacobian
from grasptask.records.solutions import grasp_columns

SETTINGS = load_physics_settings()
SPRING = replace(SETTINGS, controller="spring")
HANDS = ["configs/hands/human.yaml", "configs/hands/barrett_bh8_282.urdf", "configs/hands/allegro.yaml"]


def held(directions, effort_nm: float, task=None, settings=SETTINGS, friction: float = 0.5):
    hand, grasp, ball = gripper_grasp(directions, effort_nm)
    body = object_body(ball, settings)
    scene = build_scene(hand, ball, body, grasp, friction, settings)
    return check_grasp(scene, task or drawing_like_task(1.0), body.mass_kg, settings)


def test_the_shipped_config_is_the_documented_defaults():
    assert load_physics_settings() == PhysicsSettings()


def _random_grasp(hand, seed: int = 1) -> Grasp:
    rng = np.random.default_rng(seed)
    q = hand.apply_coupling(rng.uniform(hand.lower, hand.upper))
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    rotation *= np.sign(np.linalg.det(rotation))
    return Grasp(rotation, np.array([0.05, -0.02, 0.1]), q)


@pytest.mark.parametrize("path", HANDS)
def test_the_scene_puts_every_joint_where_the_hands_kinematics_does(path):
    """MuJoCo's forward kinematics of the built scene (the project's model for the human hand, the hand's own
    file for the robots) against the project's, at a random posture and palm pose; and the actuators give
    exactly the joint torques of the hand's force capability."""
    hand = load_hand(path).grasping_hand()
    grasp = _random_grasp(hand)
    ball = load_object("configs/objects/sphere.yaml")
    scene = build_scene(hand, ball, object_body(ball, SETTINGS), grasp, 0.5, SETTINGS)
    from_file = hand.model_file is not None
    assert from_file == (path != HANDS[0])
    data = mujoco.MjData(scene.model)
    data.qpos[scene.hand_qpos] = grasp.joint_angles
    data.ctrl[:] = np.random.default_rng(2).uniform(0, 1, scene.model.nu)
    mujoco.mj_forward(scene.model, data)
    pose = forward(hand, grasp.joint_angles, grasp.palm_rotation, grasp.palm_position)
    ours = np.concatenate([placed.joint_positions[0, :-1] for placed in pose.fingers.values()])
    np.testing.assert_allclose(data.xanchor[scene.model.dof_jntid[scene.hand_dof]], ours, atol=1e-9)
    np.testing.assert_allclose(data.qfrc_actuator[scene.hand_dof], scene.actuation @ data.ctrl, atol=1e-12)
    if not from_file:  # every collision sphere of the project's model has its geom, a fingertip's less its pulp
        centres, radii = forward(hand, grasp.joint_angles, grasp.palm_rotation, grasp.palm_position).collision_spheres()
        spheres = [g for g in range(scene.model.ngeom) if scene.model.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE]
        gaps = np.linalg.norm(data.geom_xpos[spheres][:, None, :] - centres[0][None], axis=2)
        assert gaps.min(axis=0).max() < 1e-9
        tips = np.concatenate(
            [[s.link == f.n_joints - 1 for s in f.spheres] for f in hand.fingers.values()]
            + [[False] * len(hand.palm.radii)]
        )
        sizes = scene.model.geom_size[np.array(spheres)[gaps.argmin(axis=0)], 0]
        np.testing.assert_allclose(sizes, radii - np.where(tips, hand.compliance_m, 0.0), atol=1e-12)


def test_the_allegro_scene_holds_the_mjcf_files_own_collision_geoms():
    hand = load_hand("configs/hands/allegro.yaml")
    own = mujoco.MjModel.from_xml_path("configs/hands/allegro.xml")
    colliding = int(((own.geom_contype | own.geom_conaffinity) != 0).sum())
    ball = load_object("configs/objects/sphere.yaml")
    scene = build_scene(hand.grasping_hand(), ball, object_body(ball, SETTINGS), _random_grasp(hand), 0.5, SETTINGS)
    assert hand.grasping == ("thumb", "index", "middle", "ring")  # every finger grasps: nothing is left out
    assert int(scene.hand_geoms.sum()) == colliding == own.ngeom == 21
    kinds = {int(t) for t in scene.model.geom_type[scene.hand_geoms]}
    assert kinds == {int(mujoco.mjtGeom.mjGEOM_BOX), int(mujoco.mjtGeom.mjGEOM_CAPSULE)}  # its boxes and capsules


def _gripper_scene(folder: Path, effort_nm: float = 2.0, settings=SETTINGS):
    hand = load_hand(write_mesh_gripper(folder, effort_nm)).grasping_hand()
    ball = Superquadric(np.full(3, GRIPPER_BALL_RADIUS_M), 1.0, 1.0, name="ball")
    grasp = Grasp(np.eye(3), -ball_centre(), np.zeros(hand.n_joints))
    body = object_body(ball, settings)
    return hand, build_scene(hand, ball, body, grasp, 0.5, settings), body


def test_a_urdf_hand_with_mesh_links_is_simulated_from_its_own_file(tmp_path):
    """A published-style URDF (STL links through package:// paths, joints named "0".."5") compiles through
    MuJoCo's URDF support with its mesh geoms, and holds a ball its three tips touch."""
    hand, scene, body = _gripper_scene(tmp_path)
    assert hand.joint_names == [str(k) for k in range(6)]
    meshes = scene.hand_geoms & (scene.model.geom_type == mujoco.mjtGeom.mjGEOM_MESH)
    assert int(meshes.sum()) == 7 and int(scene.hand_geoms.sum()) == 10  # palm and six links; three tips
    result = check_grasp(scene, drawing_like_task(0.2), body.mass_kg, SETTINGS)
    assert result.passed, result.record()
    assert result.initial_penetration_m < 1e-4


UNBALANCED = (
    '<inertial><mass value="0.1"/><inertia ixx="1e-6" iyy="1e-6" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial>'
)


def test_an_inertia_mujoco_refuses_and_the_files_own_mujoco_element_pass_the_physics_check(tmp_path):
    """A link's inertia that breaks A + B >= C (MuJoCo refuses it as it is) is balanced and said; the URDF's
    own <mujoco> element is merged with the scene's, not doubled ("repeated element")."""
    path = write_mesh_gripper(tmp_path, inertia=UNBALANCED)
    text = path.read_text()
    path.write_text(text.replace("</robot>", '<mujoco><compiler balanceinertia="false"/></mujoco>\n</robot>'))
    from grasptask.report.hand_view import hand_lines

    assert any(
        "balanced by the physics check" in line and "finger0_link0" in line for line in hand_lines(load_hand(path))
    )
    hand = load_hand(path).grasping_hand()
    ball = Superquadric(np.full(3, GRIPPER_BALL_RADIUS_M), 1.0, 1.0, name="ball")
    grasp = Grasp(np.eye(3), -ball_centre(), np.zeros(hand.n_joints))
    body = object_body(ball, SETTINGS)
    result = check_grasp(
        build_scene(hand, ball, body, grasp, 0.5, SETTINGS), drawing_like_task(0.2), body.mass_kg, SETTINGS
    )
    assert result.passed, result.record()


def test_a_hand_file_mujoco_cannot_compile_is_one_line(cli, sweep, tmp_path):
    """A URDF the hand loader reads but MuJoCo refuses (its own <mujoco> element asks for angles in a unit
    MuJoCo does not know): one line naming the file and MuJoCo's message, exit 2, nothing written."""
    path = write_mesh_gripper(tmp_path)
    path.write_text(path.read_text().replace("</robot>", '<mujoco><compiler angle="sideways"/></mujoco></robot>'))
    hand = load_hand(path).grasping_hand()
    grasp = Grasp(np.eye(3), -ball_centre(), np.zeros(hand.n_joints))
    row = {"start_id": 0, "verified": True, "Q": 0.1}
    row.update(grasp_columns(grasp, hand.joint_names, list(hand.fingers), np.zeros((3, 3)), np.eye(3)))
    pd.DataFrame([row]).to_parquet(tmp_path / "solutions.parquet")
    ball = tmp_path / "ball.yaml"
    size = ", ".join([str(GRIPPER_BALL_RADIUS_M)] * 3)
    ball.write_text(f"type: superquadric\nsize_m: [{size}]\nexponents: [1.0, 1.0]\n")
    tasks, _ = sweep
    result = cli(
        "physics", tmp_path / "solutions.parquet", "--tasks", tasks, "--task", "drawing", "--out", tmp_path / "o",
        "--hand", path, "--object", ball,
    )  # fmt: skip
    assert result.exit_code == 2, result.output
    assert len(result.output.strip().splitlines()) == 1
    assert "gripper.urdf" in result.output and "MuJoCo" in result.output
    assert not (tmp_path / "o").exists()


def test_four_pads_around_a_ball_hold_it_with_every_force_inside_its_cone():
    result = held(TETRAHEDRON, effort_nm=2.0)
    assert result.passed and result.benchmark_passed, result.record()
    assert result.worst("task").translation_m < 1e-3
    assert result.record()["physics_friction_use"] < 1.0  # no fingertip slides under any task wrench
    hand, grasp, ball = gripper_grasp(TETRAHEDRON, 2.0)
    scene = build_scene(hand, ball, object_body(ball, SETTINGS), grasp, 0.5, SETTINGS)
    run = _Run(scene, SETTINGS)
    run.simulate(SETTINGS.settle_s)
    controller = GripController.of(scene, SETTINGS)
    contacts = hand_contacts(scene, run.data)
    assert len(contacts) >= 4
    jacobians = np.array(
        [point_jacobian(scene, run.data, p, int(b)) for p, b in zip(contacts.points, contacts.bodies, strict=True)]
    )
    test = task_tests(drawing_like_task(1.0))[0]
    forces = controller.contact_forces(run.data, contacts, jacobians, test, 1.0)
    tangential, normal = np.linalg.norm(forces[:, 1:], axis=1), forces[:, 0]
    assert (normal >= -1e-9).all()
    assert (tangential <= SETTINGS.grip_friction_fraction * scene.friction * normal + 1e-7).all()


@pytest.mark.parametrize("settings", [SETTINGS, SPRING], ids=["grip", "spring"])
def test_pads_all_on_one_side_lose_the_ball(settings):
    result = held(ONE_SIDE, effort_nm=2.0, settings=settings)
    assert not result.passed and not result.benchmark_passed


def test_the_same_grasp_without_strength_drops_the_ball_under_the_task_wrench():
    result = held(TETRAHEDRON, effort_nm=1e-3)
    assert not result.passed
    assert result.failed_test is not None
    assert result.record()["physics_saturated"]


def test_a_dropped_grasp_says_which_pad_slipped_and_with_what():
    """The ball held by four pads at a hundredth of the friction: a pad slipped at its cone's edge, and the
    friction and strength are said; without strength, the pads still pressing meet the ball along its own
    normal; pads all on one side press on nothing once the ball has gone."""
    record = held(TETRAHEDRON, effort_nm=2.0, friction=0.005).record()
    assert not record["physics_passed"]
    assert record["physics_slip_finger"] in {f"f{k}" for k in range(4)}
    assert record["physics_slip_friction_use"] >= 0.95
    assert record["physics_friction"] == 0.005 and record["physics_strength"] == 1.0
    why = record["physics_why"]
    assert why.startswith(record["physics_failed_wrench"] + ": ") and f"{record['physics_slip_finger']} slipped" in why
    weak = held(TETRAHEDRON, effort_nm=1e-3).record()
    assert "peak activation at its limit" in weak["physics_why"]
    assert weak["physics_slip_normal_off_deg"] < 10.0
    gone = held(ONE_SIDE, effort_nm=2.0).record()
    assert gone["physics_lost_contact"] == "f0;f1;f2;f3" and "f0, f1, f2, f3 pressed on nothing" in gone["physics_why"]
    firm = held(TETRAHEDRON, effort_nm=2.0).record()
    assert firm["physics_passed"] and firm["physics_why"] == "" and firm["physics_slip_finger"] == ""


def test_the_check_is_deterministic():
    first, second = held(TETRAHEDRON, 2.0).record(), held(TETRAHEDRON, 2.0).record()
    first.pop("physics_seconds"), second.pop("physics_seconds")
    np.testing.assert_equal(first, second)  # NaN (no failed test) equal to NaN


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), scale=st.sampled_from([0.3, 1.0, 3.0, 10.0]))
def test_the_tendon_mapping_is_the_bounded_least_squares_optimum(seed, scale):
    """More tendons than joints, torques inside their reach and far beyond it (saturated): the same residual
    as SciPy's BVLS, and activations within [0, 1]."""
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(seed)
    actuation = rng.normal(size=(9, 14))
    wanted = rng.normal(size=9) * scale
    mapping = ActuatorMap.of(actuation)
    assert isinstance(mapping.method, BoundedLeastSquares)
    ours = mapping(wanted)
    theirs = lsq_linear(actuation, wanted, bounds=(0, 1), method="bvls", tol=1e-12).x
    residual = np.linalg.norm(actuation @ ours.activations - wanted)
    assert residual == pytest.approx(np.linalg.norm(actuation @ theirs - wanted), abs=1e-7)
    assert ours.activations.min() >= 0 and ours.activations.max() <= 1
    assert ours.saturated == (residual > 1e-3 * np.linalg.norm(wanted) + 1e-6 and ours.activations.max() >= 1 - 1e-9)


def test_the_human_hands_tendons_saturate_only_beyond_their_reach():
    hand = load_hand().grasping_hand()
    actuation = hand.capability.transmission.T @ hand.capability.torque_map
    mapping = ActuatorMap.of(actuation)
    reachable = actuation @ np.full(actuation.shape[1], 0.5)
    assert not mapping(reachable).saturated
    assert mapping(20 * reachable).saturated


def test_independent_motors_are_mapped_exactly():
    """Motors that drive their own joints (one of them two, as a mimic pair does) get the box least-squares
    optimum in closed form; tendons that share joints are not taken for motors."""
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(5)
    push = np.zeros((7, 4))
    for motor, joints in enumerate(([0], [1, 2], [3, 4], [5, 6])):
        push[joints, motor] = rng.uniform(0.2, 2.0, size=len(joints))
    actuation = np.hstack([push, -push])
    assert isinstance(ActuatorMap.of(actuation).method, IndependentMotors)
    for scale in (0.3, 3.0):  # inside the box, and beyond it
        wanted = rng.normal(size=7) * scale
        ours = ActuatorMap.of(actuation)(wanted).activations
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
    from grasptask.physics.judge import write_physics_results

    table = pd.DataFrame({"start_id": [0, 1], "verified": [False, False], "Q": [float("nan")] * 2})
    with StagedOutput(tmp_path / "out", Provenance.of("test", {}, [])) as staged:
        result = write_physics_results(staged, table, "drawing", SETTINGS, [], None)
    assert result["solved"] == result["verified"] == 0 and result["physics_pass_rate_of_verified"] is None
    assert result["seconds_per_grasp_median"] is None and result["failed_wrenches_of_verified"] == {}
    assert (tmp_path / "out" / "physics_summary.json").is_file()
    assert result["traced"] == [] and result["films_unavailable"] is None
    assert pd.read_parquet(tmp_path / "out" / "physics_trace.parquet").empty


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


def test_a_grasp_physics_drops_carries_its_why_in_physics_parquet(cli, sweep, tmp_path):
    tasks, folder = sweep
    result = cli(
        "physics", folder / "solutions.parquet", "--tasks", tasks, "--task", "drawing", "--out", tmp_path,
        "--friction-scale", "0.01",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    table = pd.read_parquet(tmp_path / "physics.parquet")
    dropped = table[table["physics_passed"].notna() & ~table["physics_passed"].astype(bool)]
    assert len(dropped), "at a hundredth of the friction every grasp should slip"
    for _, row in dropped.iterrows():
        assert row["physics_why"].startswith(row["physics_failed_wrench"] + ": ")
        assert row["physics_slip_finger"] in row["physics_why"] or row["physics_lost_contact"]
        assert row["physics_friction"] < 0.1


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


def test_fingers_the_grasp_leaves_out_are_left_out_of_the_files_scene(tmp_path):
    """As the NLP leaves them out: the gripper's middle finger, and the BarrettHand's second finger with the
    spread coupling that tied it to the first."""
    path = write_mesh_gripper(tmp_path)
    subset = path.parent / "two.yaml"
    subset.write_text("model: gripper.urdf\ngrasping_fingers: [finger0_tip, finger2_tip]\n")
    hand = load_hand(subset).grasping_hand()
    ball = Superquadric(np.full(3, GRIPPER_BALL_RADIUS_M), 1.0, 1.0, name="ball")
    body = object_body(ball, SETTINGS)
    scene = build_scene(hand, ball, body, Grasp(np.eye(3), -ball_centre(), np.zeros(4)), 0.5, SETTINGS)
    assert scene.model.njnt == 5 and int(scene.hand_geoms.sum()) == 7  # four joints and the object's; palm + 2 x 3
    barrett = load_hand("configs/hands/barrett_bh8_282.urdf").with_grasping(["tip_3", "tip_1"]).grasping_hand()
    scene = build_scene(barrett, ball, body, _random_grasp(barrett), 0.5, SETTINGS)
    names = {scene.model.joint(j).name for j in range(scene.model.njnt)}
    assert "j21" not in names and "j22" not in names and {"j32", "j33", "j11", "j12", "j13"} <= names
    assert scene.model.neq == 2  # the two remaining fingers' distal couplings


def test_fingertips_sunk_by_the_compliance_are_seated_at_rest_before_the_hold(tmp_path):
    """The gripper's tips 0.5 mm into a ball (a fingertip's compliance, as synthesis leaves it): the scene starts
    from the least joint motion that lifts them out, so that MuJoCo's rigid geoms do not resolve the overlap as an
    impulse; the row records the synthesized depth and the motion, and the grasp holds."""
    from grasptask.physics.protocol import hold_grasp
    from grasptask.physics.seating import SEATED_DEPTH_M, seat

    hand = load_hand(write_mesh_gripper(tmp_path, 2.0)).grasping_hand()
    ball = Superquadric(np.full(3, GRIPPER_BALL_RADIUS_M + 5e-4), 1.0, 1.0, name="ball")
    grasp = Grasp(np.eye(3), -ball_centre(), np.zeros(hand.n_joints))
    body = object_body(ball, SETTINGS)
    scene = build_scene(hand, ball, body, grasp, 0.5, SETTINGS)
    seating = seat(scene, hand, scene.posture)
    assert seating.joints is not None and seating.synthesized_depth_m == pytest.approx(5e-4, abs=1e-4)
    data = mujoco.MjData(scene.model)
    data.qpos[scene.hand_qpos] = seating.joints
    mujoco.mj_forward(scene.model, data)
    assert hand_contacts(scene, data).depths.max(initial=0.0) <= SEATED_DEPTH_M
    assert 0 < seating.moved_deg < 3
    record = hold_grasp(hand, ball, body, grasp, 0.5, drawing_like_task(0.2), SETTINGS).record()
    assert record["physics_passed"] and record["physics_seat_deg"] == pytest.approx(seating.moved_deg)
    assert record["physics_initial_penetration_mm"] == pytest.approx(0.5, abs=0.1)


def test_fingers_that_touch_nothing_close_onto_the_object(tmp_path):
    """Two of the gripper's tips 1 mm off a ball, at 120 degrees: no push along their normals balances, and a
    closing planned as a balance of frictionless contacts commanded almost nothing (the tips moved 0.3 degrees
    in the settle, and never touched). With no finger touching there is nothing to balance: each closes with the
    squeeze, as under a test. The YCB wood block lost 9 of 27 verified grasps so: seated, the object drifted off
    at the first step, and the fingers stayed where they were."""
    from grasptask.physics.protocol import _Run

    path = write_mesh_gripper(tmp_path, 2.0)
    (path.parent / "two.yaml").write_text("model: gripper.urdf\ngrasping_fingers: [finger0_tip, finger2_tip]\n")
    hand = load_hand(path.parent / "two.yaml").grasping_hand()
    ball = Superquadric(np.full(3, GRIPPER_BALL_RADIUS_M - 1e-3), 1.0, 1.0, name="ball")
    scene = build_scene(
        hand, ball, object_body(ball, SETTINGS), Grasp(np.eye(3), -ball_centre(), np.zeros(4)), 0.5, SETTINGS
    )
    run = _Run(scene, SETTINGS)
    mujoco.mj_forward(scene.model, run.data)
    assert len(hand_contacts(scene, run.data)) == 0
    touched: set[int] = set()
    for _ in range(30):
        run.simulate(0.01)
        touched |= set(scene.finger_of_body[hand_contacts(scene, run.data).bodies].tolist())
    assert touched == {0, 1}


def test_a_finger_at_its_joint_limits_is_seated_within_them_and_its_coupling():
    """The human middle finger at its limits (MCP fully extended, PIP fully flexed, its DIP following at 2/3)
    pressed 0.3 mm onto a ball: seating backs it out by the joints that can still move, within their limits
    and the coupling. A step blind to both was clipped and overwritten until the tip sank no less deep, and
    the grasp was held unseated."""
    from grasptask.physics.seating import SEATED_DEPTH_M, seat

    hand = load_hand("configs/hands/human.yaml").grasping_hand()
    ball = Superquadric(np.full(3, 0.03), 1.0, 1.0, name="ball")
    body = object_body(ball, SETTINGS)
    q = hand.apply_coupling(np.radians([60, 50, -15, -10, 18, 15, 90, 13, 8, 11, -10, 110, 0]))
    pose = forward(hand, q)
    centre, normal = pose.pad_centres()[0, 2], pose.pad_normals()[0, 2]

    def scene_at(offset: float):
        scene = build_scene(hand, ball, body, Grasp(np.eye(3), -(centre - offset * normal), q), 0.5, SETTINGS)
        data = mujoco.MjData(scene.model)
        data.qpos[scene.hand_qpos] = scene.posture
        mujoco.mj_forward(scene.model, data)
        return scene, data, hand_contacts(scene, data).depths.max(initial=0.0)

    near, far = 0.0, 0.05  # the ball's centre this far beyond the pad: 0.3 mm deep between them
    for _ in range(14):
        middle = (near + far) / 2
        near, far = (middle, far) if scene_at(middle)[2] > 3e-4 else (near, middle)
    scene, data, depth = scene_at(near)
    assert depth == pytest.approx(3e-4, abs=2e-5)
    seating = seat(scene, hand, scene.posture)
    assert seating.joints is not None
    data.qpos[scene.hand_qpos] = seating.joints
    mujoco.mj_forward(scene.model, data)
    assert hand_contacts(scene, data).depths.max(initial=0.0) <= SEATED_DEPTH_M
    seated = scene.to_hand(seating.joints)
    assert np.all(seated >= hand.lower - 1e-9) and np.all(seated <= hand.upper + 1e-9)
    np.testing.assert_allclose(seated, hand.apply_coupling(seated), atol=1e-9)


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda t: t.assign(verified=t["verified"].map({True: "True", False: "False"})), "column 'verified'"),
        (lambda t: t.iloc[0:0], "holds no starts"),
        (lambda t: pd.concat([t, t.iloc[[0]]], ignore_index=True), "column 'start_id'"),
    ],
    ids=["verdicts-as-text", "no-rows", "a-start-twice"],
)
def test_a_solutions_table_physics_would_misread_is_one_line(cli, sweep, tmp_path, change, message):
    """ "False" as text counted as verified; no rows were a KeyError; a start twice gave two rows."""
    tasks, folder = sweep
    bad = tmp_path / "sweep" / "solutions.parquet"
    bad.parent.mkdir()
    change(pd.read_parquet(folder / "solutions.parquet")).to_parquet(bad)
    (bad.parent / "run.json").write_text((folder / "run.json").read_text())
    result = cli("physics", bad, "--tasks", tasks, "--task", "drawing", "--out", tmp_path / "o")
    assert result.exit_code == 2 and message in result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()


def test_a_second_physics_run_into_one_folder_is_refused_at_its_start(sweep, tmp_path):
    """The lock is taken before the grasps are held, as synthesize does: the second run does no work and
    exits 2, where both used to exit 0 and the last writer won."""
    import subprocess
    import sys

    from processes import held_lock

    tasks, folder = sweep
    out = tmp_path / "out"
    with held_lock(out, "physics drawing"):
        began = resource.getrusage(resource.RUSAGE_CHILDREN)
        result = subprocess.run(
            [sys.executable, "-m", "grasptask.cli", "physics", str(folder / "solutions.parquet"), "--tasks",
             str(tasks), "--task", "drawing", "--out", str(out)],
            capture_output=True, text=True, timeout=600,
        )  # fmt: skip
    ended = resource.getrusage(resource.RUSAGE_CHILDREN)
    assert result.returncode == 2 and "physics drawing" in result.stderr
    assert "physics drawing:" not in result.stderr  # no progress: refused before any grasp was held
    # its own CPU time, not the wall clock's: refused at start-up, however busy the machine
    assert ended.ru_utime + ended.ru_stime - began.ru_utime - began.ru_stime < 60 and not out.exists()


def test_physics_takes_the_task_from_the_sweep_and_refuses_another(cli, sweep, tmp_path):
    """A drawing sweep judged with --task cutting exited 0 with '0% held'; --tasks was required where export
    took it from run.json."""
    tasks, folder = sweep
    result = cli("physics", folder / "solutions.parquet", "--task", "cutting", "--out", tmp_path / "o")
    assert result.exit_code == 2 and "the sweep is of task 'drawing', not 'cutting'" in result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "o").exists()
    result = cli("physics", folder / "solutions.parquet", "--out", tmp_path / "o")
    assert result.exit_code == 0, result.output
    assert json.loads((tmp_path / "o" / "physics_summary.json").read_text())["task"] == "drawing"


def test_a_hand_whose_fingers_share_a_joint_is_simulated_with_it_once(tmp_path):
    """The spread joint before two fingers is one MuJoCo joint: seven simulated joints for the hand's eight
    columns, and the three tips hold the ball they touch."""
    from tests.hand_files import write_spread_gripper

    hand = load_hand(write_spread_gripper(tmp_path)).grasping_hand()
    ball = Superquadric(np.full(3, GRIPPER_BALL_RADIUS_M), 1.0, 1.0, name="ball")
    body = object_body(ball, SETTINGS)
    scene = build_scene(hand, ball, body, Grasp(np.eye(3), -ball_centre(), np.zeros(hand.n_joints)), 0.5, SETTINGS)
    assert len(scene.hand_dof) == len(set(scene.hand_dof.tolist())) == 7 and scene.transmission.shape == (7, 7)
    result = check_grasp(scene, drawing_like_task(0.2), body.mass_kg, SETTINGS)
    assert result.passed, result.record()
