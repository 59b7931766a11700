"""The physics check: a second judge, separate from the analytic verifier, that holds each grasp in
MuJoCo against its own task's wrenches."""

from grasptask.physics.protocol import PhysicsResult, check_grasp, hold_grasp
from grasptask.physics.scene import Scene, build_scene
from grasptask.physics.settings import PhysicsSettings, load_physics_settings

__all__ = [
    "PhysicsResult",
    "PhysicsSettings",
    "Scene",
    "build_scene",
    "check_grasp",
    "hold_grasp",
    "load_physics_settings",
]
