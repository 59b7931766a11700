"""Hand files as their authors root them: at an empty frame fixed to the palm, at a forearm with a wrist before
the palm, with an IMU fixed beside the palm. The palm is the link where the fingers' chains branch, with every
link fixed to it; the joints before it are held and said."""

from __future__ import annotations

import numpy as np
import pytest

from grasptask.errors import BadInputError
from grasptask.hand import load_hand
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
