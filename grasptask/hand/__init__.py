"""Hands: kinematic chains, contact pads, collision spheres and force capabilities (paper Section 3)."""

from grasptask.hand.hand_files import load_hand
from grasptask.hand.hand_model import Capability, Finger, GraspingHand, Hand, Joint, Pad, Palm, Sphere
from grasptask.hand.kinematics import HandPose, forward

__all__ = [
    "Capability",
    "Finger",
    "GraspingHand",
    "Hand",
    "HandPose",
    "Joint",
    "Pad",
    "Palm",
    "Sphere",
    "forward",
    "load_hand",
]
