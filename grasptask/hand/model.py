"""Hand models loaded from YAML (``configs/hands/*.yaml``), validated once here."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from grasptask.errors import BadInputError
from grasptask.io.config import load_yaml, number, numbers, reject_unknown, require, whole
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


def _unit(vector: Any, source: Path, name: str) -> np.ndarray:
    v = numbers(vector, source, name, 3)
    if np.linalg.norm(v) < 1e-9:
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
    if not isinstance(tables, dict):
        raise BadInputError(source, "field 'tendons' must be a mapping of tendon tables")
    table = tables.get(finger)
    if table is None:
        raise BadInputError(source, f"missing tendon table 'tendons.{finger}'")
    if isinstance(table, dict) and "same_as" in table:
        table = tables.get(table["same_as"], {})
    muscles = table.get("muscles") if isinstance(table, dict) else None
    if not isinstance(muscles, dict) or not muscles:
        raise BadInputError(source, f"tendon table for '{finger}' lists no muscles")
    arms, forces = [], []
    for name, muscle in muscles.items():
        where = f"tendons.{finger}.muscles.{name}"
        if not isinstance(muscle, dict):
            raise BadInputError(source, f"field '{where}' must be a mapping with arms_mm and max_force_n")
        arms.append(numbers(muscle.get("arms_mm"), source, f"{where}.arms_mm", len(joints)) * 1e-3)
        forces.append(number(muscle.get("max_force_n"), source, f"{where}.max_force_n", positive=True))
    return tuple(muscles), np.array(arms).T, np.array(forces)


def _joint(spec: Any, source: Path, where: str) -> Joint:
    if not isinstance(spec, dict):
        raise BadInputError(source, f"field '{where}' must be a mapping")
    for key in ("name", "axis", "min_deg", "max_deg"):
        if key not in spec:
            raise BadInputError(source, f"missing field '{where}.{key}'")
    lower = np.deg2rad(number(spec["min_deg"], source, f"{where}.min_deg"))
    upper = np.deg2rad(number(spec["max_deg"], source, f"{where}.max_deg"))
    if not lower < upper:
        raise BadInputError(source, f"field '{where}': min_deg must be below max_deg")
    coupled = spec.get("coupled_to")
    return Joint(
        name=str(spec["name"]),
        axis=_unit(spec["axis"], source, f"{where}.axis"),
        lower=float(lower),
        upper=float(upper),
        link=number(spec.get("link_m", 0.0), source, f"{where}.link_m", minimum=0.0),
        coupled_to=None if coupled is None else str(coupled),
        ratio=number(spec.get("ratio", 1.0), source, f"{where}.ratio"),
    )


def _finger(data: dict, name: str, spec: Any, source: Path) -> Finger:
    where = f"fingers.{name}"
    if not isinstance(spec, dict):
        raise BadInputError(source, f"field '{where}' must be a mapping")
    joints = tuple(
        _joint(j, source, f"{where}.joints[{k + 1}]") for k, j in enumerate(require(spec, "joints", source, list))
    )
    if not any(j.link > 0 for j in joints):
        raise BadInputError(source, f"field '{where}.joints': no joint has a link (link_m > 0) to carry the pad")
    names = {j.name for j in joints}
    for j in joints:
        if j.coupled_to is not None and j.coupled_to not in names:
            raise BadInputError(source, f"joint '{j.name}' is coupled to unknown joint '{j.coupled_to}'")
    base = require(spec, "base", source, dict)
    muscles, arms, forces = _tendons(data, name, joints, source)

    def fractions(key: str, default: list[float]) -> tuple[float, ...]:
        return tuple(numbers(spec.get(key, default), source, f"{where}.{key}"))

    return Finger(
        name=name,
        base_position=numbers(base.get("position_m"), source, f"{where}.base.position_m", 3),
        base_rotation=_base_rotation(base, source, name),
        radius=number(spec.get("radius_m"), source, f"{where}.radius_m", positive=True),
        pad_along=number(spec.get("pad_along", 0.65), source, f"{where}.pad_along", minimum=0.0),
        sample_fractions=fractions("sample_fractions", [0.0, 0.35, 0.7]),
        distal_sample_fractions=fractions("distal_sample_fractions", [0.0, 0.3]),
        joints=joints,
        muscles=muscles,
        moment_arms=arms,
        max_forces=forces,
    )


def _palm(data: dict, source: Path) -> Palm:
    palm = require(data, "palm", source, dict)
    x0, x1 = numbers(palm.get("x_range_m"), source, "palm.x_range_m", 2)
    y0, y1 = numbers(palm.get("y_range_m"), source, "palm.y_range_m", 2)
    grid = palm.get("grid")
    if not isinstance(grid, list) or len(grid) != 2:
        raise BadInputError(source, f"field 'palm.grid' must be two whole numbers, got {grid!r}")
    nx, ny = (whole(g, source, f"palm.grid[{k + 1}]", minimum=1) for k, g in enumerate(grid))
    points = np.array([[x, y, 0.0] for x in np.linspace(x0, x1, nx) for y in np.linspace(y0, y1, ny)])
    return Palm(number(palm.get("radius_m"), source, "palm.radius_m", positive=True), points)


def load_hand(path: str | Path = DEFAULT_HAND) -> Hand:
    """A hand from its YAML, every field checked: a one-line error names the field at fault."""
    path = Path(path)
    data = load_yaml(path)
    reject_unknown(
        data, {"name", "hand_length_m", "grasping_fingers", "palm", "fingers", "tendons", "coupling_source"}, path
    )
    fingers = {
        str(name): _finger(data, str(name), spec, path) for name, spec in require(data, "fingers", path, dict).items()
    }
    grasping = data.get("grasping_fingers", list(fingers))
    if not isinstance(grasping, list) or not grasping:
        raise BadInputError(path, f"field 'grasping_fingers' must be a list of finger names, got {grasping!r}")
    for name in grasping:
        if name not in fingers:
            raise BadInputError(path, f"grasping finger '{name}' is not defined")
    tendons = data.get("tendons", {})
    sources = {name: str(t.get("source", "")) for name, t in tendons.items() if isinstance(t, dict)}
    return Hand(str(data.get("name", path.stem)), fingers, _palm(data, path), tuple(grasping), sources)
