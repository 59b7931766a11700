"""The physics check's scene, controller and protocol settings (``configs/physics.yaml``), read once."""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

from grasptask.errors import BadInputError
from grasptask.io.config import load_yaml, number, reject_unknown
from grasptask.paths import DEFAULT_PHYSICS_CONFIG


@dataclass(frozen=True)
class PhysicsSettings:
    """What the README's physics section justifies; the friction coefficient is the grasp config's own."""

    timestep_s: float = 0.001
    #: the object's mass when its config gives none (DexGraspBench's 100 g)
    object_mass_kg: float = 0.1
    #: MuJoCo's torsional friction coefficient (m): the radius of a fingertip's soft contact patch
    torsional_friction_m: float = 0.002
    #: the controller, before the projection onto the force capability: a spring on each fingertip pad ...
    tip_stiffness_n_per_m: float = 2000.0
    tip_damping_ns_per_m: float = 20.0
    #: ... whose rest point is this far inside the object along its inward normal (the squeeze) ...
    squeeze_m: float = 0.002
    #: ... deepened under each test wrench to give this multiple of the grip friction needs for it ...
    grip_safety: float = 1.5
    #: ... and a weak pull towards the synthesized posture
    posture_stiffness_nm_per_rad: float = 0.2
    posture_damping_nms_per_rad: float = 0.05
    #: reflected actuator inertia on every hand joint (kg m^2): keeps the stiff controller stable at the timestep
    armature_kg_m2: float = 1e-3
    control_period_s: float = 0.002
    settle_s: float = 0.3
    ramp_s: float = 0.2
    hold_s: float = 0.3
    #: a grasp passes when no test moves the object further than these from where the hand settled it
    max_translation_m: float = 0.005
    max_rotation_deg: float = 5.0
    #: DexGraspBench's six +-axis forces are this acceleration times the object's mass (its 10 m/s^2)
    benchmark_acceleration_m_s2: float = 10.0
    #: DexGraspBench's pass thresholds, reported beside ours
    benchmark_translation_m: float = 0.05
    benchmark_rotation_deg: float = 15.0


def load_physics_settings(path: str | Path = DEFAULT_PHYSICS_CONFIG) -> PhysicsSettings:
    data = load_yaml(path)
    reject_unknown(data, {f.name for f in fields(PhysicsSettings)}, path)
    settings = PhysicsSettings(**{key: number(value, path, key, positive=True) for key, value in data.items()})
    if settings.control_period_s < settings.timestep_s:
        raise BadInputError(path, "field 'control_period_s': must be at least timestep_s")
    return settings
