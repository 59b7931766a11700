"""Contacts a real fingertip can make: the contact rolls over the fingertip's sphere, whose centre sits one
radius minus the hand's compliance from the surface, and no link of the hand's true geometry sinks deeper than
that compliance."""

from __future__ import annotations

import dataclasses

import numpy as np
import pyomo.environ as pyo
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from grasptask.errors import BadInputError
from grasptask.grasp.grasp_pose import Grasp
from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand import forward, load_hand
from grasptask.objects.superquadric import Superquadric
from grasptask.synthesis.nlp import build_model
from grasptask.verifier.verify import verify
from tests.grasp_fixtures import BALL_RADIUS, ball_grasp, drawing_like_task
from tests.hand_files import write_mesh_gripper


def test_the_rolling_contact_is_the_sphere_nearest_the_surface_sunk_by_the_compliance():
    grasp, ball = ball_grasp()
    hand = load_hand().grasping_hand()
    result = verify(grasp, hand, ball, drawing_like_task(), GraspSettings())
    assert result.ok, result.failures
    pose = forward(hand, grasp.joint_angles, grasp.palm_rotation, grasp.palm_position)
    centres = pose.pad_centres()[0]
    radii = np.array([f.pad.radius for f in hand.fingers.values()])
    # each contact is on the line from the ball's centre to its fingertip's centre, one offset from it, give or
    # take the contact distance the verifier reports (the fixture fits the contacts to 0.4 mm)
    along = centres / np.linalg.norm(centres, axis=1, keepdims=True)
    np.testing.assert_allclose(result.contacts, BALL_RADIUS * along, atol=1e-7)
    reach = np.linalg.norm(result.contacts - centres, axis=1)
    np.testing.assert_allclose(reach, radii - 0.002 + result.contact_distance_m, atol=1e-9)
    # the deepest sinking is a fingertip's, by the compliance less its contact distance
    assert result.penetration_m == pytest.approx((0.002 - result.contact_distance_m).max(), abs=5e-5)


def test_the_penetration_check_rejects_a_fingertip_sunk_3_mm_into_the_object():
    grasp, ball = ball_grasp()
    hand = load_hand().grasping_hand()
    pose = forward(hand, grasp.joint_angles, grasp.palm_rotation, grasp.palm_position)
    towards = -pose.pad_centres()[0][0] / np.linalg.norm(pose.pad_centres()[0][0])  # thumb tip to ball centre
    sunk = dataclasses.replace(grasp, palm_position=grasp.palm_position + 0.003 * towards)
    result = verify(sunk, hand, ball, drawing_like_task(), GraspSettings())
    assert "penetration" in result.failures
    # the compliance's 2 mm and 3 mm more, less the thumb's contact distance in the fixture
    before = verify(grasp, hand, ball, drawing_like_task(), GraspSettings()).contact_distance_m[0]
    assert result.penetration_m == pytest.approx(0.005 - before, abs=5e-5)
    paper = verify(sunk, hand, ball, drawing_like_task(), GraspSettings(rolling_contacts=False))
    assert "penetration" not in paper.failures  # the paper's fixed pad point sets no such limit


def test_penetration_is_measured_on_the_true_geometry_a_box_edge(tmp_path):
    """A ball 2 mm into the edge of a gripper's box link, from the diagonal: the true surface sinks 2 mm, and the
    spheres covering the box for eq. 14 hold the edge too (spheres of its half-width on its spine, the old cover,
    stayed 0.5 mm clear of the ball)."""
    hand = load_hand(write_mesh_gripper(tmp_path)).grasping_hand()
    radius, depth, half = 0.02, 0.002, 0.006
    edge = np.array([0.03 + half, half, 0.035])  # finger 0's first link: a 12 mm box from z = 0 to 7 cm
    centre = edge + (radius - depth) * np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    grasp = Grasp(np.eye(3), -centre, np.zeros(hand.n_joints))
    result = verify(
        grasp, hand, Superquadric(np.full(3, radius), 1.0, 1.0, name="ball"), drawing_like_task(), GraspSettings()
    )
    assert result.penetration_m == pytest.approx(depth, abs=1e-4)
    assert "penetration" in result.failures
    assert result.min_clearance_m < -depth + 1e-9  # the cover bulges beyond the edge, never short of it


def test_the_paper_mode_keeps_the_fixed_pad_point():
    grasp, ball = ball_grasp()
    rolling = build_model(load_hand(), ball, drawing_like_task(), GraspSettings()).model
    fixed = build_model(load_hand(), ball, drawing_like_task(), GraspSettings(rolling_contacts=False)).model
    assert len(rolling.eq2_rolling_contact) == 9 and len(rolling.eq2_contact_point) == 0
    assert len(fixed.eq2_rolling_contact) == 0 and len(fixed.eq2_contact_point) == 9
    bounds = [c.lower for c in fixed.eq14_collision.values()]
    assert all(pyo.value(b) == 0 for b in bounds)  # no sphere may sink without rolling contacts


def test_compliance_is_a_hand_property_checked_against_the_fingertip(tmp_path):
    gripper = write_mesh_gripper(tmp_path)
    assert load_hand(gripper).compliance_m == 0.0005  # a robot fingertip's default
    assert load_hand().compliance_m == 0.002  # the human pulp, cited in configs/hands/human.yaml
    spec = {"model": str(gripper), "compliance_m": 0.012}
    (tmp_path / "soft.yaml").write_text(yaml.safe_dump(spec))
    with pytest.raises(BadInputError, match="compliance 0.012 m is not below the fingertip radius 0.01 m"):
        load_hand(tmp_path / "soft.yaml")
    spec["compliance_m"] = 0.001
    (tmp_path / "soft.yaml").write_text(yaml.safe_dump(spec))
    assert load_hand(tmp_path / "soft.yaml").compliance_m == 0.001


def test_the_human_hand_cites_a_source_for_every_maximal_tendon_force():
    """Every thumb muscle names its own source; those still assumed are the ones no published model gives."""
    data = yaml.safe_load(open("configs/hands/human.yaml"))
    header = open("configs/hands/human.yaml").read().split("\nname:")[0]
    tables = data["tendons"]
    assert "[AN83]" in tables["index"]["source"] and tables["middle"]["same_as"] == "index"
    assumed = set()
    for name, muscle in tables["thumb"]["muscles"].items():
        source = muscle["source"]
        if source.startswith("ASSUMPTION"):
            assumed.add(name)
        else:
            assert source in header, f"{name}: {source} is not among the file's sources"
    assert assumed == {"FPB", "APB", "ADP"}
    forces = {name: m["max_force_n"] for name, m in tables["thumb"]["muscles"].items()}
    assert forces["FPL"] == 201.0 and forces["EPL"] == 88.3 and forces["EPB"] == 46.0 and forces["APL"] == 116.7


def test_the_paper_hand_is_the_human_hand_with_the_assumed_thumb_strengths(tmp_path):
    """make paper's hand (configs/hands/human_paper.yaml, ``base: human.yaml``) differs in the thumb's maximal
    forces only; a base that leads back to its own file is one line."""
    cited, paper = load_hand(), load_hand("configs/hands/human_paper.yaml")
    assert paper.joint_names == cited.joint_names and paper.compliance_m == cited.compliance_m
    thumb = cited.slices()["thumb"]
    differs = np.abs(cited.capability.torque_map - paper.capability.torque_map) > 1e-12
    assert differs.any() and not differs[thumb.stop :].any()  # the fingers' tendons are the same
    (tmp_path / "a.yaml").write_text("base: b.yaml\n")
    (tmp_path / "b.yaml").write_text("base: a.yaml\n")
    with pytest.raises(BadInputError, match="leads back"):
        load_hand(tmp_path / "a.yaml")


@settings(max_examples=30, deadline=None)
@given(radius=st.floats(0.003, 0.02), half_length=st.floats(0.0, 0.05))
def test_a_capsule_cover_holds_the_whole_capsule_and_keeps_its_ends_exact(radius, half_length):
    """Every point of a capsule lies in one of its cover's spheres (no sag between them, which let the Allegro's
    tips sink 0.85 mm where eq. 14 allowed 0.5), the end spheres are the capsule's own (the pad sits on the
    last), and the inner ones bulge at most 3.1% of the radius."""
    from grasptask.hand import skin, spheres

    frame = np.eye(4)
    frame[:3, :3] = np.linalg.qr(np.array([[1.0, 0.2, 0.3], [0.1, 1.0, 0.4], [0.5, 0.3, 1.0]]))[0]
    frame[:3, 3] = [0.01, -0.02, 0.03]
    cover = spheres.capsule(radius, half_length, frame)
    centres = np.array([c for c, _ in cover])
    radii = np.array([r for _, r in cover])
    points = skin.capsule(radius, half_length, frame)
    inside = (np.linalg.norm(points[:, None] - centres[None], axis=2) - radii[None]).min(axis=1)
    assert inside.max() <= 1e-9
    assert radii[0] == radii[-1] == radius
    assert np.allclose(centres[-1], frame[:3, 3] + half_length * frame[:3, 2])
    assert radii.max() <= radius * np.hypot(1.0, spheres.CAPSULE_STEP / 2) + 1e-12
