"""The independent grasp verifier: numpy and scipy only, sharing no code with the NLP (README, "Hand, objects
and the grasp verifier").

A grasp counts as found only when :func:`verify` accepts it: when it passes every check of
:data:`~grasptask.verifier.checks.CHECKS`. Distances are Euclidean, measured against a dense sampling of the
object's surface (:class:`grasptask.objects.surface.SurfaceIndex`), not the implicit function the NLP
constrains; force closure is judged by the Ferrari-Canny metric (qhull), torque feasibility by a linear program
over contact forces in the friction cones and tendon activations, and Q is recomputed from the contact geometry.
"""

from __future__ import annotations

import numpy as np

from grasptask.grasp.grasp_pose import Grasp
from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand.hand_model import GraspingHand
from grasptask.hand.kinematics import forward
from grasptask.objects.surface import ImplicitObject
from grasptask.task.task_model import TaskModel
from grasptask.verifier.checks import CHECKS, Inspection, task_targets
from grasptask.verifier.loads_lp import load_block
from grasptask.verifier.margins import friction_margin, strength_margin
from grasptask.verifier.verification import Tolerances, Verification


def inspect(
    grasp: Grasp,
    hand: GraspingHand,
    obj: ImplicitObject,
    task: TaskModel,
    settings: GraspSettings,
    tolerances: Tolerances,
) -> Inspection:
    """``grasp`` measured once for the checks: the hand's pose, and where each contact meets the object."""
    if not isinstance(hand, GraspingHand):
        raise TypeError(f"the verifier takes a grasping hand ({hand.name}.grasping_hand()), not the whole hand")
    q = np.asarray(grasp.joint_angles, dtype=float)
    rotation, position = np.asarray(grasp.palm_rotation, float), np.asarray(grasp.palm_position, float)
    pose = forward(hand, q, rotation, position)
    offsets = hand.contact_offsets(settings.rolling_contacts)
    reference = np.where((offsets > 0)[:, None], pose.pad_centres()[0], pose.contacts()[0])
    contacts, outward = obj.closest_point(reference, exact=True)
    return Inspection(hand, obj, task, settings, tolerances, q, rotation, pose, offsets, reference, contacts, outward)


def verify(
    grasp: Grasp,
    hand: GraspingHand,
    obj: ImplicitObject,
    task: TaskModel,
    settings: GraspSettings,
    tolerances: Tolerances = Tolerances(),
) -> Verification:
    """Check a grasp of ``obj`` by ``hand`` (its grasping fingers) for ``task``: every check, then, for a grasp that
    passes them all, its strength and friction margins (each costs LPs, so of those only)."""
    s = inspect(grasp, hand, obj, task, settings, tolerances)
    figures: dict = {}
    failures = []
    for check in CHECKS:
        passed, measured = check.judge(s)
        figures.update(measured)
        if not passed:
            failures.append(check.name)
    strength = friction = float("nan")
    if not failures:
        targets = task_targets(task)
        edges, mu, twists = s.cone_edges(), settings.friction_coefficient, s.twists()
        strength = strength_margin(load_block(edges, s.contacts, s.jacobians, s.hand, twists), targets)
        known = settings.friction_scale * mu if figures["torque_effort"] <= 1.0 else None  # held at full strength
        friction = friction_margin(
            s.inward, s.tangents, s.contacts, s.jacobians, s.hand, mu, settings.cone_edges, targets, known, twists
        )
    return Verification(
        **figures,
        strength_margin=strength,
        friction_margin=friction,
        contacts=s.contacts,
        normals=s.outward,
        failures=failures,
    )
