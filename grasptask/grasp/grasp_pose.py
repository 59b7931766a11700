"""A grasp as a hand pose: the value the NLP produces, the verifier judges and the tables store."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Grasp:
    """A hand pose: palm rotation ``R_h`` and position ``d_h`` in the object frame, and joint angles (rad) of
    the grasping fingers in the hand's joint order."""

    palm_rotation: np.ndarray
    palm_position: np.ndarray
    joint_angles: np.ndarray
