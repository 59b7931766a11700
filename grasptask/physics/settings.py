"""The physics check's scene, controller and protocol settings (``configs/physics.yaml``), read once."""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

from grasptask.errors import BadInputError
from grasptask.io.config import load_yaml, number, reject_unknown
from grasptask.paths import DEFAULT_PHYSICS_CONFIG

CONTROLLERS = ("grip", "spring")


@dataclass(frozen=True)
class PhysicsSettings:
    """What the README's physics section justifies; the friction coefficient is the grasp config's own."""

    #: "grip" (contact forces from a QP over MuJoCo's contacts) or "spring" (a spring on each synthesized pad)
    controller: str = "grip"
    timestep_s: float = 0.001
    #: the object's mass when its config gives none (DexGraspBench's 100 g)
    object_mass_kg: float = 0.1
    #: MuJoCo's torsional friction coefficient (m): the radius of a fingertip's soft contact patch
    torsional_friction_m: float = 0.002
    #: the grip controller: the least normal force on each hand link in contact, and on a closing fingertip ...
    min_normal_force_n: float = 0.5
    #: ... raised from 0 over this time while the hand closes ...
    closing_s: float = 0.1
    #: ... the part of the friction cone its forces may use ...
    grip_friction_fraction: float = 0.8
    #: ... and the impedance on the object's pose error from where the grasp settled
    object_stiffness_n_per_m: float = 300.0
    object_damping_ns_per_m: float = 5.0
    object_rotational_stiffness_nm_per_rad: float = 1.0
    object_rotational_damping_nms_per_rad: float = 0.01
    #: the spring controller: a spring on each fingertip pad ...
    tip_stiffness_n_per_m: float = 2000.0
    tip_damping_ns_per_m: float = 20.0
    #: ... whose rest point is this far inside the object along its inward normal (the squeeze) ...
    squeeze_m: float = 0.002
    #: ... deepened under each test wrench to give this multiple of the grip friction needs for it ...
    grip_safety: float = 1.5
    #: ... and a weak pull towards the synthesized posture
    posture_stiffness_nm_per_rad: float = 0.2
    #: viscous damping of every hand joint, in the scene itself (MuJoCo integrates it implicitly, so a finger
    #: that loses its contact between two control steps cannot run away)
    joint_damping_nms_per_rad: float = 0.05
    #: reflected actuator inertia on every hand joint (kg m^2): keeps the stiff controller stable at the timestep
    armature_kg_m2: float = 1e-3
    control_period_s: float = 0.01
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
    controller = data.pop("controller", PhysicsSettings.controller)
    if controller not in CONTROLLERS:
        raise BadInputError(path, f"field 'controller': must be one of {', '.join(CONTROLLERS)}, got {controller!r}")
    values = {key: number(value, path, key, positive=True) for key, value in data.items()}
    settings = PhysicsSettings(controller=controller, **values)
    if settings.grip_friction_fraction > 1:
        raise BadInputError(path, "field 'grip_friction_fraction': must be at most 1 (the whole cone)")
    if settings.control_period_s < settings.timestep_s:
        raise BadInputError(path, "field 'control_period_s': must be at least timestep_s")
    return settings
