"""The loads the physics check puts on a grasp: the task's own wrenches, ``+-gamma_i u_i`` for the ellipsoid's six
axes (eq. 10's 12 blocks) with their torques about the task frame's origin, and DexGraspBench's six +-axis forces
of ``m a`` at the centre of mass, so that the numbers compare with theirs. Gravity is off: the recorded wrenches
are the whole load."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasptask.physics.physics_settings import PhysicsSettings
from grasptask.task.task_model import TaskModel


@dataclass(frozen=True)
class Test:
    """A wrench on the object: force (N) and torque (N m) in the world frame, the torque about ``about``
    (``"frame"``: the object frame's origin, where the task was recorded; ``"com"``: its centre of mass)."""

    name: str
    wrench: np.ndarray
    about: str

    @property
    def of_task(self) -> bool:
        return self.name.startswith("task")

    def about_origin(self, origin: np.ndarray, com: np.ndarray) -> np.ndarray:
        """The wrench with its torque about the object frame's origin ``origin`` (world coordinates)."""
        if self.about == "frame":
            return self.wrench
        force = self.wrench[:3]
        return np.concatenate([force, self.wrench[3:] + np.cross(com - origin, force)])

    def grip_n(self, contacts: np.ndarray, friction: float) -> float:
        """The normal force per finger that friction needs to carry this wrench: ``|f| / (mu b)`` for the
        force, and ``|tau| / (mu sum_j r_j)`` for the torque, ``r_j`` each contact's distance from the torque's
        axis through the task frame's origin (the spring controller's grip, raised with the load)."""
        force, torque = np.linalg.norm(self.wrench[:3]), np.linalg.norm(self.wrench[3:])
        grip = force / (friction * len(contacts))
        if torque > 0:
            levers = np.linalg.norm(np.cross(self.wrench[3:] / torque, contacts), axis=1)
            grip += torque / (friction * max(float(levers.sum()), 1e-6))
        return float(grip)


def task_tests(task: TaskModel) -> list[Test]:
    """``+-gamma_i u_i`` for each axis of the task ellipsoid, named ``task+u1`` ... ``task-u6``."""
    return [
        Test(f"task{'+-'[s]}u{i + 1}", (1.0 - 2.0 * s) * task.lengths[i] * task.axes[i], "frame")
        for i in range(len(task.lengths))
        for s in (0, 1)
    ]


def benchmark_tests(mass_kg: float, settings: PhysicsSettings) -> list[Test]:
    """DexGraspBench's force-closure test: forces of ``m a`` along -x, +x, -y, +y, -z, +z."""
    force = mass_kg * settings.benchmark_acceleration_m_s2
    tests = []
    for axis, label in enumerate("xyz"):
        for sign in (-1.0, 1.0):
            wrench = np.zeros(6)
            wrench[axis] = sign * force
            tests.append(Test(f"dexgraspbench{'-+'[sign > 0]}{label}", wrench, "com"))
    return tests
