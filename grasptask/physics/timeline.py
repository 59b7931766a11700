"""What the physics check did at every control step of one phase, kept with ``check_grasp(..., trace=True)``:
the object's motion from where the phase began, the wrench and the actuators' controls applied over the step,
and the object's pose and the hand's joints at its end. It draws the report's path plots and replays the check
in an exported scene (:mod:`grasptask.physics.scene_file`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PhaseTrace:
    """One phase, one row per control step. ``time_s`` is the end of the step: the controls and the wrench act
    over the step before it, the motion and the poses are read at it. ``force`` and ``torque`` are what MuJoCo's
    ``xfrc_applied`` got: world frame (the object's task frame at rest), the torque about the object's centre of
    mass. ``object_pose`` is its free joint's ``qpos`` (position, then quaternion w x y z); ``joints`` the
    scene's simulated hand joints."""

    time_s: np.ndarray  # (n,)
    translation_m: np.ndarray  # (n,)
    rotation_deg: np.ndarray  # (n,)
    force: np.ndarray  # (n, 3)
    torque: np.ndarray  # (n, 3)
    controls: np.ndarray  # (n, actuators)
    object_pose: np.ndarray  # (n, 7)
    joints: np.ndarray  # (n, joints)

    @classmethod
    def of(cls, rows: list[np.ndarray], actuators: int, joints: int) -> PhaseTrace:
        """From the rows :meth:`row` made."""
        table = np.array(rows, dtype=float).reshape(-1, 9 + actuators + 7 + joints)
        cuts = np.cumsum([1, 1, 1, 3, 3, actuators, 7])
        time, moved, turned, force, torque, controls, pose, angles = np.split(table, cuts, axis=1)
        return cls(time[:, 0], moved[:, 0], turned[:, 0], force, torque, controls, pose, angles)

    @staticmethod
    def row(
        time_s: float,
        moved: float,
        turned: float,
        wrench: np.ndarray,
        controls: np.ndarray,
        object_pose: np.ndarray,
        joints: np.ndarray,
    ) -> np.ndarray:
        return np.concatenate([[time_s, moved, turned], wrench, controls, object_pose, joints])
