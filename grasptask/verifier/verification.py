"""What the verifier decides and measures: its acceptance thresholds, and the verdict on one grasp with every
figure its checks measured."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np


@dataclass(frozen=True)
class Tolerances:
    """Every acceptance threshold of the verifier, in one place."""

    contact_distance_m: float = 1e-3  # |distance from a pad point to the surface| (a sphere's centre: minus its offset)
    joint_limit_rad: float = 1e-4  # how far a joint may sit beyond a limit
    coupling_rad: float = 1e-3  # |theta_DIP - k theta_PIP|
    joint_limit_m: float = 1e-5  # the same two for a sliding joint (a gripper's jaw)
    coupling_m: float = 1e-5
    rotation: float = 1e-6  # |R^T R - I| and |det R - 1|
    clearance_m: float = -1e-3  # signed distance minus radius (plus a rolling fingertip's compliance), every sphere
    pad_angle_slack_deg: float = 1.0  # on top of the configured bound
    epsilon_min: float = 1e-6  # Ferrari-Canny epsilon (torques divided by the characteristic length)
    rank_rtol: float = 1e-8  # relative singular value threshold for the rank condition of eq. 9
    effort_slack: float = 1e-6  # how far the activations the task wrenches need may exceed the margin's cap
    # how far the hand's true geometry may sink beyond its compliance: a mesh's surrogate, which the NLP holds the
    # fingertips to, misses the triangles by up to half a millimetre (0.2-0.3 mm at the mug's contacts)
    penetration_m: float = 5e-4
    # how far outside a mesh fingertip's own triangles its contact may lie (where the pad sphere fits the mesh,
    # the contact lies the compliance inside it)
    fingertip_m: float = 5e-4


@dataclass(frozen=True)
class WrenchLoad:
    """How the grasp applies one task wrench in the verifier's LP (the solution of least peak activation, one
    of many): the force each contact pushes on the object with (N, object frame), the joint torques that
    balance them (N.m, the grasping joints' order) and the actuators' activations in [0, 1]."""

    wrench: np.ndarray  # (6,): force (N) and torque (N.m) on the object
    contact_forces: np.ndarray  # (b, 3)
    joint_torques: np.ndarray  # (n,)
    activations: np.ndarray  # (actuators,)


@dataclass
class Verification:
    contact_distance_m: np.ndarray
    joint_limit_margin_deg: float
    coupling_error_deg: float
    rotation_error: float
    min_clearance_m: float
    #: how deep the hand's true collision geometry (every link, the fingertips included) sinks into the object
    penetration_m: float
    pad_angle_deg: np.ndarray
    #: how far each contact lies outside its fingertip's own collision mesh, negative inside (NaN: a sphere or
    #: capsule tip)
    fingertip_gap_m: np.ndarray
    epsilon: float
    internal_force_rank: int
    internal_force_dim: int
    torque_effort: float
    Q: float
    #: the largest scale of the task's wrenches held at the hand's real strength and mu (1: at the edge)
    strength_margin: float
    #: the smallest mu that holds every task wrench at the real strength
    friction_margin: float
    contacts: np.ndarray = field(repr=False)
    normals: np.ndarray = field(repr=False)
    failures: list[str] = field(default_factory=list)
    #: the LP's solution behind ``torque_effort``, one per task wrench (empty when some wrench is infeasible)
    loads: list[WrenchLoad] = field(default_factory=list, repr=False)

    @property
    def ok(self) -> bool:
        return not self.failures

    def record(self, fingers: list[str]) -> dict:
        """Flat columns for a table (``verify_*``), one value per finger where there is one per finger."""
        out = {"verified": self.ok, "verify_failures": ";".join(self.failures)}
        for key, value in asdict(self).items():
            if key in ("contacts", "normals", "failures", "loads"):
                continue
            if isinstance(value, np.ndarray):
                for name, v in zip(fingers, value, strict=True):
                    out[f"verify_{key}_{name}"] = float(v)
            else:
                out[f"verify_{key}"] = value
        return out
