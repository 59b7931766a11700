"""Where a traced check shows most: the phase that dropped the grasp (else its worst phase of the task's, the
settling included), the moment in it where the object was furthest from its start against the thresholds, and
the hand and object there; that phase filmed (:mod:`grasptask.physics.film`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from grasptask.physics.physics_settings import PhysicsSettings
from grasptask.physics.protocol import PhysicsResult
from grasptask.physics.scene import Scene

if TYPE_CHECKING:
    from grasptask.physics.judge import Holding

#: the film's view: this many times the farthest contact from the grasp's middle, and no nearer than this (m)
VIEW_SPAN, NEAREST_VIEW_M = 6.0, 0.3


def _share(result: PhysicsResult, phase: str, settings: PhysicsSettings) -> np.ndarray:
    """A phase's motion at each step as a share of the thresholds (the larger of translation and rotation)."""
    trace = result.traces[phase]
    return np.maximum(trace.translation_m / settings.max_translation_m, trace.rotation_deg / settings.max_rotation_deg)


def worst_moment(scene: Scene, result: PhysicsResult, settings: PhysicsSettings) -> dict[str, Any]:
    """The phase and the step a picture of the check shows, with the object's pose (world frame: position, then
    quaternion w x y z) and the hand's joint angles (the hand model's ``joint_names`` order) there."""
    phases = [p for p in result.traces if not p.startswith("dexgraspbench")]
    phase = result.failed_test or max(phases, key=lambda p: float(_share(result, p, settings).max(initial=0.0)))
    step = int(np.argmax(_share(result, phase, settings)))
    trace = result.traces[phase]
    return {
        "phase": phase,
        "held": result.passed,
        "time_s": float(trace.time_s[step]),
        "translation_m": float(trace.translation_m[step]),
        "rotation_deg": float(trace.rotation_deg[step]),
        "object_pose": [float(v) for v in trace.object_pose[step]],
        "joint_angles": [float(v) for v in scene.to_hand(trace.joints[step])],
    }


def film_of(scene: Scene, result: PhysicsResult, phase: str, holding: Holding) -> bytes | None:
    """``phase`` of the check as a GIF, seen from beside the grasp (None: no offscreen rendering)."""
    from grasptask.physics.film import film, offscreen_unavailable
    from grasptask.physics.scene_file import scene_files

    if offscreen_unavailable() is not None:
        return None
    trace = result.traces[phase]
    start = result.start_state if phase == "settle" else result.settled_state
    qpos = np.repeat(start["qpos"][None], len(trace.time_s), axis=0)
    qpos[:, scene.hand_qpos] = trace.joints
    qpos[:, scene.object_qpos : scene.object_qpos + 7] = trace.object_pose
    middle = scene.contacts.mean(axis=0)
    distance = max(VIEW_SPAN * float(np.linalg.norm(scene.contacts - middle, axis=1).max()), NEAREST_VIEW_M)
    files = scene_files(scene, result, holding.obj.picture(4000), holding.settings)
    return film(files, qpos, middle, distance)
