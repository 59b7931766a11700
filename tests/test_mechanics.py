"""Grasp mechanics on textbook grasps, Q's invariances, and the verifier on a real grasp and broken ones."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand import load_hand
from grasptask.verifier.epsilon import ferrari_canny
from grasptask.verifier.mechanics import (
    friction_cone_edges,
    grasp_matrix,
    internal_forces,
    primitive_wrenches,
    task_quality,
    task_torques,
)
from grasptask.verifier.verify import verify
from tests.grasp_fixtures import ball_grasp, drawing_like_task

seeds = st.integers(0, 2**32 - 1)
HAND = load_hand()
GRASPING = HAND.grasping_hand()


def sphere_contacts(directions):
    points = np.asarray(directions, dtype=float)
    points = points / np.linalg.norm(points, axis=1, keepdims=True) * 0.03
    return points, -points / 0.03  # inward normals


def epsilon_of(points, inward, mu=0.5, m=4, reference=np.zeros(3), scale=0.03, tangents=None):
    edges = friction_cone_edges(inward, mu, m, tangents)
    return ferrari_canny(primitive_wrenches(points, edges, reference, scale))


def test_friction_cone_edges_make_the_friction_angle_with_the_normal():
    normal = np.array([[0.0, 0.0, 1.0]])
    edges = friction_cone_edges(normal, 0.5, 4)[0]
    np.testing.assert_allclose(np.linalg.norm(edges, axis=1), 1.0)
    np.testing.assert_allclose(edges @ normal[0], np.cos(np.arctan(0.5)))


def test_grasp_matrix_maps_forces_to_the_object_wrench():
    points = np.array([[0.1, 0, 0], [0, 0.2, 0]])
    f = np.array([0, 0, 1.0, 1.0, 0, 0])
    w = grasp_matrix(points) @ f
    np.testing.assert_allclose(w[:3], [1, 0, 1])
    np.testing.assert_allclose(w[3:], np.cross(points[0], [0, 0, 1]) + np.cross(points[1], [1, 0, 0]))


def test_three_contacts_around_a_sphere_are_force_closure():
    points, inward = sphere_contacts([[1, 0, 0], [-0.5, np.sqrt(3) / 2, 0], [-0.5, -np.sqrt(3) / 2, 0]])
    assert epsilon_of(points, inward) > 0.01


def test_four_tetrahedral_contacts_are_force_closure_and_better_than_three():
    tetra = [[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]]
    three = [[1, 0, 0], [-0.5, np.sqrt(3) / 2, 0], [-0.5, -np.sqrt(3) / 2, 0]]
    assert epsilon_of(*sphere_contacts(tetra)) > epsilon_of(*sphere_contacts(three)) > 0


def test_two_antipodal_point_contacts_are_not_force_closure():
    """No torsional friction: nothing resists a torque about the line through the two contacts."""
    points, inward = sphere_contacts([[1, 0, 0], [-1, 0, 0]])
    assert epsilon_of(points, inward, m=8) == 0.0


def test_contacts_all_on_one_side_are_not_force_closure():
    points, inward = sphere_contacts([[0.2, 0, 1], [-0.1, 0.17, 1], [-0.1, -0.17, 1]])
    assert epsilon_of(points, inward) == 0.0


@settings(max_examples=25, deadline=None)
@given(seeds)
def test_q_is_invariant_to_adding_internal_forces(seed):
    rng = np.random.default_rng(seed)
    points = rng.normal(size=(3, 3)) * 0.05
    G = grasp_matrix(points)
    J = rng.normal(size=(9, 13)) * 0.05
    u = rng.normal(size=6)
    u /= np.linalg.norm(u)
    base, _ = task_torques(G, J, u)
    shifted = np.linalg.lstsq(G, u, rcond=None)[0] + internal_forces(G) @ rng.normal(size=3) * 10
    other, _ = task_torques(G, J, u, particular=shifted)
    np.testing.assert_allclose(other, base, atol=1e-9)


@settings(max_examples=25, deadline=None)
@given(seeds)
def test_epsilon_and_q_are_invariant_to_a_rigid_motion_of_the_whole_grasp(seed):
    rng = np.random.default_rng(seed)
    points, inward = sphere_contacts(rng.normal(size=(3, 3)) + [[3, 0, 0], [-1, 2, 0], [-1, -2, 0]])
    J = rng.normal(size=(9, 13)) * 0.05
    axes = np.linalg.qr(rng.normal(size=(6, 6)))[0].T
    weights = rng.dirichlet(np.ones(6))
    rotation, shift = Rotation.random(random_state=seed).as_matrix(), rng.normal(size=3)
    moved_points, moved_inward = points @ rotation.T + shift, inward @ rotation.T
    moved_J = np.kron(np.eye(3), rotation) @ J
    moved_axes = axes @ np.kron(np.eye(2), rotation).T  # task wrenches about the moved object origin
    tangents = rng.normal(size=(3, 3))  # each cone's orientation, carried along with the grasp (eq. 24)
    moved = epsilon_of(moved_points, moved_inward, reference=shift, tangents=tangents @ rotation.T)
    assert moved == pytest.approx(epsilon_of(points, inward, tangents=tangents), rel=1e-7)
    q, _ = task_quality(grasp_matrix(points), J, axes, weights)
    moved_q, _ = task_quality(grasp_matrix(moved_points, shift), moved_J, moved_axes, weights)
    assert moved_q == pytest.approx(q, rel=1e-7)


def test_q_with_a_weight_matrix_equals_the_identity_case_when_it_is_the_identity():
    rng = np.random.default_rng(0)
    G, J = grasp_matrix(rng.normal(size=(3, 3)) * 0.05), rng.normal(size=(9, 13)) * 0.05
    axes, weights = np.eye(6), np.full(6, 1 / 6)
    assert task_quality(G, J, axes, weights, np.eye(13))[0] == pytest.approx(task_quality(G, J, axes, weights)[0])
    doubled, _ = task_quality(G, J, axes, weights, 2 * np.eye(13))
    assert doubled == pytest.approx(2 * task_quality(G, J, axes, weights)[0])


@pytest.fixture(scope="module")
def accepted():
    grasp, ball = ball_grasp()
    return grasp, ball, verify(grasp, GRASPING, ball, drawing_like_task(), GraspSettings())


def test_verifier_accepts_a_real_precision_grasp(accepted):
    grasp, ball, result = accepted
    assert result.ok, result.failures
    assert np.abs(result.contact_distance_m).max() < 1e-3
    assert result.epsilon > 0 and result.torque_effort <= 1
    assert result.internal_force_rank == result.internal_force_dim == 3
    record = result.record(["thumb", "index", "middle"])
    assert record["verified"] and "verify_pad_angle_deg_index" in record


def test_verifier_rejects_a_task_too_strong_for_the_tendons(accepted):
    grasp, ball, _ = accepted
    result = verify(grasp, GRASPING, ball, drawing_like_task(scale=2.0), GraspSettings())
    assert result.failures == ["torque_feasibility"] and result.torque_effort > 1


def test_verifier_rejects_a_finger_inside_the_object(accepted):
    grasp, ball, _ = accepted
    sunk = dataclasses.replace(grasp, palm_position=grasp.palm_position + np.array([0.0, 0.0, 0.012]))
    result = verify(sunk, GRASPING, ball, drawing_like_task(), GraspSettings())
    assert "clearance" in result.failures or "contact_distance" in result.failures
    assert result.min_clearance_m < -1e-3 or np.abs(result.contact_distance_m).max() > 1e-3


def test_verifier_rejects_a_joint_beyond_its_limit(accepted):
    grasp, ball, _ = accepted
    q = grasp.joint_angles.copy()
    q[HAND.grasping_hand().joint_names.index("index_mcp_abd")] = np.radians(25.0)
    result = verify(dataclasses.replace(grasp, joint_angles=q), GRASPING, ball, drawing_like_task(), GraspSettings())
    assert "joint_limits" in result.failures and result.joint_limit_margin_deg < -9


def test_verifier_rejects_broken_coupling_and_a_non_rotation(accepted):
    grasp, ball, _ = accepted
    q = grasp.joint_angles.copy()
    q[HAND.grasping_hand().joint_names.index("index_dip")] += 0.2
    assert (
        "coupling"
        in verify(
            dataclasses.replace(grasp, joint_angles=q), GRASPING, ball, drawing_like_task(), GraspSettings()
        ).failures
    )
    skewed = dataclasses.replace(grasp, palm_rotation=grasp.palm_rotation * 1.01)
    assert "palm_rotation" in verify(skewed, GRASPING, ball, drawing_like_task(), GraspSettings()).failures


def test_verifier_rejects_all_contacts_on_one_side(accepted):
    """The same hand pose, with the object shifted so that all three pads touch one small sphere from one side."""
    grasp, _, _ = accepted
    from grasptask.hand import forward
    from grasptask.objects import Superquadric

    pose = forward(HAND.grasping_hand(), grasp.joint_angles, grasp.palm_rotation, grasp.palm_position)
    pads, normals = pose.contacts()[0], pose.pad_normals()[0]
    # a big ball touched near one pole: every pad on the same cap
    centre = pads.mean(axis=0) + normals.mean(axis=0) / np.linalg.norm(normals.mean(axis=0)) * 0.5
    ball = Superquadric(np.full(3, np.linalg.norm(pads - centre, axis=1).mean()), 1.0, 1.0, position=centre)
    result = verify(grasp, GRASPING, ball, drawing_like_task(), GraspSettings())
    assert "force_closure" in result.failures and result.epsilon == 0.0


def _with_tip_meshes(hand, shrink_m: float = 0.0):
    """``hand`` with each fingertip given its own mesh: an icosphere over its pad's sphere (or, for a pad without
    one, an 8 mm sphere touching the pad point), ``shrink_m`` smaller."""
    import trimesh

    fingers = {}
    for name, finger in hand.fingers.items():
        pad = finger.pad
        radius = pad.radius if pad.radius > 0 else 0.008
        ball = trimesh.creation.icosphere(4, radius - shrink_m)
        vertices = ball.vertices + (pad.point - radius * pad.normal)
        fingers[name] = dataclasses.replace(finger, tip_mesh=(vertices, ball.faces))
    return dataclasses.replace(hand, fingers=fingers)


def test_verifier_measures_each_contact_against_its_fingertips_own_mesh(accepted):
    """A mesh fingertip's contact must lie on the mesh, not only on the sphere the NLP rolls it over: a LEAP
    Hand's verified contacts lay 1-6.7 mm off its fingertip meshes."""
    grasp, ball, plain = accepted
    hand = HAND.grasping_hand()
    on_tip = verify(grasp, _with_tip_meshes(hand), ball, drawing_like_task(), GraspSettings())
    assert on_tip.ok, on_tip.failures
    assert np.isnan(plain.fingertip_gap_m).all()  # no mesh, nothing to measure
    assert (on_tip.fingertip_gap_m < 0).all()  # inside the tip: it gives by the compliance there
    # a contact sits the compliance (2 mm for the human hand) inside its pad sphere: 6 mm smaller, 4 mm outside
    off_tip = verify(grasp, _with_tip_meshes(hand, shrink_m=0.006), ball, drawing_like_task(), GraspSettings())
    assert off_tip.failures == ["fingertip_contact"]
    np.testing.assert_allclose(off_tip.fingertip_gap_m, 0.004, atol=6e-4)  # contacts sit within 1 mm


def test_a_points_distance_outside_a_mesh_is_signed_by_its_side_whichever_way_its_faces_turn():
    import trimesh

    from grasptask.verifier.fingertip import outside_distance

    ball = trimesh.creation.icosphere(4, 0.01)
    points = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.009], [0.012, 0.0, 0.0], [0.0, -0.02, 0.0]])
    expected = [-0.01, -0.001, 0.002, 0.01]
    np.testing.assert_allclose(outside_distance(points, ball.triangles), expected, atol=5e-5)
    ball.invert()
    np.testing.assert_allclose(outside_distance(points, ball.triangles), expected, atol=5e-5)


@settings(max_examples=40, deadline=None)
@given(seeds)
def test_a_points_distance_to_triangles_is_the_nearest_of_their_points(seed):
    from grasptask.verifier.fingertip import outside_distance

    rng = np.random.default_rng(seed)
    triangles, points = rng.normal(size=(4, 3, 3)), rng.normal(size=(5, 3)) * 2
    u, v = np.meshgrid(np.linspace(0, 1, 120), np.linspace(0, 1, 120))
    inside = u + v <= 1
    weights = np.stack([1 - u[inside] - v[inside], u[inside], v[inside]], axis=1)
    samples = np.einsum("sk,tkd->tsd", weights, triangles).reshape(-1, 3)
    sampled = np.linalg.norm(points[:, None] - samples[None], axis=2).min(axis=1)
    exact = np.abs(outside_distance(points, triangles))  # unsigned: the nearest triangle's distance
    assert (exact <= sampled + 1e-12).all()
    assert (sampled - exact <= 0.05).all()  # the samples lie 1/120 of a triangle apart
