"""Hand files as their authors root them: at an empty frame fixed to the palm, at a forearm with a wrist before
the palm, with an IMU fixed beside the palm. The palm is the link where the fingers' chains branch, with every
link fixed to it; the joints before it are held and said."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from grasptask.errors import BadInputError
from grasptask.hand import load_hand
from grasptask.hand.mesh_cover import MAX_BOUND_M, mesh_spheres
from grasptask.report.hand_view import hand_lines
from tests.test_robot_hands import TWO_FINGERS

PALM = '<link name="palm"><collision><geometry><box size="0.08 0.08 0.02"/></geometry></collision></link>'


def rooted_at_an_empty_link() -> str:
    """The two-finger hand as a published collection roots it: an empty 'base' fixed to the palm."""
    return TWO_FINGERS.replace(
        PALM,
        '<link name="base"/>\n  <joint name="base_joint" type="fixed"><parent link="base"/><child link="palm"/>'
        '<origin xyz="0 0 0.1" rpy="0 0 1.5708"/></joint>\n  ' + PALM,
    )


def with_a_wrist(lower: float = -0.5, upper: float = 0.5) -> str:
    """A forearm with a wrist joint before the palm, and an IMU with a box fixed beside the palm."""
    forearm = (
        '<link name="forearm"><collision><origin xyz="0 0 -0.1"/><geometry><box size="0.06 0.06 0.2"/></geometry>'
        '</collision></link>\n  <joint name="wrist" type="revolute"><parent link="forearm"/><child link="palm"/>'
        f'<origin xyz="0 0 0.05"/><axis xyz="1 0 0"/><limit lower="{lower}" upper="{upper}" effort="5" velocity="1"/>'
        "</joint>\n  "
    )
    imu = (
        '\n  <link name="imu"><collision><geometry><box size="0.01 0.01 0.01"/></geometry></collision></link>'
        '\n  <joint name="palm_to_imu" type="fixed"><parent link="palm"/><child link="imu"/>'
        '<origin xyz="0 0.03 -0.01"/></joint>'
    )
    return TWO_FINGERS.replace(PALM, forearm + PALM + imu)


def test_a_hand_rooted_at_an_empty_fixed_link_keeps_its_palm(tmp_path):
    plain, rooted = tmp_path / "plain.urdf", tmp_path / "rooted.urdf"
    plain.write_text(TWO_FINGERS)
    rooted.write_text(rooted_at_an_empty_link())
    reference, hand = load_hand(plain), load_hand(rooted)
    assert hand.palm_link == "palm" and len(hand.palm.radii) == len(reference.palm.radii) > 0
    np.testing.assert_allclose(hand.palm.points, reference.palm.points, atol=1e-12)
    assert list(hand.fingers) == list(reference.fingers)


def test_a_wrist_before_the_palm_is_held_and_said(tmp_path):
    path = tmp_path / "forearm.urdf"
    path.write_text(with_a_wrist())
    hand = load_hand(path)
    assert hand.palm_link == "palm" and hand.held_joints == {"wrist": 0.0}
    assert list(hand.fingertip_links.values()) == ["f1", "f2"]  # the IMU beside the palm is no fingertip
    assert "wrist" not in hand.joint_names
    plain = tmp_path / "plain.urdf"
    plain.write_text(TWO_FINGERS)
    # the palm's own box and the IMU's; not the forearm, beyond the held wrist
    assert len(hand.palm.radii) > len(load_hand(plain).palm.radii)
    assert (hand.palm.points[:, 2] > -0.03).all()
    assert any("held" in line and "wrist at 0 deg" in line for line in hand_lines(hand))


def test_a_wrist_whose_range_leaves_out_zero_is_held_at_its_nearest_limit(tmp_path):
    path = tmp_path / "forearm.urdf"
    path.write_text(with_a_wrist(0.2, 0.8))
    assert load_hand(path).held_joints == {"wrist": pytest.approx(0.2)}


def test_a_hand_yaml_holds_the_wrist_where_it_says_and_names_a_wrong_joint(tmp_path):
    (tmp_path / "forearm.urdf").write_text(with_a_wrist())
    yaml_path = tmp_path / "hand.yaml"
    yaml_path.write_text("model: forearm.urdf\nheld_joints: {wrist: 0.3}\n")
    assert load_hand(yaml_path).held_joints == {"wrist": 0.3}
    yaml_path.write_text("model: forearm.urdf\nheld_joints: {j1: 0.3}\n")
    with pytest.raises(BadInputError, match=r"hand.yaml: field 'held_joints.j1': 'j1' is no joint between the root"):
        load_hand(yaml_path)
    yaml_path.write_text("model: forearm.urdf\nheld_joints: {wrist: 2.0}\n")
    with pytest.raises(BadInputError, match=r"field 'held_joints.wrist': 2.0 rad is outside the joint's range"):
        load_hand(yaml_path)


def test_a_palm_without_collision_geometry_is_said(tmp_path):
    path = tmp_path / "bare.urdf"
    path.write_text(TWO_FINGERS.replace(PALM, '<link name="palm"/>'))
    lines = hand_lines(load_hand(path))
    assert any("0 on the palm; the palm has no collision geometry" in line for line in lines)


def test_the_summary_counts_motors_not_their_two_directions():
    lines = hand_lines(load_hand("configs/hands/allegro.yaml"))
    assert "16 joints, 16 motors (motors)" in lines[1]


def open_meshes() -> dict[str, trimesh.Trimesh]:
    """Meshes as hand files ship them: a palm tray without its lid, a one-sided sheet, an open shell, a closed
    box with its faces turned inward."""
    box = trimesh.creation.box([0.08, 0.06, 0.01])
    sheet = trimesh.creation.box([0.08, 0.06, 0.004])
    ball = trimesh.creation.icosphere(3, 0.04)
    shell = trimesh.Trimesh(ball.vertices, ball.faces[ball.triangles_center[:, 2] > 0])
    shell.remove_unreferenced_vertices()
    inverted = trimesh.creation.box([0.05, 0.04, 0.02])
    inverted.invert()
    return {
        "tray": trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 2] < 0.9]),
        "sheet": trimesh.Trimesh(sheet.vertices, sheet.faces[sheet.face_normals[:, 2] > 0.9]),
        "shell": shell,
        "inverted": inverted,
    }


@pytest.mark.parametrize("kind", ["tray", "sheet", "shell", "inverted"])
def test_no_cover_sphere_of_an_open_mesh_leaves_its_bounding_box_by_more_than_its_stated_reach(kind):
    mesh = open_meshes()[kind]
    spheres, reach = mesh_spheres(mesh.vertices, mesh.faces, np.eye(4))
    low, high = mesh.bounds
    for centre, radius in spheres:
        assert (centre - radius >= low - reach - 1e-9).all() and (centre + radius <= high + reach + 1e-9).all()
    assert reach <= MAX_BOUND_M  # the explosion was a 354 mm sphere on an open palm plate
    assert len(spheres) <= 64


def test_a_hand_whose_palm_is_an_open_plate_keeps_its_cover_on_the_palm(tmp_path):
    open_meshes()["tray"].export(tmp_path / "palm.stl")
    path = tmp_path / "hand.urdf"
    path.write_text(TWO_FINGERS.replace('<box size="0.08 0.08 0.02"/>', '<mesh filename="palm.stl"/>'))
    hand = load_hand(path)
    reach = hand.cover_reach_m["palm"]
    assert 0 < reach <= MAX_BOUND_M
    extent = (np.abs(hand.palm.points) + hand.palm.radii[:, None]).max(axis=0)
    assert (extent <= np.array([0.04, 0.03, 0.005]) + reach + 1e-9).all()
    assert any("palm" in line and "mm" in line for line in hand_lines(hand) if "reach" in line)


def test_a_sweep_of_a_hand_too_weak_for_the_task_says_so_with_numbers():
    import pandas as pd

    from grasptask.records.solutions import why_few_verified

    table = pd.DataFrame(
        {
            "status": ["optimal", "optimal", "acceptable", "infeasible", "optimal"],
            "verified": [False, False, False, False, True],
            "verify_failures": ["torque_feasibility", "torque_feasibility;pad_angle", "torque_feasibility", "", ""],
            "verify_torque_effort": [2.3, 8.7, 4.0, np.nan, 0.5],
        }
    )
    said = why_few_verified(table, "screwdriving")
    assert said == (
        "the hand is too weak for screwdriving: 3 of the 3 starts the verifier rejected failed its torque check, "
        "asking 2.3-8.7x its motors' or tendons' rated strength"
    )
    # a hand so weak that no start converges (the Inspire Hand's cutting): the points IPOPT left still say it
    weak = table.assign(status="infeasible", verified=False)
    assert why_few_verified(weak, "cutting").startswith("the hand is too weak for cutting: 3 of the 4 starts")
    # contacts that hold the wrenches at no strength are no sign of weak motors (a 6 mm rod: 9 of 10 so)
    table["verify_torque_effort"] = [2.3, np.inf, np.inf, np.nan, 0.5]
    table["verify_failures"] = ["torque_feasibility", "torque_feasibility;force_closure", "torque_feasibility", "", ""]
    assert why_few_verified(table, "drawing").endswith("(and 2 whose contacts could not hold them at any strength)")
    table["verify_torque_effort"] = [2.3, 0.8, np.inf, np.nan, 0.5]
    table["verify_failures"] = ["torque_feasibility;pad_angle", "pad_angle", "force_closure;torque_feasibility", "", ""]
    assert why_few_verified(table, "screwdriving") == (  # strength is not what failed most: the checks that did
        "of the 3 starts the verifier rejected (IPOPT converged on 3), 2 failed torque_feasibility, 2 pad_angle, "
        "1 force_closure"
    )
    table["verified"] = [True, True, True, False, True]
    assert why_few_verified(table, "screwdriving") is None  # most verified


def test_the_summary_line_says_which_q_is_which_where_the_judges_differ():
    from grasptask.cli.summaries import verifier_said

    assert verifier_said({"best_Q": 0.0100, "best_Q_verifier": 0.01005}) == ""
    assert verifier_said({"best_Q": 0.0100, "best_Q_verifier": 0.0920}) == " (the NLP's; the verifier's 0.092)"
    assert verifier_said({"best_Q": None, "best_Q_verifier": None}) == ""


def test_a_joint_shared_by_two_fingers_moves_both_and_its_torque_is_counted_once(tmp_path):
    """The Schunk SVH's case: one spread joint before the ring and little fingers. It was refused ("moves
    fingers ... and ..."); now it is one angle and one motor in both fingers' chains, its link's geometry once."""
    from grasptask.hand.kinematics import forward
    from tests.hand_files import write_spread_gripper

    hand = load_hand(write_spread_gripper(tmp_path))
    assert hand.shared_joints() == {"spread": ["finger1_tip", "finger2_tip"]}
    assert hand.file_joint_names.count("spread") == 2 and len(set(hand.joint_names)) == hand.n_joints == 8
    assert any("joint spread moves fingers finger1_tip and finger2_tip together" in line for line in hand_lines(hand))
    # one motor for the spread, its row summing the torque both fingers' contacts ask of it
    capability = hand.capability
    assert len(capability.actuators) == 2 * 7
    columns = [k for k, name in enumerate(hand.file_joint_names) if name == "spread"]
    row = np.flatnonzero(capability.transmission[:, columns[0]])
    assert len(row) == 1 and np.count_nonzero(capability.transmission[row[0]]) == 2
    np.testing.assert_array_equal(capability.transmission[row[0], columns], [1.0, 1.0])
    # turning it turns both fingers about the palm's axis, and leaves the third
    q = np.zeros(hand.n_joints)
    q[columns[0]] = 0.2
    q = hand.apply_coupling(q)
    assert q[columns[1]] == 0.2
    still, turned = forward(hand, np.zeros(hand.n_joints)).contacts()[0], forward(hand, q).contacts()[0]
    turn = np.array([[np.cos(0.2), -np.sin(0.2), 0], [np.sin(0.2), np.cos(0.2), 0], [0, 0, 1]])
    np.testing.assert_allclose(turned[1:], still[1:] @ turn.T, atol=1e-12)
    np.testing.assert_allclose(turned[0], still[0], atol=1e-12)
    # the knuckle's box is carried by one finger, not both
    links = {name: {s.link for s in f.spheres} for name, f in hand.fingers.items()}
    assert 0 in links["finger1_tip"] and 0 not in links["finger2_tip"]


def test_more_than_three_fingers_on_one_motor_each_get_a_hint_to_name_three(tmp_path):
    """The Inspire Hand's case: five grasping fingers, four closing on one motor each; all five ended every
    drawing start in IPOPT's restoration failure, three of them 6/6 optimal at 0.7 s a start."""
    from dataclasses import replace

    path = tmp_path / "two.urdf"
    path.write_text(TWO_FINGERS)
    two = load_hand(path)
    fingers = {f"{name}{k}": replace(finger, name=f"{name}{k}") for k in (1, 2) for name, finger in two.fingers.items()}
    four = replace(two, fingers=fingers, grasping=tuple(fingers))
    hint = [line for line in hand_lines(four) if "close on one motor each" in line]
    assert len(hint) == 1 and "4 fingers grasp" in hint[0] and "--fingers" in hint[0]
    assert not any("one motor each" in line for line in hand_lines(four.with_grasping(list(fingers)[:3])))
