"""The spring controller (``--controller spring``): each fingertip pad held by a Cartesian spring,
``F_j = s P_j + K (r_j - x_j) - D v_j``, plus a weak pull towards the synthesized posture for the joints the pads
leave free. While the hand closes, the rest points ``r_j`` lie a squeeze depth inside the object along its
inward normals at the synthesized contacts, and ``P = 0``. Once it has settled, :meth:`SpringController.hold`
makes the settled pads the rest points and the settled spring forces the preload ``P``: forces that hold the
object in equilibrium, which the protocol scales by ``s`` with each test's load, as a hand raises its grip.

It sees the synthesized contacts, not MuJoCo's, and never the wrench: kept so that the benchmark can compare it
with the grip controller (:mod:`grasptask.physics.grip`)."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from grasptask.physics.loads import Test
from grasptask.physics.physics_settings import PhysicsSettings
from grasptask.physics.scene import Scene
from grasptask.physics.sensing import Contacts, pad_jacobians, pad_positions


@dataclass
class SpringController:
    scene: Scene
    settings: PhysicsSettings
    rest: np.ndarray
    preload: np.ndarray

    @classmethod
    def of(cls, scene: Scene, settings: PhysicsSettings) -> SpringController:
        rest = scene.contacts - settings.squeeze_m * scene.normals
        return cls(scene, settings, rest, np.zeros_like(scene.contacts))

    def torques(self, data: mujoco.MjData, contacts: Contacts, test: Test | None, ramp: float) -> np.ndarray:
        scene, s = self.scene, self.settings
        q, qdot = data.qpos[scene.hand_qpos], data.qvel[scene.hand_dof]
        tips, jacobians = pad_positions(scene, data), pad_jacobians(scene, data)
        preload_n = float(np.linalg.norm(self.preload, axis=1).mean())
        scale = 1.0
        if test is not None and preload_n > 0:  # the grip raised with the load, to grip_safety times what it needs
            scale += ramp * s.grip_safety * test.grip_n(scene.contacts, scene.friction) / preload_n
        forces = (
            scale * self.preload
            + s.tip_stiffness_n_per_m * (self.rest - tips)
            - s.tip_damping_ns_per_m * (jacobians @ qdot)
        )
        return np.einsum("bij,bi->j", jacobians, forces) + s.posture_stiffness_nm_per_rad * (scene.posture - q)

    def hold(self, data: mujoco.MjData) -> None:
        """Hold the pads where they are with the forces the springs give there."""
        tips = pad_positions(self.scene, data)
        self.preload = self.preload + self.settings.tip_stiffness_n_per_m * (self.rest - tips)
        self.rest = tips.copy()
