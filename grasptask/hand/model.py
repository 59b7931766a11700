"""Hand models loaded from YAML (``configs/hands/*.yaml``), validated once here."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from grasptask.errors import BadInputError
from grasptask.io.config import load_yaml, reject_unknown, require
from grasptask.paths import DEFAULT_HAND


@dataclass(frozen=True)
class Joint:
    """A revolute joint: rotation about ``axis`` (frame of the link before it), then a link along its own x."""

    name: str
    axis: np.ndarray
    lower: float  # rad
    upper: float  # rad
    link: float  # m
    coupled_to: str | None = None
    ratio: float = 1.0


@dataclass(frozen=True)
class Finger:
    name: str
    base_position: np.ndarray
    base_rotation: np.ndarray
    radius: float
    pad_along: float
    sample_fractions: tuple[float, ...]
    distal_sample_fractions: tuple[float, ...]
    joints: tuple[Joint, ...]
    muscles: tuple[str, ...]
    moment_arms: np.ndarray  # (joints, muscles), m
    max_forces: np.ndarray  # (muscles,), N

    @property
    def n_joints(self) -> int:
        return len(self.joints)

    @property
    def lower(self) -> np.ndarray:
        return np.array([j.lower for j in self.joints])

    @property
    def upper(self) -> np.ndarray:
        return np.array([j.upper for j in self.joints])

    @property
    def torque_map(self) -> np.ndarray:
        """``M P``: joint torques (N.m) per unit activation of each muscle (eq. 1)."""
        return self.moment_arms * self.max_forces


@dataclass(frozen=True)
class Palm:
    radius: float
    points: np.ndarray  # (k, 3) collision sample centres in the palm frame


@dataclass(frozen=True)
class Hand:
    name: str
    fingers: dict[str, Finger]
    palm: Palm
    grasping: tuple[str, ...]
    sources: dict[str, str] = field(default_factory=dict)

    @property
    def joint_names(self) -> list[str]:
        return [j.name for f in self.fingers.values() for j in f.joints]

    @property
    def n_joints(self) -> int:
        return sum(f.n_joints for f in self.fingers.values())

    def slices(self) -> dict[str, slice]:
        """Each finger's columns in a joint vector ordered as :attr:`joint_names`."""
        out, start = {}, 0
        for name, finger in self.fingers.items():
            out[name] = slice(start, start + finger.n_joints)
            start += finger.n_joints
        return out

    def subset(self, names: Iterable[str]) -> Hand:
        """The same hand with only the named fingers (in the given order), e.g. the grasping fingers."""
        names = list(names)
        unknown = [n for n in names if n not in self.fingers]
        if unknown:
            raise KeyError(f"no finger '{unknown[0]}' in hand '{self.name}'")
        return Hand(self.name, {n: self.fingers[n] for n in names}, self.palm, tuple(names), self.sources)

    def grasping_hand(self) -> Hand:
        return self.subset(self.grasping)

    @property
    def lower(self) -> np.ndarray:
        return np.concatenate([f.lower for f in self.fingers.values()])

    @property
    def upper(self) -> np.ndarray:
        return np.concatenate([f.upper for f in self.fingers.values()])

    def mid_range(self) -> np.ndarray:
        """Joint angles halfway between the limits, with the coupling applied."""
        return self.apply_coupling(0.5 * (self.lower + self.upper))

    def couplings(self) -> list[tuple[int, int, float]]:
        """``(dependent, independent, ratio)`` joint indices: ``q[dependent] = ratio * q[independent]``."""
        index = {n: i for i, n in enumerate(self.joint_names)}
        out = []
        for finger in self.fingers.values():
            for joint in finger.joints:
                if joint.coupled_to is not None:
                    out.append((index[joint.name], index[joint.coupled_to], joint.ratio))
        return out

    def apply_coupling(self, q: np.ndarray) -> np.ndarray:
        q = np.array(q, dtype=float, copy=True)
        for dependent, independent, ratio in self.couplings():
            q[..., dependent] = ratio * q[..., independent]
        return q


def _unit(vector, source, name) -> np.ndarray:
    v = np.asarray(vector, dtype=float)
    if v.shape != (3,) or not np.isfinite(v).all() or np.linalg.norm(v) < 1e-9:
        raise BadInputError(source, f"field '{name}' must be a non-zero 3-vector, got {vector!r}")
    return v / np.linalg.norm(v)


def _base_rotation(base: dict, source: Path, finger: str) -> np.ndarray:
    x = _unit(base.get("x", [1, 0, 0]), source, f"fingers.{finger}.base.x")
    z = _unit(base.get("z", [0, 0, 1]), source, f"fingers.{finger}.base.z")
    z = z - (z @ x) * x
    if np.linalg.norm(z) < 1e-6:
        raise BadInputError(source, f"fields 'fingers.{finger}.base.x' and '.z' are parallel")
    z /= np.linalg.norm(z)
    return np.column_stack([x, np.cross(z, x), z])


def _tendons(data: dict, finger: str, joints: tuple[Joint, ...], source: Path):
    tables = data.get("tendons", {})
    table = tables.get(finger)
    if table is None:
        raise BadInputError(source, f"missing tendon table 'tendons.{finger}'")
    if "same_as" in table:
        table = tables.get(table["same_as"], {})
    muscles = table.get("muscles")
    if not isinstance(muscles, dict) or not muscles:
        raise BadInputError(source, f"tendon table for '{finger}' lists no muscles")
    arms, forces = [], []
    for name, muscle in muscles.items():
        row = np.asarray(muscle.get("arms_mm", []), dtype=float)
        if row.shape != (len(joints),):
            raise BadInputError(source, f"muscle '{finger}.{name}' needs {len(joints)} moment arms, got {len(row)}")
        force = float(muscle.get("max_force_n", -1))
        if not force > 0:
            raise BadInputError(source, f"muscle '{finger}.{name}' needs a positive max_force_n")
        arms.append(row * 1e-3)
        forces.append(force)
    return tuple(muscles), np.array(arms).T, np.array(forces)


def load_hand(path: str | Path = DEFAULT_HAND) -> Hand:
    path = Path(path)
    data = load_yaml(path)
    reject_unknown(
        data, {"name", "hand_length_m", "grasping_fingers", "palm", "fingers", "tendons", "coupling_source"}, path
    )
    fingers = {}
    for name, spec in require(data, "fingers", path, dict).items():
        joints = []
        for k, j in enumerate(require(spec, "joints", path, list)):
            where = f"fingers.{name}.joints[{k + 1}]"
            for key in ("name", "axis", "min_deg", "max_deg"):
                if key not in j:
                    raise BadInputError(path, f"missing field '{where}.{key}'")
            lower, upper = np.deg2rad(float(j["min_deg"])), np.deg2rad(float(j["max_deg"]))
            if not lower < upper:
                raise BadInputError(path, f"field '{where}': min_deg must be below max_deg")
            joints.append(
                Joint(
                    name=str(j["name"]),
                    axis=_unit(j["axis"], path, f"{where}.axis"),
                    lower=lower,
                    upper=upper,
                    link=float(j.get("link_m", 0.0)),
                    coupled_to=j.get("coupled_to"),
                    ratio=float(j.get("ratio", 1.0)),
                )
            )
        names = {j.name for j in joints}
        for j in joints:
            if j.coupled_to is not None and j.coupled_to not in names:
                raise BadInputError(path, f"joint '{j.name}' is coupled to unknown joint '{j.coupled_to}'")
        base = require(spec, "base", path, dict)
        muscles, arms, forces = _tendons(data, name, tuple(joints), path)
        fingers[name] = Finger(
            name=name,
            base_position=np.asarray(base["position_m"], dtype=float),
            base_rotation=_base_rotation(base, path, name),
            radius=float(require(spec, "radius_m", path, (int, float))),
            pad_along=float(spec.get("pad_along", 0.65)),
            sample_fractions=tuple(spec.get("sample_fractions", [0.0, 0.35, 0.7])),
            distal_sample_fractions=tuple(spec.get("distal_sample_fractions", [0.0, 0.3])),
            joints=tuple(joints),
            muscles=muscles,
            moment_arms=arms,
            max_forces=forces,
        )
    palm = require(data, "palm", path, dict)
    (x0, x1), (y0, y1) = palm["x_range_m"], palm["y_range_m"]
    xs = np.linspace(float(x0), float(x1), int(palm["grid"][0]))
    ys = np.linspace(float(y0), float(y1), int(palm["grid"][1]))
    points = np.array([[x, y, 0.0] for x in xs for y in ys])
    grasping = tuple(data.get("grasping_fingers", list(fingers)))
    for name in grasping:
        if name not in fingers:
            raise BadInputError(path, f"grasping finger '{name}' is not defined")
    sources = {name: str(t.get("source", "")) for name, t in data.get("tendons", {}).items()}
    return Hand(str(data.get("name", path.stem)), fingers, Palm(float(palm["radius_m"]), points), grasping, sources)
