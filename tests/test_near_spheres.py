"""The collision spheres a polish carries (SPEC section 12, issue 88 item 6): only those near the object where the
search ended; the verifier still checks every sphere; a grasp a left-out sphere sinks into
is polished again with it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from grasptask.hand import load_hand
from grasptask.hand.kinematics import forward
from grasptask.objects import load_object
from grasptask.synthesis.near_spheres import (
    NearSpheres,
    carrying,
    clearances,
    penetrating,
    sphere_count,
    within,
)

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "configs" / "objects" / "tool.yaml"


@pytest.fixture(scope="module")
def leap(tmp_path_factory):
    """A LEAP-like hand as its URDF is published: thin printed links covered by 6,600 spheres, mesh fingertips."""
    from tests.hand_files import write_leap_like

    return load_hand(write_leap_like(tmp_path_factory.mktemp("leap")))


def _grasp_near_the_tool(hand, obj):
    """The palm 8 cm off the tool's axis, its normal toward it, the fingers 0.4 of their range closed: some
    spheres near, most far."""
    rotation = np.array([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]])
    return rotation, obj.centre + np.array([0.08, 0.0, 0.0]), hand.grasping_hand().posture(0.4)


def test_the_near_spheres_are_those_within_the_distance(leap):
    obj = load_object(TOOL)
    rotation, position, q = _grasp_near_the_tool(leap, obj)
    at = clearances(leap, obj, rotation, position, q)
    assert len(at) == sphere_count(leap) == 6593
    kept = within(leap, at, 0.015)
    offset = 0
    for indices, finger in zip(kept.fingers, leap.grasping_hand().fingers.values(), strict=True):
        assert set(indices) == set(np.flatnonzero(at[offset : offset + len(finger.spheres)] <= 0.015))
        offset += len(finger.spheres)
    assert set(kept.palm) == set(np.flatnonzero(at[offset:] <= 0.015))
    assert kept.count == (at <= 0.015).sum()
    assert 0 < kept.count < sphere_count(leap) / 10


def test_a_hand_carrying_the_near_spheres_has_those_at_the_same_places(leap):
    obj = load_object(TOOL)
    rotation, position, q = _grasp_near_the_tool(leap, obj)
    kept = within(leap, clearances(leap, obj, rotation, position, q), 0.015)
    narrow = carrying(leap, kept)
    assert sphere_count(narrow) == kept.count
    every, radii = forward(leap.grasping_hand(), q, rotation, position).collision_spheres()
    some, some_radii = forward(narrow.grasping_hand(), q, rotation, position).collision_spheres()
    index, offset = [], 0
    for indices, finger in zip(kept.fingers, leap.grasping_hand().fingers.values(), strict=True):
        index += [offset + i for i in indices]
        offset += len(finger.spheres)
    index += [offset + i for i in kept.palm]
    np.testing.assert_allclose(some[0], every[0][index])
    np.testing.assert_allclose(some_radii, radii[index])
    # the joints, pads and capability are the hand's own
    assert narrow.grasping_hand().joint_names == leap.grasping_hand().joint_names
    assert narrow.capability is leap.capability


def test_a_left_out_sphere_that_sinks_in_widens_the_set():
    hand = load_hand(ROOT / "configs" / "hands" / "human.yaml")
    count = sphere_count(hand)
    clearance = np.full(count, 0.05)
    clearance[[1, count - 1]] = -0.002  # a finger's sphere and the palm's last, 2 mm in
    deep = penetrating(hand, clearance, 0.5e-3)
    assert deep.count == 2 and deep.palm == (len(hand.palm.radii) - 1,)
    near = within(hand, clearance, 0.01)
    assert near == deep and near.covers(deep)
    none = within(hand, np.full(count, np.inf), 0.0)
    assert none.count == 0 and not none.covers(deep) and none.widened(deep) == deep
    some = within(hand, np.where(np.arange(count) == 5, 0.0, 0.05), 0.01)
    wider = some.widened(deep)
    assert wider.covers(deep) and wider.covers(some) and wider.count == 3
    assert NearSpheres(((),) * len(none.fingers), ()).covers(none)


def test_a_search_sweep_on_a_hand_of_many_spheres_polishes_with_the_near_ones(tasks, tmp_path):
    """A hand counted as one of many spheres (the config's threshold at 0): the workers' model carries no
    collision sphere, each polish those near its grasp, and every polished grasp the verifier passed
    clears every sphere of the hand."""
    from grasptask.records.solutions import grasp_from_row
    from grasptask.stages import SynthesisOptions, run_synthesize

    config = tmp_path / "solver.yaml"
    config.write_text("search_round: 2\nsearch: {batch_size: 2, polish_all_spheres_max: 0}\n")
    said: list[str] = []
    options = SynthesisOptions(tasks=tasks, task="drawing", out=tmp_path / "out", solver_config=config, starts=2,
                               workers=1, route="search")  # fmt: skip
    run_synthesize(options, echo=said.append)
    rows = pd.read_parquet(tmp_path / "out" / "drawing" / "solutions.parquet")
    polished = rows[rows["outcome"] == "polished"]
    assert len(polished) >= 1 and polished["verified"].any()
    hand, obj = load_hand(ROOT / "configs" / "hands" / "human.yaml"), load_object(TOOL)
    assert (polished["polish_spheres"] < sphere_count(hand)).all()
    assert any("none of the hand's 33 collision spheres" in line for line in said)
    names = hand.grasping_hand().joint_names
    for _, row in polished[polished["verified"]].iterrows():
        grasp = grasp_from_row(row, names)
        at = clearances(hand, obj, grasp.palm_rotation, grasp.palm_position, grasp.joint_angles)
        assert at.min() >= -hand.compliance_m - 1e-4
    run = __import__("json").loads((tmp_path / "out" / "drawing" / "run.json").read_text())
    assert run["route"]["polish_model"]["spheres"] == int(polished["polish_spheres"].median())
