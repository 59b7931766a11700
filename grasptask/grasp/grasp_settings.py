"""Contact model and grasp requirements (``configs/grasp.yaml``): the schema, with every default, declared once
and shared as plain data by synthesis and the verifier."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

from pydantic import Field, Strict
from pydantic.dataclasses import dataclass

from grasptask.io.config_schema import SCHEMA, Flag, NonNegative, Positive, Share, load_yaml, validated
from grasptask.paths import DEFAULT_GRASP_CONFIG

#: the largest torsional friction a pad can have (m): see ``torsional_friction_m``
MAX_TORSIONAL_FRICTION_M = 0.05


@dataclass(frozen=True, config=SCHEMA)
class GraspSettings:
    """The contact model and the margin every task wrench is held with. The paper's own model is
    ``configs/grasp_paper.yaml``: four cone edges, no margin and a fixed pad point."""

    #: mu
    friction_coefficient: Positive = 0.5
    #: m, edges of the linearised friction cone (an octagon: within 8% of the round cone; 32 edges are within
    #: 0.5%, and the NLP grows with each)
    cone_edges: Annotated[int, Strict(), Field(ge=3, le=32)] = 8
    #: the largest angle between a fingertip pad's normal and the inward surface normal
    pad_angle_max_deg: Annotated[float, Strict(), Field(gt=0, le=90)] = 45.0
    #: epsilon in phi >= epsilon (eq. 4)
    force_closure_min_weight: NonNegative = 1e-3
    #: synthesis keeps activations this far below the cap, so that the verifier's own LP still finds every task
    #: wrench within reach
    activation_margin: NonNegative = 0.02
    #: the margin: every task wrench held with tendon activations at most this (1: none) ...
    activation_max: Share = 0.8
    #: ... with motor torques at most this share of their rating (a motor's torque is rated, a muscle's
    #: force estimated) ...
    motor_activation_max: Share = 0.9
    #: ... with forces inside cones of this times mu ...
    friction_scale: Share = 0.8
    #: ... and with at least this normal force at each contact (N)
    min_normal_force_n: NonNegative = 0.5
    #: contacts roll over the fingertip's sphere, sunk by the hand's compliance (false: a fixed pad point)
    rolling_contacts: Flag = True
    #: m, a flat pad's torsional friction: it resists a twist about the contact normal up to this times its
    #: normal force (the soft-finger contact of Salisbury and Mason; 0: point contacts only). 0.005 m is
    #: MuJoCo's default torsional friction (geom friction[1]), and mu L / 4 for a pad pressed along a line of
    #: L = 40 mm with mu = 0.5 and even pressure. A fingertip that is not flat is a point contact. At most
    #: 0.05 m: mu L / 4 of a pad 10 cm long with mu = 2, beyond any fingertip (1e6 ran a hopeless sweep)
    torsional_friction_m: Annotated[float, Strict(), Field(ge=0, le=MAX_TORSIONAL_FRICTION_M)] = 0.005

    def __post_init__(self) -> None:
        if self.activation_margin >= min(self.activation_max, self.motor_activation_max):
            raise ValueError("field 'activation_margin': must be below activation_max and motor_activation_max")

    def activation_cap(self, kind: str) -> float:
        """The margin's activation cap for a hand whose capability is of ``kind`` ("tendons", "motors" or a
        mix of both, which takes the lower)."""
        caps = {"tendons": self.activation_max, "motors": self.motor_activation_max}
        return caps.get(kind, min(caps.values()))


def load_grasp_settings(path: str | Path = DEFAULT_GRASP_CONFIG) -> GraspSettings:
    """The grasp config file at ``path``: only the keys it sets differ from :class:`GraspSettings`' defaults."""
    return validated(GraspSettings, load_yaml(path), path)
