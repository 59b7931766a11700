"""The project's own hand YAML (``configs/hands/human.yaml``): each finger a chain of joints from its base in the
palm, a joint turning about its axis and the link after it extending ``link_m`` along its own x, collision
spheres at fractions of each link, the pad on the distal link, and a tendon table per finger (eq. 1)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from grasptask.errors import BadInputError
from grasptask.hand import skin
from grasptask.hand.hand_config import FingerConfig, HandConfig, JointConfig, PalmConfig
from grasptask.hand.hand_model import Capability, Finger, Hand, Joint, Pad, Palm, Skin, Sphere
from grasptask.io.config_schema import validated


def _unit(vector: tuple[float, float, float], source: Path, name: str) -> np.ndarray:
    v = np.array(vector, dtype=float)
    if np.linalg.norm(v) < 1e-9:
        raise BadInputError(source, f"field '{name}' must be a non-zero 3-vector, got {list(vector)!r}")
    return v / np.linalg.norm(v)


def _base_rotation(spec: FingerConfig, source: Path, finger: str) -> np.ndarray:
    x = _unit(spec.base.x, source, f"fingers.{finger}.base.x")
    z = _unit(spec.base.z, source, f"fingers.{finger}.base.z")
    z = z - (z @ x) * x
    if np.linalg.norm(z) < 1e-6:
        raise BadInputError(source, f"fields 'fingers.{finger}.base.x' and '.z' are parallel")
    z /= np.linalg.norm(z)
    return np.column_stack([x, np.cross(z, x), z])


def _tendons(config: HandConfig, finger: str, joints: tuple[Joint, ...], source: Path):
    table = config.tendons.get(finger)
    if table is None:
        raise BadInputError(source, f"missing tendon table 'tendons.{finger}'")
    owner = finger
    if table.same_as is not None:
        owner = table.same_as
        table = config.tendons.get(owner)
        if table is None:
            raise BadInputError(source, f"field 'tendons.{finger}.same_as': no tendon table '{owner}'")
    if not table.muscles:
        raise BadInputError(source, f"tendon table for '{finger}' lists no muscles")
    arms, forces = [], []
    for name, muscle in table.muscles.items():
        if len(muscle.arms_mm) != len(joints):
            where = f"tendons.{owner}.muscles.{name}.arms_mm"
            raise BadInputError(source, f"field '{where}' must be {len(joints)} numbers, got {list(muscle.arms_mm)!r}")
        arms.append(np.array(muscle.arms_mm) * 1e-3)
        forces.append(muscle.max_force_n)
    return tuple(table.muscles), np.array(arms).T, np.array(forces)


def _joint(spec: JointConfig, source: Path, where: str) -> Joint:
    return Joint(
        name=spec.name,
        axis=_unit(spec.axis, source, f"{where}.axis"),
        lower=float(np.deg2rad(spec.min_deg)),
        upper=float(np.deg2rad(spec.max_deg)),
        coupled_to=spec.coupled_to,
        ratio=spec.ratio,
    )


def _finger(name: str, spec: FingerConfig, source: Path) -> Finger:
    where = f"fingers.{name}"
    parsed = [(_joint(j, source, f"{where}.joints[{k + 1}]"), j.link_m) for k, j in enumerate(spec.joints)]
    if parsed[-1][1] <= 0:
        raise BadInputError(source, f"field '{where}.joints': the last joint must carry the distal link (link_m > 0)")
    names = {j.name for j, _ in parsed}
    for j, _ in parsed:
        if j.coupled_to is not None and j.coupled_to not in names:
            raise BadInputError(source, f"joint '{j.name}' is coupled to unknown joint '{j.coupled_to}'")
    radius = spec.radius_m
    along, at_distal = spec.sample_fractions, spec.distal_sample_fractions
    # the link before joint k ends where joint k sits: along x of that link's frame
    joints, spheres = [], []
    for k, (joint, link) in enumerate(parsed):
        if k == 0:
            offset = np.array(spec.base.position_m, dtype=float)
            joint = replace(joint, offset=offset, rotation=_base_rotation(spec, source, name))
        else:
            joint = replace(joint, offset=np.array([parsed[k - 1][1], 0.0, 0.0]))
        joints.append(joint)
        if link > 0:
            for f in at_distal if k == len(parsed) - 1 else along:
                spheres.append(Sphere(k, np.array([f * link, 0.0, 0.0]), radius))
    distal = parsed[-1][1]
    # the pad is the distal link's skin over its axis: a sphere of the finger's radius rolls on the object
    pad = Pad(
        np.array([spec.pad_along * distal, 0.0, radius]), np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), radius
    )
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


def _palm(palm: PalmConfig) -> Palm:
    (x0, x1), (y0, y1), (nx, ny) = palm.x_range_m, palm.y_range_m, palm.grid
    points = np.array([[x, y, 0.0] for x in np.linspace(x0, x1, nx) for y in np.linspace(y0, y1, ny)])
    radius = palm.radius_m
    return Palm(points, np.full(len(points), radius), np.vstack([skin.sphere(p, radius) for p in points]))


def hand_from_yaml(data: dict, path: Path) -> Hand:
    """A hand from the project's YAML, every field checked: a one-line error names the field at fault."""
    config = validated(HandConfig, data, path)
    fingers = {name: _finger(name, spec, path) for name, spec in config.fingers.items()}
    grasping = config.grasping_fingers or list(fingers)
    for name in grasping:
        if name not in fingers:
            raise BadInputError(path, f"grasping finger '{name}' is not defined")
    capability = Capability.combined(
        [Capability.tendons(*_tendons(config, name, finger.joints, path)) for name, finger in fingers.items()]
    )
    sources = {name: table.source for name, table in config.tendons.items()}
    compliance = config.pad_compliance_m
    thinnest = min(f.pad.radius for f in fingers.values())
    if compliance >= thinnest:
        raise BadInputError(
            path, f"field 'pad_compliance_m': {compliance} m is not below the fingertip radius {thinnest} m"
        )
    name = config.name or path.stem
    return Hand(name, fingers, _palm(config.palm), tuple(grasping), capability, sources, compliance_m=compliance)
