"""The schemas of a hand YAML, every key, default and check declared once: the project's own hand model
(:class:`HandConfig`, ``configs/hands/human.yaml``) and a YAML that adds to a URDF or MJCF file what the file
cannot say (:class:`ModelHandConfig`, ``model: FILE``)."""

from __future__ import annotations

from dataclasses import field
from typing import Annotated

from pydantic import Field, Strict
from pydantic.dataclasses import dataclass

from grasptask.hand.hand_model import DEFAULT_COMPLIANCE_M
from grasptask.io.config_schema import SCHEMA, NonNegative, Positive, Real, Text, Vector

Names = Annotated[list[Text], Field(min_length=1)]
#: a sample's place along a link, as a fraction of its length
Along = Annotated[float, Strict(), Field(ge=0, le=1)]


@dataclass(frozen=True, config=SCHEMA)
class JointConfig:
    """A revolute joint: it turns about ``axis`` (in the frame of the link before it), then the link after it
    extends ``link_m`` along its own x."""

    name: Text
    axis: Vector
    min_deg: Real
    max_deg: Real
    link_m: NonNegative = 0.0
    #: a joint that follows another: q = ratio q_master
    coupled_to: Text | None = None
    ratio: Real = 1.0
    #: where the values come from
    source: str = ""

    def __post_init__(self) -> None:
        if not self.min_deg < self.max_deg:
            raise ValueError(f"min_deg ({self.min_deg}) must be below max_deg ({self.max_deg})")


@dataclass(frozen=True, config=SCHEMA)
class BaseConfig:
    """Where a finger's first joint sits in the palm frame, and the directions of its first link (x) and its
    pad (z, made orthogonal to x)."""

    position_m: Vector
    x: Vector = (1.0, 0.0, 0.0)
    z: Vector = (0.0, 0.0, 1.0)


@dataclass(frozen=True, config=SCHEMA)
class FingerConfig:
    #: the finger's radius: its collision spheres' and its fingertip pad's
    radius_m: Positive
    base: BaseConfig
    joints: Annotated[list[JointConfig], Field(min_length=1)]
    #: the pad on the distal link at this fraction of its length
    pad_along: NonNegative = 0.65
    #: collision spheres along each link, as fractions of its length ...
    sample_fractions: tuple[Along, ...] = (0.0, 0.35, 0.7)
    #: ... and along the distal link
    distal_sample_fractions: tuple[Along, ...] = (0.0, 0.3)


@dataclass(frozen=True, config=SCHEMA)
class MuscleConfig:
    max_force_n: Positive
    #: moment arm at each of the finger's joints, in the order of its joints (mm; 0 where it crosses none)
    arms_mm: tuple[Real, ...]
    source: str = ""


@dataclass(frozen=True, config=SCHEMA)
class TendonTable:
    """A finger's tendons (eq. 1), or ``same_as`` another finger's table."""

    muscles: dict[str, MuscleConfig] | None = None
    same_as: Text | None = None
    source: str = ""


@dataclass(frozen=True, config=SCHEMA)
class PalmConfig:
    """The palm as a slab in the x-y plane of the palm frame: collision points on a grid, each a sphere."""

    radius_m: Positive
    x_range_m: tuple[Real, Real]
    y_range_m: tuple[Real, Real]
    grid: tuple[Annotated[int, Strict(), Field(ge=1, le=50)], Annotated[int, Strict(), Field(ge=1, le=50)]]


@dataclass(frozen=True, config=SCHEMA)
class HandConfig:
    """The project's own hand YAML (``configs/hands/human.yaml``)."""

    fingers: Annotated[dict[str, FingerConfig], Field(min_length=1)]
    palm: PalmConfig
    tendons: dict[str, TendonTable]
    name: Text | None = None
    #: the hand length its segment lengths were scaled for (m), for the record
    hand_length_m: Positive | None = None
    #: the fingers that grasp (default: all)
    grasping_fingers: Names | None = None
    coupling_source: str = ""
    #: how far a fingertip's pulp gives at a contact (m)
    pad_compliance_m: NonNegative = DEFAULT_COMPLIANCE_M


@dataclass(frozen=True, config=SCHEMA)
class PadConfig:
    """A fingertip pad in its link's frame: its point, outward normal and first cone edge's direction."""

    point_m: Vector
    normal: Vector
    tangent: Vector
    #: the fingertip's radius of curvature, for the contact to roll over it (0: a fixed point)
    radius_m: NonNegative = 0.0
    #: a flat pad's face, its length along the tangent and its width across (m), centred on the point: the
    #: contact stays at the point and the face lies on the surface (a flat pad has no radius)
    flat_size_m: tuple[Positive, Positive] | None = None


@dataclass(frozen=True, config=SCHEMA)
class ApproachConfig:
    """The palm's approach direction (z, towards the object) and its x, in the palm frame."""

    z: Vector
    x: Vector | None = None


@dataclass(frozen=True, config=SCHEMA)
class ModelHandConfig:
    """A YAML that adds to a URDF or MJCF file (``model``, relative to the YAML) what the file cannot say."""

    #: the URDF or MJCF file, relative to this YAML
    model: Text
    #: what the report and the records call the hand (default: the model's name)
    name: Text | None = None
    description: str = ""
    #: the link the fingers start from (default: the link where the chains to the fingertips branch)
    palm_link: Text | None = None
    #: the angle (rad) a joint before the palm (a wrist) is held at (default: 0, or its nearest limit)
    held_joints: dict[str, Real] = field(default_factory=dict)
    #: one fingertip link per finger (default: the last link with collision geometry of each chain)
    fingertips: Names | None = None
    #: what the report and the records call each finger, in the order of fingertips
    finger_names: Names | None = None
    #: the fingers that grasp (default: all)
    grasping_fingers: Names | None = None
    #: a pad per fingertip link, in place of the one fitted to its geometry
    pads: dict[str | int, PadConfig] = field(default_factory=dict)  # a link named 3 is written 3
    #: the palm's approach direction, {z: [...], x: [...]} in the palm frame (default: from the palm to the pads)
    approach: ApproachConfig | None = None
    #: where each value came from
    sources: dict[str, str] = field(default_factory=dict)
    #: how far a fingertip gives at a contact (m)
    compliance_m: NonNegative = DEFAULT_COMPLIANCE_M
    #: each motor's effort (N.m, or N for a sliding joint) by joint name or pattern (``finger_*_prox_joint``), in
    #: place of the file's: a joint's own name wins over a pattern, a later pattern over an earlier one
    efforts: dict[Text, Positive] = field(default_factory=dict)
    #: each joint's velocity limit (rad/s, or m/s), likewise, in place of the file's
    velocities: dict[Text, Positive] = field(default_factory=dict)
