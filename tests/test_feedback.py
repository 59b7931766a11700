"""The verifier's feedback to the NLP: which rejected grasps are re-solved, and how far their limits tighten."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grasptask.synthesis.feedback import PAD_MARGIN_DEG, Limits, tightened

NOMINAL = Limits(0.98, np.full(3, 45.0))


def test_only_narrow_misses_are_re_solved():
    for failures in ([], ["clearance"], ["torque_feasibility", "force_closure"], ["contact_distance", "pad_angle"]):
        assert tightened(NOMINAL, 0.98, failures, 1.1, np.full(3, 47.0)) is None
    assert tightened(NOMINAL, 0.98, ["torque_feasibility"], float("inf"), np.full(3, 40.0)) is None


def test_the_cap_shrinks_by_the_verifiers_effort_and_the_pads_by_their_excess():
    limits = tightened(NOMINAL, 0.98, ["torque_feasibility", "pad_angle"], 1.25, np.array([47.0, 30.0, 45.0]))
    assert limits is not None
    assert limits.activation_cap == pytest.approx(0.98 * 0.98 / 1.25)
    np.testing.assert_allclose(limits.pad_angle_deg, [45.0 - 2.0 - PAD_MARGIN_DEG, 45.0, 45.0])
    only_pads = tightened(NOMINAL, 0.98, ["pad_angle"], 0.9, np.array([46.5, 44.0, 45.0]))
    assert only_pads is not None and only_pads.activation_cap == 0.98


@settings(max_examples=50, deadline=None)
@given(
    st.floats(0.3, 0.98),
    st.floats(1.0, 5.0),
    st.lists(st.floats(0.0, 90.0), min_size=3, max_size=3),
    st.sampled_from([["torque_feasibility"], ["pad_angle"], ["pad_angle", "torque_feasibility"]]),
)
def test_tightened_limits_are_never_looser(cap, effort, angles, failures):
    before = Limits(cap, np.array([45.0, 40.0, 44.0]))
    after = tightened(before, 0.98, failures, effort, np.array(angles))
    assert after is not None
    assert after.activation_cap <= before.activation_cap
    assert np.all(after.pad_angle_deg <= before.pad_angle_deg)
    seen_past = np.array(angles) > before.pad_angle_deg
    if "pad_angle" in failures:  # a pad the verifier saw past its bound is bounded below what it saw
        assert np.all(after.pad_angle_deg[seen_past] < np.array(angles)[seen_past])


def test_a_contact_off_its_mesh_fingertip_rolls_less_on_the_re_solve():
    limits = tightened(
        NOMINAL, 0.98, ["fingertip_contact"], 0.5, np.array([30.0, 44.0, 10.0]), np.array([1, 0, 1], bool)
    )
    assert limits is not None and limits.activation_cap == 0.98
    np.testing.assert_allclose(limits.pad_angle_deg, [27.5, 45.0, 7.5])
