"""Hands: kinematic chains, contact pads, collision spheres and force capabilities (paper Section 3)."""

from grasptask.hand.kinematics import HandPose, forward
from grasptask.hand.loading import load_hand
from grasptask.hand.model import Capability, Finger, Hand, Joint, Pad, Palm, Sphere

__all__ = ["Capability", "Finger", "Hand", "HandPose", "Joint", "Pad", "Palm", "Sphere", "forward", "load_hand"]
