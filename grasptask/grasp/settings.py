"""Contact model and grasp requirements (``configs/grasp.yaml``), read once and shared as plain data."""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

from grasptask.errors import BadInputError
from grasptask.io.config import load_yaml, number, reject_unknown, whole
from grasptask.paths import DEFAULT_GRASP_CONFIG


@dataclass(frozen=True)
class GraspSettings:
    friction_coefficient: float = 0.5
    cone_edges: int = 8
    pad_angle_max_deg: float = 45.0
    force_closure_min_weight: float = 1e-3
    activation_margin: float = 0.02
    #: the margin every task wrench is held with, by synthesis and the verifier alike: activations at most
    #: activation_max (motor_activation_max for a hand driven by motors), forces inside cones of friction_scale
    #: mu, and at least min_normal_force_n at each contact
    activation_max: float = 0.8
    #: a motor's torque is rated, a muscle's force estimated: at 0.9 physics held 95-100% of the Allegro's and
    #: the BarrettHand's verified grasps, the human hand's screw driving 71% (docs/margins.md)
    motor_activation_max: float = 0.9
    friction_scale: float = 0.8
    min_normal_force_n: float = 0.5
    #: contacts roll over the fingertip's sphere, sunk by the hand's compliance (False: a fixed pad point, the
    #: paper's model)
    rolling_contacts: bool = True

    def activation_cap(self, kind: str) -> float:
        """The margin's activation cap for a hand whose capability is of ``kind`` ("tendons", "motors" or a
        mix of both, which takes the lower)."""
        caps = {"tendons": self.activation_max, "motors": self.motor_activation_max}
        return caps.get(kind, min(caps.values()))


def load_grasp_settings(path: str | Path = DEFAULT_GRASP_CONFIG) -> GraspSettings:
    data = load_yaml(path)
    names = {f.name for f in fields(GraspSettings)}
    reject_unknown(data, names, path)
    values: dict[str, float | int | bool] = {}
    for key, value in data.items():
        if isinstance(getattr(GraspSettings, key), bool):
            if not isinstance(value, bool):
                raise BadInputError(path, f"field '{key}': must be true or false, got {value!r}")
            values[key] = value
        elif isinstance(getattr(GraspSettings, key), int):
            values[key] = whole(value, path, key)
        else:
            values[key] = number(value, path, key, minimum=0.0)
    settings = GraspSettings(**values)  # type: ignore[arg-type]
    if settings.friction_coefficient <= 0 or settings.cone_edges < 3 or not 0 < settings.pad_angle_max_deg <= 90:
        raise BadInputError(path, "need friction_coefficient > 0, cone_edges >= 3 and 0 < pad_angle_max_deg <= 90")
    for key in ("activation_max", "motor_activation_max", "friction_scale"):
        if not 0 < getattr(settings, key) <= 1:
            raise BadInputError(path, f"field '{key}': must be in (0, 1], got {getattr(settings, key)}")
    if settings.activation_margin >= min(settings.activation_max, settings.motor_activation_max):
        raise BadInputError(path, "field 'activation_margin': must be below activation_max and motor_activation_max")
    return settings
