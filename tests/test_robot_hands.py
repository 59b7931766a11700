"""Robot hands from URDF and MJCF files: their kinematics against the parsing library's own, Jacobians against
finite differences, mimic couplings, effort limits in the NLP and the verifier, and bad hand files."""

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyomo.repn import generate_standard_repn

from grasptask.errors import BadInputError
from grasptask.grasp.grasp_settings import GraspSettings, load_grasp_settings
from grasptask.hand import forward, load_hand
from grasptask.hand.tendons import activation_for
from tests.test_hand import assert_contact_jacobians_match_finite_differences

BARRETT = Path("configs/hands/barrett_bh8_282.urdf")
ALLEGRO = Path("configs/hands/allegro.yaml")
ALLEGRO_MJCF = Path("configs/hands/allegro.xml")
seeds = st.integers(0, 2**32 - 1)


def random_q(hand, rng):
    return hand.apply_coupling(rng.uniform(hand.lower, hand.upper))


@settings(max_examples=15, deadline=None)
@given(seeds)
def test_urdf_kinematics_agree_with_yourdfpy(seed):
    import yourdfpy

    hand = load_hand(BARRETT)
    urdf = yourdfpy.URDF.load(str(BARRETT), build_scene_graph=True, load_meshes=False, load_collision_meshes=False)
    q = random_q(hand, np.random.default_rng(seed))
    values = dict(zip(hand.joint_names, q, strict=True))
    urdf.update_cfg({name: values[name] for name in urdf.actuated_joint_names})
    pose = forward(hand, q)
    children = {j.name: j.child for j in urdf.robot.joints}
    for name, finger in hand.fingers.items():
        posed = pose.fingers[name]
        for k, joint in enumerate(finger.joints):
            expected = urdf.get_transform(children[joint.name], "palm")
            np.testing.assert_allclose(posed.joint_positions[0, k], expected[:3, 3], atol=1e-9)
            np.testing.assert_allclose(posed.link_rotations[0, k], expected[:3, :3], atol=1e-9)
        # the tip's sphere holds the pad: the contact surface, not one of the collision spheres
        radius = urdf.link_map[name].collisions[0].geometry.sphere.radius
        tip_centre = posed.contact[0] - radius * posed.pad_normal[0]
        np.testing.assert_allclose(tip_centre, urdf.get_transform(name, "palm")[:3, 3], atol=1e-9)
        assert np.linalg.norm(pose.collision_spheres()[0][0] - tip_centre, axis=1).min() > 1e-3


MJCF_WITH_OFFSETS = """<mujoco model="offsets">
  <compiler angle="radian" autolimits="true"/>
  <worldbody><body name="palm"><geom type="box" size="0.03 0.03 0.01"/>
    <body name="a1" pos="0.03 0.01 0.01" quat="0.9 0.1 0.3 0.2">
      <joint name="ja1" axis="0 1 0.2" pos="0.004 -0.002 0.003" range="-0.5 1.5"/>
      <geom type="capsule" size="0.008 0.015" pos="0 0 0.02" quat="0.9 0 0.2 0"/>
      <body name="a2" pos="0.002 0 0.04"><joint name="ja2" axis="0 1 0" pos="0 0 0.002" range="0 1.2"/>
        <geom type="sphere" size="0.009" pos="0.001 0.002 0.025"/></body></body>
    <body name="b1" pos="-0.03 0 0.01" quat="0.7 0 0 0.7"><joint name="jb1" axis="1 0 0" range="-1 1"/>
      <geom type="cylinder" size="0.008 0.01" pos="0 0 0.015"/>
      <body name="b2" pos="0 0 0.03"><joint name="jb2" axis="0 1 0" range="0 1"/>
        <geom type="sphere" size="0.01" pos="0 0 0.02"/></body></body>
  </body></worldbody>
  <equality><joint joint1="jb2" joint2="jb1" polycoef="0.1 0.5 0 0 0"/></equality>
  <actuator><motor joint="ja1" ctrlrange="-0.4 0.4" gear="2"/><motor joint="ja2" ctrlrange="-0.3 0.3"/>
    <motor joint="jb1" forcerange="-0.6 0.6" forcelimited="true" ctrlrange="-5 5"/></actuator>
</mujoco>
"""


@settings(max_examples=15, deadline=None)
@given(seed=seeds)
def test_mjcf_kinematics_agree_with_mujoco(tmp_path_factory, seed):
    import mujoco

    path = tmp_path_factory.getbasetemp() / "offsets.xml"
    path.write_text(MJCF_WITH_OFFSETS)
    for source in (path, ALLEGRO_MJCF):
        hand = load_hand(source)
        model = mujoco.MjModel.from_xml_path(str(source))
        data = mujoco.MjData(model)
        q = random_q(hand, np.random.default_rng(seed))
        for name, value in zip(hand.joint_names, q, strict=True):
            data.qpos[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)]] = value
        mujoco.mj_kinematics(model, data)
        palm = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "palm")
        to_palm = data.xmat[palm].reshape(3, 3).T
        pose = forward(hand, q)
        spheres = np.flatnonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_SPHERE)
        ours = pose.collision_spheres()[0][0]
        for g in spheres:  # each sphere is a collision sphere, or holds a pad (the tip's contact surface)
            expected = to_palm @ (data.geom_xpos[g] - data.xpos[palm])
            pads = [f.contact[0] - model.geom_size[g][0] * f.pad_normal[0] for f in pose.fingers.values()]
            assert np.min(np.linalg.norm(np.vstack([ours, pads]) - expected, axis=1)) < 1e-9
        for name, finger in hand.fingers.items():
            posed = pose.fingers[name]
            for k, joint in enumerate(finger.joints):
                j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, joint.name)
                anchor = to_palm @ (data.xanchor[j] - data.xpos[palm])
                np.testing.assert_allclose(posed.joint_positions[0, k], anchor, atol=1e-9)
                np.testing.assert_allclose(posed.joint_axes[0, k], to_palm @ data.xaxis[j], atol=1e-9)


@pytest.mark.parametrize("source", [BARRETT, ALLEGRO])
def test_contact_jacobians_of_robot_hands_match_finite_differences(source):
    hand = load_hand(source)
    rng = np.random.default_rng(4)
    assert_contact_jacobians_match_finite_differences(hand, rng.uniform(hand.lower, hand.upper))


def test_mimic_joints_are_coupled_and_share_their_motor():
    hand = load_hand(BARRETT)
    names = hand.joint_names
    couplings = {names[d]: (names[i], r) for d, i, r, _ in hand.couplings()}
    assert couplings["j13"] == ("j12", pytest.approx(0.84 / 2.44, rel=1e-5))
    assert couplings["j21"] == ("j11", 1.0)  # the spread: one motor for fingers 1 and 2
    capability = hand.capability
    spread = capability.transmission[:, names.index("j11")].nonzero()[0]
    assert len(spread) == 1 and capability.transmission[spread[0], names.index("j21")] == 1.0
    assert capability.transmission.shape == (4, 8)  # four motors for eight joints
    q = hand.apply_coupling(np.full(hand.n_joints, 0.5))
    assert q[names.index("j13")] == pytest.approx(0.5 * 0.84 / 2.44, rel=1e-5)


def test_effort_limits_reach_the_nlp_and_the_verifier(tmp_path):
    from grasptask.objects import load_object
    from grasptask.synthesis.nlp import build_model
    from tests.grasp_fixtures import drawing_like_task

    text = BARRETT.read_text()
    doubled = tmp_path / "strong.urdf"
    doubled.write_text(text.replace('effort="1.8"', 'effort="3.6"'))
    hand, strong = load_hand(BARRETT), load_hand(doubled)
    nlp = build_model(hand, load_object("configs/objects/tool.yaml"), drawing_like_task(), GraspSettings())
    coefficients = {
        round(abs(c), 6)
        for con in nlp.model.eq10_torque.values()
        for c in generate_standard_repn(con.body).linear_coefs
    }
    assert 1.8 in coefficients and 1.0 in coefficients  # the motors' efforts, as eq. 10's torque map
    torque = np.zeros(hand.n_joints)
    torque[hand.joint_names.index("j12")] = 0.9
    assert activation_for(hand.capability, torque).effort == pytest.approx(0.5)
    assert activation_for(strong.capability, torque).effort == pytest.approx(0.25)


def test_human_hand_grasps_with_four_and_five_fingers():
    hand = load_hand()
    for fingers in (("thumb", "index", "middle", "ring"), ("thumb", "index", "middle", "ring", "little")):
        grasping = hand.with_grasping(fingers).grasping_hand()
        assert list(grasping.fingers) == list(fingers)
        assert grasping.capability.transmission.shape[1] == grasping.n_joints


BAD_URDFS = {
    "malformed XML": ("<robot name='x'><link name='a'>", "malformed XML"),
    "a cycle": (
        "<robot name='x'><link name='a'/><link name='b'/>"
        "<joint name='j1' type='fixed'><parent link='a'/><child link='b'/></joint>"
        "<joint name='j2' type='fixed'><parent link='b'/><child link='a'/></joint></robot>",
        "cycle",
    ),
    "no limits": ("<limit lower='0' upper='1.5' effort='2.0' velocity='1'/>", "has no limits"),
    "non-positive effort": ("effort='2.0'", "effort -1 is negative"),
    "missing mimic": ("<axis xyz='0 1 0'/>", "mimics 'nowhere', which is not a joint"),
    "one fingertip": ("f2", "at least two fingertips"),
}

TWO_FINGERS = """<robot name="two">
  <link name="palm"><collision><geometry><box size="0.08 0.08 0.02"/></geometry></collision></link>
  <link name="l1"/><link name="f1"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>
  <link name="l2"/><link name="f2"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="palm"/><child link="l1"/><origin xyz="0.03 0 0.01"/>
    <axis xyz="0 1 0"/><limit lower="0" upper="1.5" effort="2.0" velocity="1"/></joint>
  <joint name="t1" type="fixed"><parent link="l1"/><child link="f1"/><origin xyz="0 0 0.05"/></joint>
  <joint name="j2" type="revolute"><parent link="palm"/><child link="l2"/><origin xyz="-0.03 0 0.01"/>
    <axis xyz="0 -1 0"/><limit lower="0" upper="1.5" effort="2.0" velocity="1"/></joint>
  <joint name="t2" type="fixed"><parent link="l2"/><child link="f2"/><origin xyz="0 0 0.05"/></joint>
</robot>
"""


def bad_urdf(case: str) -> str:
    text, _ = BAD_URDFS[case]
    if case in ("malformed XML", "a cycle"):
        return text
    if case == "no limits":
        return TWO_FINGERS.replace(text.replace("'", '"'), "", 1)
    if case == "non-positive effort":
        return TWO_FINGERS.replace('effort="2.0"', 'effort="-1"', 1)
    if case == "missing mimic":
        return TWO_FINGERS.replace('<axis xyz="0 -1 0"/>', '<axis xyz="0 -1 0"/><mimic joint="nowhere"/>', 1)
    return TWO_FINGERS.replace(
        '<collision><geometry><sphere radius="0.01"/></geometry></collision></link>\n  <link name="l2"/>',
        '</link>\n  <link name="l2"/>',
        1,
    )


@pytest.mark.parametrize("case", list(BAD_URDFS))
def test_bad_hand_files_are_one_line(case, tmp_path, cli, simulated):
    path = tmp_path / "hand.urdf"
    path.write_text(bad_urdf(case))
    tasks = simulated[0] / "tasks" / "task_models.json"
    result = cli("synthesize", "--tasks", tasks, "--task", "drawing", "--out", tmp_path / "o", "--hand", path)
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert "hand.urdf" in lines[0] and BAD_URDFS[case][1] in lines[0], lines[0]
    assert not (tmp_path / "o").exists()


def test_a_two_finger_urdf_loads_without_any_extra_file(tmp_path):
    path = tmp_path / "two.urdf"
    path.write_text(TWO_FINGERS)
    hand = load_hand(path)
    assert list(hand.fingers) == ["f1", "f2"] and hand.capability.kind == "motors"
    yaml = tmp_path / "two.yaml"
    yaml.write_text("model: two.urdf\nfingertips: [f1, f9]\n")
    with pytest.raises(BadInputError, match="unknown fingertip 'f9'"):
        load_hand(yaml)
    yaml.write_text(
        "model: two.urdf\nfingertips: [f1, f2]\nfinger_names: [left, right]\ngrasping_fingers: [left, right]\n"
    )
    assert list(load_hand(yaml).fingers) == ["left", "right"]


def test_a_missing_visual_mesh_does_not_stop_loading(tmp_path):
    path = tmp_path / "visual.urdf"
    path.write_text(
        TWO_FINGERS.replace(
            '<link name="l1"/>',
            '<link name="l1"><visual><geometry><mesh filename="package://gone/meshes/l1.stl"/></geometry></visual></link>',
        )
    )
    assert len(load_hand(path).fingers) == 2


def test_elements_the_hand_does_not_use_are_ignored(tmp_path):
    """A URDF as ROS tools write it, with materials, a transmission, Gazebo tags and an inertial block, gives the
    same hand as the bare file."""
    extras = (
        '<material name="grey"><color rgba="0.5 0.5 0.5 1"/></material>'
        '<transmission name="t_j1"><type>transmission_interface/SimpleTransmission</type>'
        '<joint name="j1"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>'
        '<actuator name="m1"><mechanicalReduction>1</mechanicalReduction></actuator></transmission>'
        '<gazebo reference="f1"><mu1>0.9</mu1></gazebo>'
    )
    inertial = (
        '<inertial><mass value="0.1"/><inertia ixx="1e-5" ixy="0" ixz="0" iyy="1e-5" iyz="0" izz="1e-5"/></inertial>'
    )
    rich = TWO_FINGERS.replace('<link name="l1"/>', f'<link name="l1">{inertial}</link>').replace(
        "</robot>", extras + "</robot>"
    )
    (tmp_path / "bare.urdf").write_text(TWO_FINGERS)
    (tmp_path / "rich.urdf").write_text(rich)
    bare, loaded = load_hand(tmp_path / "bare.urdf"), load_hand(tmp_path / "rich.urdf")
    q = np.array([0.4, 0.9])
    assert loaded.joint_names == bare.joint_names
    np.testing.assert_allclose(forward(loaded, q).contacts(), forward(bare, q).contacts(), atol=1e-12)
    np.testing.assert_allclose(loaded.capability.torque_map, bare.capability.torque_map)


def test_a_sweep_runs_end_to_end_on_a_urdf_hand(cli, simulated, tmp_path):
    """Starts, placement, the NLP, the verifier and the tables for a robot hand: rows named by its own joints
    and fingers, every status one of the sweep's, and the run recording the hand's fingers."""
    import json

    import pandas as pd

    from grasptask.records.solutions import STATUSES

    tasks = simulated[0] / "tasks" / "task_models.json"
    result = cli(
        "synthesize", "--tasks", tasks, "--task", "drawing", "--out", tmp_path, "--hand", BARRETT,
        "--solver-config", "tests/data/solver_fast.yaml", "--starts", "2", "--executor", "serial",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    solutions = pd.read_parquet(tmp_path / "drawing" / "solutions.parquet")
    assert set(solutions["status"]) <= set(STATUSES) and len(solutions) == 2
    hand = load_hand(BARRETT)
    solved = solutions[solutions["palm_x"].notna()]
    assert not solved.empty
    for name in hand.joint_names:
        assert f"q_{name}" in solutions.columns
    for finger in hand.fingers:
        assert f"contact_{finger}_x" in solutions.columns and f"verify_pad_angle_deg_{finger}" in solutions.columns
    for _, row in solved.iterrows():  # the NLP honoured the mimic couplings
        assert abs(row["q_j13"] - 0.344262 * row["q_j12"]) < 1e-5 and abs(row["q_j21"] - row["q_j11"]) < 1e-5
    assert json.loads((tmp_path / "drawing" / "run.json").read_text())["fingers"] == list(hand.fingers)


HOLDING_HANDS = {
    "barrett": (BARRETT, None),
    "allegro": (ALLEGRO, None),
    "human4": (Path("configs/hands/human.yaml"), ("thumb", "index", "middle", "ring")),
    "human5": (Path("configs/hands/human.yaml"), ("thumb", "index", "middle", "ring", "little")),
}


#: with the margin, the robot hands hold screw driving from 12% (Barrett) and 31% (Allegro) of the starts only
#: (docs/design/margins.md); there the test checks the machinery in the paper's contact model
WITHOUT_MARGIN = {("barrett", "screwdriving"), ("allegro", "screwdriving")}


@pytest.mark.parametrize(
    "task",
    ["drawing", pytest.param("cutting", marks=pytest.mark.slow), pytest.param("screwdriving", marks=pytest.mark.slow)],
)
@pytest.mark.parametrize("hand_name", list(HOLDING_HANDS))
def test_each_hand_holds_each_task_within_a_few_starts(simulated, hand_name, task):
    """Every shipped robot hand, and the human hand with four and five fingers, reaches a grasp the independent
    verifier accepts for every task on the tool cylinder, within the first few of the spread-out starts: with the
    margin and rolling contacts, but where the margin is out of the hand's reach."""
    from grasptask.synthesis.context import Job, SolverContext
    from grasptask.synthesis.solver_config import load_solver_config
    from grasptask.synthesis.starts import make_starts, subset

    path, fingers = HOLDING_HANDS[hand_name]
    tasks = simulated[0] / "tasks" / "task_models.json"
    solver = load_solver_config("configs/solver.yaml")
    paper = (hand_name, task) in WITHOUT_MARGIN
    settings = load_grasp_settings("configs/grasp_paper.yaml") if paper else GraspSettings()
    context = SolverContext(
        Job.from_files(str(path), "configs/objects/tool.yaml", str(tasks), task, solver=solver, fingers=fingers,
            settings=settings)
    )  # fmt: skip
    tried = []
    for start in subset(make_starts(context.bounds), 12)[:5]:
        row = context.solve(start)
        tried.append((start.start_id, row["status"], row.get("verify_failures")))
        if row["verified"]:
            assert np.isfinite(row["Q"])
            return
    pytest.fail(f"{hand_name} found no verified {task} grasp in {len(tried)} starts: {tried}")


def test_a_start_the_verifier_rejects_is_solved_again_from_an_opened_hand(simulated):
    """Some of the BarrettHand's end-on screw-driving starts end in a locally infeasible ring grasp from mid-range
    joints; the retry postures of configs/solver.yaml solve them again from an opened hand. A retried row adds
    up every attempt's seconds and iterations and says how the first attempt did; without retry postures the
    same start is solved once."""
    from dataclasses import replace

    from grasptask.synthesis.context import Job, SolverContext
    from grasptask.synthesis.solver_config import load_solver_config
    from grasptask.synthesis.starts import make_starts

    tasks = str(simulated[0] / "tasks" / "task_models.json")
    # the whole model from the start (torque_axes None), so that only the retry postures re-solve a rejected start,
    # and the first attempt from the mid-range joints these starts fail from
    solver = replace(load_solver_config("configs/solver.yaml"), torque_axes=None, first_posture=0.5)
    assert solver.retry_postures
    # the paper's contact model: with the margin the Barrett holds screw driving from few starts
    # (docs/design/margins.md)
    paper = load_grasp_settings("configs/grasp_paper.yaml")
    context = SolverContext(
        Job.from_files(str(BARRETT), "configs/objects/tool.yaml", tasks, "screwdriving", solver=solver, settings=paper)
    )
    starts = make_starts(context.bounds)
    # end-on starts (palm normal within 37 degrees of the handle), in order: which of them fail from mid-range
    # differs between processors (floating-point paths), so the first rescued one is taken, not a fixed one
    end_on = [s.start_id for s in starts if abs(s.palm_rotation[2, 2]) > 0.8]
    rescued = None
    for start_id in end_on:
        row = context.solve(starts[start_id])
        assert row["attempts"] == 1 or not row["first_attempt_verified"]
        if row["attempts"] > 1 and row["verified"]:
            rescued = start_id, row
            break
    assert rescued is not None, "no end-on start was rescued by the retry postures"
    start_id, row = rescued
    assert row["seconds"] > row["first_attempt_seconds"] > 0 and row["iterations"] > 0
    once = SolverContext(
        Job.from_files(
            str(BARRETT),
            "configs/objects/tool.yaml",
            tasks,
            "screwdriving",
            solver=replace(solver, retry_postures=()),
            settings=paper,
        )
    ).solve(starts[start_id])
    assert once["attempts"] == 1 and not once["verified"]
    assert once["seconds"] == pytest.approx(once["first_attempt_seconds"])
