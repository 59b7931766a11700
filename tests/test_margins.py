"""The margin every task wrench is held with, and the margin figures of a grasp, on a case small enough to
work out by hand: two contacts opposed across a ball of radius R at (+-R, 0, 0), each on a finger whose three
joints move the contact along x, y and z (its Jacobian is the identity), each joint a motor of effort E. A force
F along y on the object is carried half by each contact's friction, with a squeeze a on each:

    F / 2 <= mu a (the square pyramid of 4 edges) and a <= E (the motors)

so the hand holds it when F / (2 mu) <= E; the strength margin is 2 mu E / F (for mu < 1), the friction
margin F / (2 E)."""

from __future__ import annotations

import numpy as np
import pytest

from grasptask.grasp.grasp_settings import GraspSettings, load_grasp_settings
from grasptask.hand.hand_model import Capability, Finger, Hand, Joint, Pad, Palm
from grasptask.verifier.checks import torque_effort
from grasptask.verifier.loads_lp import load_block
from grasptask.verifier.margins import FRICTION_STEPS, friction_margin, strength_margin
from grasptask.verifier.mechanics import friction_cone_edges

R = 0.02
POINTS = np.array([[R, 0.0, 0.0], [-R, 0.0, 0.0]])
INWARD = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
TANGENTS = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]])
JACOBIANS = [np.eye(3), np.eye(3)]


def _hand(effort: float) -> Hand:
    fingers = {}
    for k in range(2):
        joints = tuple(Joint(f"f{k}_{axis}", np.eye(3)[a], -1.0, 1.0) for a, axis in enumerate("xyz"))
        pad = Pad(np.zeros(3), np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
        fingers[f"f{k}"] = Finger(f"f{k}", joints, (), pad, np.zeros(3), 0.01)
    names = tuple(j.name for f in fingers.values() for j in f.joints)
    capability = Capability.motors(names, np.full(6, effort), np.eye(6))
    return Hand("two", fingers, Palm(np.zeros((0, 3)), np.zeros(0)), tuple(fingers), capability)


def _effort(effort: float, force: float, mu: float) -> float:
    edges = friction_cone_edges(INWARD, mu, 4, TANGENTS)

    class Task:  # one wrench, +-F along y: eq. 10's two blocks of one axis
        lengths = np.array([force])
        axes = np.array([[0.0, 1.0, 0.0, 0.0, 0.0, 0.0]])

    return torque_effort(edges, POINTS, JACOBIANS, _hand(effort), Task())[0]  # type: ignore[arg-type]


@pytest.mark.parametrize(("effort", "force", "mu"), [(2.0, 1.0, 0.5), (1.0, 0.6, 0.3), (3.0, 2.0, 0.8)])
def test_the_margin_lps_give_the_hand_computed_values(effort, force, mu):
    targets = [np.array([0.0, s * force, 0.0, 0.0, 0.0, 0.0]) for s in (1.0, -1.0)]
    edges = friction_cone_edges(INWARD, mu, 4, TANGENTS)
    strength = strength_margin(load_block(edges, POINTS, JACOBIANS, _hand(effort)), targets)
    assert strength == pytest.approx(2 * mu * effort / force, rel=1e-6)
    friction = friction_margin(INWARD, TANGENTS, POINTS, JACOBIANS, _hand(effort), mu, 4, targets)
    expected = force / (2 * effort)
    assert expected <= friction <= expected + max(mu, expected) / 2**FRICTION_STEPS  # the bisection's resolution


def test_a_grasp_at_the_edge_of_its_cones_is_held_without_the_margin_and_refused_with_it():
    """F / (2 mu) = E: every task wrench needs the whole friction cone at full strength."""
    assert _effort(effort=1.0, force=1.0, mu=0.5) == pytest.approx(1.0, rel=1e-6)  # held, at the edge
    assert _effort(effort=1.0, force=1.0, mu=0.8 * 0.5) > 1.0 + 1e-3  # in cones of 0.8 mu: out of reach


def test_the_margin_settings_are_validated(tmp_path):
    from grasptask.errors import BadInputError

    config = tmp_path / "grasp.yaml"
    config.write_text("activation_max: 1.2\n")
    with pytest.raises(BadInputError, match="activation_max"):
        load_grasp_settings(config)
    config.write_text("friction_scale: 0.8\nactivation_max: 0.8\nmin_normal_force_n: 0.2\n")
    loaded = load_grasp_settings(config)
    assert (loaded.friction_scale, loaded.activation_max, loaded.min_normal_force_n) == (0.8, 0.8, 0.2)
    # the shipped config sets nothing (the schema's defaults are the tool's), and the paper's keeps no margin
    assert GraspSettings() == load_grasp_settings("configs/grasp.yaml")
    paper = load_grasp_settings("configs/grasp_paper.yaml")
    assert (paper.activation_max, paper.friction_scale, paper.min_normal_force_n) == (1.0, 1.0, 0.0)
    assert paper.motor_activation_max == 1.0
    assert not paper.rolling_contacts
    config.write_text("motor_activation_max: 0.5\nactivation_margin: 0.6\n")
    with pytest.raises(BadInputError, match="activation_margin"):
        load_grasp_settings(config)


def test_the_activation_cap_follows_the_hand_s_actuators():
    """Rated motors take the motor cap, estimated muscles the tendon cap, a hand with both the lower."""
    from grasptask.hand import load_hand

    settings = GraspSettings(activation_max=0.8, motor_activation_max=0.9)
    assert settings.activation_cap(load_hand("configs/hands/human.yaml").capability.kind) == 0.8
    assert settings.activation_cap(load_hand("configs/hands/allegro.yaml").capability.kind) == 0.9
    assert settings.activation_cap(load_hand("configs/hands/barrett_bh8_282.urdf").capability.kind) == 0.9
    assert settings.activation_cap("mixed") == 0.8


def test_a_fixed_pad_point_is_not_held_off_a_face_by_its_tip_s_cover():
    """In the paper's model the contact is the pad point itself: a capsule cover's sphere beside it, 0.29 mm proud
    of the capsule, is clipped at the pad's tangent plane; one inside it, or proud by more than the tip gives, is
    left whole."""
    from grasptask.hand.hand_model import Pad, Sphere
    from grasptask.synthesis.nlp import _under_a_fixed_pad

    pad = Pad(np.array([0.012, 0.0, 0.043]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]), 0.012)
    proud = Sphere(3, np.array([0.0, 0.0, 0.0403]), 0.01229)
    inside = Sphere(3, np.array([-0.002, 0.0, 0.03]), 0.009)
    far = Sphere(3, np.array([0.0, 0.0, 0.03]), 0.0132)  # a cylinder cover's, 1.2 mm proud: the real link's bulk
    assert _under_a_fixed_pad(proud, pad, 0.5e-3) == pytest.approx(0.012)
    assert _under_a_fixed_pad(inside, pad, 0.5e-3) == 0.009
    assert _under_a_fixed_pad(far, pad, 0.5e-3) == 0.0132
