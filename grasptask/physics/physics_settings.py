"""The physics check's scene, controller and protocol settings (``configs/physics.yaml``), read once."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal, get_args

from pydantic import Field, Strict
from pydantic.dataclasses import dataclass

from grasptask.io.config_schema import SCHEMA, Positive, Share, load_yaml, validated
from grasptask.paths import DEFAULT_PHYSICS_CONFIG

#: a phase of the protocol lasts at most this long: a grasp that holds is simulated to its end, so an hour-long
#: hold (``hold_s: 1.0e6``) would run for ever; seconds of simulated time say all a hold can say
MAX_PHASE_S = 10.0
Phase = Annotated[float, Strict(), Field(gt=0, le=MAX_PHASE_S)]
#: MuJoCo's step is at least this: a smaller one costs hours a grasp and says nothing more
MIN_TIMESTEP_S = 1e-5

Controller = Literal["grip", "spring"]
CONTROLLERS: tuple[str, ...] = get_args(Controller)


@dataclass(frozen=True, config=SCHEMA)
class PhysicsSettings:
    """The physics check's settings, every default declared here once (why each is so: docs/design/physics.md);
    the friction coefficient is the grasp config's own. Every number is positive."""

    #: "grip" (contact forces from a QP over MuJoCo's contacts) or "spring" (a spring on each synthesized pad)
    controller: Controller = "grip"
    #: MuJoCo's step (s)
    timestep_s: Annotated[float, Strict(), Field(ge=MIN_TIMESTEP_S, le=0.01)] = 0.001
    #: the object's mass when its config gives none (DexGraspBench's 100 g)
    object_mass_kg: Positive = 0.1
    #: MuJoCo's torsional friction coefficient (m): the radius of a fingertip's soft contact patch
    torsional_friction_m: Positive = 0.002
    #: the grip controller: the least normal force on each hand link in contact, and on a closing fingertip ...
    min_normal_force_n: Positive = 0.5
    #: ... raised from 0 over this time while the hand closes ...
    closing_s: Phase = 0.1
    #: ... the part of the friction cone its forces may use ...
    grip_friction_fraction: Share = 0.8
    #: ... and the impedance on the object's pose error from where the grasp settled
    object_stiffness_n_per_m: Positive = 300.0
    #: ... and on its velocity
    object_damping_ns_per_m: Positive = 5.0
    #: the object's impedance on its rotation error ...
    object_rotational_stiffness_nm_per_rad: Positive = 1.0
    #: ... and on its angular velocity
    object_rotational_damping_nms_per_rad: Positive = 0.01
    #: the spring controller: a spring on each fingertip pad ...
    tip_stiffness_n_per_m: Positive = 2000.0
    #: ... its damping ...
    tip_damping_ns_per_m: Positive = 20.0
    #: ... whose rest point is this far inside the object along its inward normal (the squeeze) ...
    squeeze_m: Positive = 0.002
    #: ... deepened under each test wrench to give this multiple of the grip friction needs for it ...
    grip_safety: Positive = 1.5
    #: ... and a weak pull towards the synthesized posture
    posture_stiffness_nm_per_rad: Positive = 0.2
    #: viscous damping of every hand joint, in the scene itself (MuJoCo integrates it implicitly, so a finger
    #: that loses its contact between two control steps cannot run away)
    joint_damping_nms_per_rad: Positive = 0.05
    #: reflected actuator inertia on every hand joint (kg m^2): keeps the stiff controller stable at the timestep
    armature_kg_m2: Positive = 1e-3
    #: the controller's period (s): 100 Hz
    control_period_s: Phase = 0.01
    #: closing and settling (s)
    settle_s: Phase = 0.3
    #: each test wrench ramped in over this time (s) ...
    ramp_s: Phase = 0.2
    #: ... then held for this time (s)
    hold_s: Phase = 0.3
    #: a grasp passes when no test moves the object further than these from where the hand settled it
    max_translation_m: Positive = 0.005
    #: ... nor turns it further than this
    max_rotation_deg: Positive = 5.0
    #: DexGraspBench's six +-axis forces are this acceleration times the object's mass (its 10 m/s^2)
    benchmark_acceleration_m_s2: Positive = 10.0
    #: DexGraspBench's pass thresholds, reported beside ours
    benchmark_translation_m: Positive = 0.05
    #: ... and rotation
    benchmark_rotation_deg: Positive = 15.0

    def __post_init__(self) -> None:
        if self.control_period_s < self.timestep_s:
            raise ValueError("field 'control_period_s': must be at least timestep_s")


def load_physics_settings(path: str | Path = DEFAULT_PHYSICS_CONFIG) -> PhysicsSettings:
    """The physics config file at ``path``: only the keys it sets differ from :class:`PhysicsSettings`'
    defaults."""
    return validated(PhysicsSettings, load_yaml(path), path)
