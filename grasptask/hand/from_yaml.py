"""The project's own hand YAML (``configs/hands/human.yaml``): each finger a chain of joints from its base in the
palm, a joint turning about its axis and the link after it extending ``link_m`` along its own x, collision
spheres at fractions of each link, the pad on the distal link, and a tendon table per finger (eq. 1)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from grasptask.errors import BadInputError
from grasptask.hand import skin
from grasptask.hand.model import DEFAULT_COMPLIANCE_M, Capability, Finger, Hand, Joint, Pad, Palm, Skin, Sphere
from grasptask.io.config import number, numbers, reject_unknown, require, whole

TOP_FIELDS = {
    "name", "hand_length_m", "grasping_fingers", "palm", "fingers", "tendons", "coupling_source", "pad_compliance_m",
}  # fmt: skip


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


def _joint(spec: Any, source: Path, where: str) -> tuple[Joint, float]:
    """A joint and the length of the link after it."""
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
    joint = Joint(
        name=str(spec["name"]),
        axis=_unit(spec["axis"], source, f"{where}.axis"),
        lower=float(lower),
        upper=float(upper),
        coupled_to=None if coupled is None else str(coupled),
        ratio=number(spec.get("ratio", 1.0), source, f"{where}.ratio"),
    )
    return joint, number(spec.get("link_m", 0.0), source, f"{where}.link_m", minimum=0.0)


def _finger(data: dict, name: str, spec: Any, source: Path) -> Finger:
    where = f"fingers.{name}"
    if not isinstance(spec, dict):
        raise BadInputError(source, f"field '{where}' must be a mapping")
    parsed = [
        _joint(j, source, f"{where}.joints[{k + 1}]") for k, j in enumerate(require(spec, "joints", source, list))
    ]
    if not parsed or parsed[-1][1] <= 0:
        raise BadInputError(source, f"field '{where}.joints': the last joint must carry the distal link (link_m > 0)")
    names = {j.name for j, _ in parsed}
    for j, _ in parsed:
        if j.coupled_to is not None and j.coupled_to not in names:
            raise BadInputError(source, f"joint '{j.name}' is coupled to unknown joint '{j.coupled_to}'")
    base = require(spec, "base", source, dict)
    radius = number(spec.get("radius_m"), source, f"{where}.radius_m", positive=True)

    def fractions(key: str, default: list[float]) -> tuple[float, ...]:
        return tuple(numbers(spec.get(key, default), source, f"{where}.{key}"))

    along, at_distal = fractions("sample_fractions", [0.0, 0.35, 0.7]), fractions("distal_sample_fractions", [0.0, 0.3])
    # the link before joint k ends where joint k sits: along x of that link's frame
    joints, spheres = [], []
    for k, (joint, link) in enumerate(parsed):
        if k == 0:
            offset = numbers(base.get("position_m"), source, f"{where}.base.position_m", 3)
            joint = replace(joint, offset=offset, rotation=_base_rotation(base, source, name))
        else:
            joint = replace(joint, offset=np.array([parsed[k - 1][1], 0.0, 0.0]))
        joints.append(joint)
        if link > 0:
            for f in at_distal if k == len(parsed) - 1 else along:
                spheres.append(Sphere(k, np.array([f * link, 0.0, 0.0]), radius))
    distal = parsed[-1][1]
    pad_along = number(spec.get("pad_along", 0.65), source, f"{where}.pad_along", minimum=0.0)
    # the pad is the distal link's skin over its axis: a sphere of the finger's radius rolls on the object
    pad = Pad(np.array([pad_along * distal, 0.0, radius]), np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), radius)
    # the model's geometry is its spheres, the fingertip's included: their surfaces are its skin
    shapes = [(s.link, s.center, s.radius) for s in spheres] + [(len(joints) - 1, pad.centre, pad.radius)]
    return Finger(
        name=name,
        joints=tuple(joints),
        spheres=tuple(spheres),
        pad=pad,
        tip=np.array([distal, 0.0, 0.0]),
        radius=radius,
        skin=tuple(Skin(link, skin.sphere(centre, r)) for link, centre, r in shapes),
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
    radius = number(palm.get("radius_m"), source, "palm.radius_m", positive=True)
    return Palm(points, np.full(len(points), radius), np.vstack([skin.sphere(p, radius) for p in points]))


def hand_from_yaml(data: dict, path: Path) -> Hand:
    """A hand from the project's YAML, every field checked: a one-line error names the field at fault."""
    reject_unknown(data, TOP_FIELDS, path)
    fingers = {
        str(name): _finger(data, str(name), spec, path) for name, spec in require(data, "fingers", path, dict).items()
    }
    grasping = data.get("grasping_fingers", list(fingers))
    if not isinstance(grasping, list) or not grasping:
        raise BadInputError(path, f"field 'grasping_fingers' must be a list of finger names, got {grasping!r}")
    for name in grasping:
        if name not in fingers:
            raise BadInputError(path, f"grasping finger '{name}' is not defined")
    capability = Capability.combined(
        [Capability.tendons(*_tendons(data, name, finger.joints, path)) for name, finger in fingers.items()]
    )
    tendons = data.get("tendons", {})
    sources = {name: str(t.get("source", "")) for name, t in tendons.items() if isinstance(t, dict)}
    compliance = number(data.get("pad_compliance_m", DEFAULT_COMPLIANCE_M), path, "pad_compliance_m", minimum=0.0)
    thinnest = min(f.pad.radius for f in fingers.values())
    if compliance >= thinnest:
        raise BadInputError(
            path, f"field 'pad_compliance_m': {compliance} m is not below the fingertip radius {thinnest} m"
        )
    name = str(data.get("name", path.stem))
    return Hand(name, fingers, _palm(data, path), tuple(grasping), capability, sources, compliance_m=compliance)
