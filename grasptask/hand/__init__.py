"""The human hand: kinematic chains, contact pads, collision samples and tendon force capabilities (Section 3)."""

from grasptask.hand.kinematics import HandPose, forward
from grasptask.hand.model import Finger, Hand, Joint, load_hand

__all__ = ["Finger", "Hand", "HandPose", "Joint", "forward", "load_hand"]
