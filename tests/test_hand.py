"""Hand model: 21 joints, kinematics against finite differences, tendon tables and the activation LP."""

import numpy as np
import pandas as pd
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from grasptask.hand import forward, load_hand
from grasptask.hand.tendons import activation_for, producible
from grasptask.paths import REFERENCE_DIR

HAND = load_hand()
seeds = st.integers(0, 2**32 - 1)


def random_configuration(hand, rng):
    return hand.apply_coupling(rng.uniform(hand.lower, hand.upper))


def test_joint_counts_and_default_selection():
    assert HAND.n_joints == 21
    assert [f.n_joints for f in HAND.fingers.values()] == [5, 4, 4, 4, 4]
    grasping = HAND.grasping_hand()
    assert list(grasping.fingers) == ["thumb", "index", "middle"] and grasping.n_joints == 13
    assert len(grasping.couplings()) == 2


def test_every_joint_and_tendon_table_carries_a_source():
    data = yaml.safe_load(open("configs/hands/human.yaml"))
    for finger in data["fingers"].values():
        for joint in finger["joints"]:
            assert joint.get("source"), joint["name"]
    for name, table in data["tendons"].items():
        assert table.get("source"), name
    assert "ASSUMPTION" in data["tendons"]["thumb"]["source"]


def test_index_tendons_match_the_reference_table():
    reference = pd.read_csv(REFERENCE_DIR / "paper_tendons.csv", comment="#").fillna(0.0)
    index = HAND.subset(["index"]).capability
    assert list(index.actuators) == list(reference["tendon"])
    arms = reference[["arm_mcp_abd_mm", "arm_mcp_flex_mm", "arm_pip_flex_mm", "arm_dip_flex_mm"]].to_numpy()
    np.testing.assert_allclose(index.torque_map, arms.T * 1e-3 * reference["max_force_N"].to_numpy())
    assert index.kind == "tendons" and np.array_equal(index.transmission, np.eye(4))
    np.testing.assert_allclose(HAND.subset(["middle"]).capability.torque_map, index.torque_map)


@settings(max_examples=40, deadline=None)
@given(seeds)
def test_contact_jacobians_match_finite_differences(seed):
    rng = np.random.default_rng(seed)
    q = rng.uniform(HAND.lower, HAND.upper)  # every joint free: J^j has one column per joint
    rotation = Rotation.random(random_state=seed).as_matrix()
    position = rng.normal(size=3) * 0.1
    assert_contact_jacobians_match_finite_differences(HAND, q, rotation, position)


def assert_contact_jacobians_match_finite_differences(hand, q, rotation=None, position=None, step=1e-6):
    """Every finger's contact Jacobian column against central differences of its contact point."""
    pose = forward(hand, q, rotation, position)
    for (name, finger), cols in zip(pose.fingers.items(), hand.slices().values(), strict=True):
        for k, col in enumerate(range(cols.start, cols.stop)):
            plus, minus = q.copy(), q.copy()
            plus[col] += step
            minus[col] -= step
            numeric = (
                forward(hand, plus, rotation, position).fingers[name].contact
                - forward(hand, minus, rotation, position).fingers[name].contact
            ) / (2 * step)
            np.testing.assert_allclose(finger.jacobian[0, :, k], numeric[0], atol=1e-8)


def test_batched_forward_equals_one_at_a_time():
    rng = np.random.default_rng(3)
    qs = np.array([random_configuration(HAND, rng) for _ in range(5)])
    batch = forward(HAND, qs)
    for n, q in enumerate(qs):
        single = forward(HAND, q)
        np.testing.assert_allclose(batch.contacts()[n], single.contacts()[0], atol=1e-14)
        np.testing.assert_allclose(batch.collision_spheres()[0][n], single.collision_spheres()[0][0], atol=1e-14)


def test_pad_is_offset_from_the_bone_by_the_finger_radius():
    pose = forward(HAND, HAND.mid_range())
    for name, finger in pose.fingers.items():
        chain = finger.joint_positions[0]
        distal_start, tip = chain[-2], chain[-1]
        bone = (tip - distal_start) / np.linalg.norm(tip - distal_start)
        offset = finger.contact[0] - distal_start
        off_axis = offset - (offset @ bone) * bone
        assert np.isclose(np.linalg.norm(off_axis), HAND.fingers[name].radius)
        np.testing.assert_allclose(off_axis / np.linalg.norm(off_axis), finger.pad_normal[0], atol=1e-12)


@settings(max_examples=20, deadline=None)
@given(st.floats(0.0, 1.0))
def test_postures_lie_within_the_limits_and_honour_the_couplings(fraction):
    """The retry postures of synthesis: each independent joint that fraction of its range, couplings applied."""
    q = HAND.posture(fraction)
    assert np.all(q >= HAND.lower - 1e-12) and np.all(q <= HAND.upper + 1e-12)
    np.testing.assert_array_equal(q, HAND.apply_coupling(q))
    free = [i for i in range(HAND.n_joints) if i not in {d for d, *_ in HAND.couplings()}]
    np.testing.assert_allclose(q[free], (HAND.lower + fraction * (HAND.upper - HAND.lower))[free])
    np.testing.assert_array_equal(HAND.posture(0.5), HAND.mid_range())


def test_straight_index_reaches_its_length():
    q = np.zeros(HAND.n_joints)
    index = forward(HAND, q).fingers["index"]
    finger = HAND.fingers["index"]
    length = sum(j.offset[0] for j in finger.joints[1:]) + finger.tip[0]  # the links, end to end
    assert abs(length - 0.190 * (0.245 + 0.143 + 0.097)) < 1e-3  # [BA92] ratios of a 190 mm hand, rounded
    np.testing.assert_allclose(index.joint_positions[0, -1], finger.joints[0].offset + [length, 0, 0])


def test_flexion_curls_towards_the_palm_side():
    q = np.zeros(HAND.n_joints)
    q[HAND.joint_names.index("index_mcp_flex")] = np.pi / 2
    tip = forward(HAND, q).fingers["index"].joint_positions[0, -1]
    assert tip[2] > 0.08  # the palm's normal is +z


@settings(max_examples=30, deadline=None)
@given(seeds)
def test_torques_from_activations_in_range_are_producible(seed):
    rng = np.random.default_rng(seed)
    for name in HAND.fingers:
        finger = HAND.subset([name]).capability
        a = rng.uniform(0, 1, len(finger.actuators))
        result = activation_for(finger, finger.torque_map @ a)
        assert result.feasible and result.effort <= a.max() + 1e-7
        np.testing.assert_allclose(finger.torque_map @ result.activations, finger.torque_map @ a, atol=1e-8)


def test_torque_beyond_capability_is_not_producible():
    index = HAND.subset(["index"]).capability
    all_flexors = index.torque_map @ np.array([1, 1, 0, 0, 0, 0, 0.0])
    assert producible(index, all_flexors)
    assert not producible(index, 2.5 * all_flexors)
    # the extensor mechanism ties DIP to PIP: a pure DIP flexion torque has no activation pattern at all
    assert activation_for(index, np.array([0, 0, 0, 0.1])).effort == float("inf")
