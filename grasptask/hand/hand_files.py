"""``load_hand``: a hand from the file a user has, checked once here.

- a URDF (``.urdf``), parsed with yourdfpy;
- an MJCF file (``.xml``, ``.mjcf``), compiled with MuJoCo;
- the project's own hand YAML (``configs/hands/human.yaml``);
- a YAML that points at a URDF or MJCF file (``model: path``, relative to the YAML) and adds what the file
  cannot say: ``name``, ``palm_link``, ``fingertips`` (link names) with ``finger_names``, ``grasping_fingers``,
  ``pads`` (per fingertip link, ``point_m``, ``normal`` and ``tangent`` in its frame), ``approach`` (``z`` and
  ``x`` in the palm frame), ``compliance_m`` (how far a fingertip gives at a contact, 0.5 mm unless given) and
  ``sources`` (where each value came from). A pad may give ``radius_m``, its fingertip's radius of curvature,
  for the contact to roll over it. ``efforts`` and ``velocities`` set joints' limits by name or pattern
  (``finger_*_prox_joint: 1.0``) where the file states none, or states them wrong.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from grasptask.errors import BadInputError, existing_file
from grasptask.hand.from_mjcf import read_mjcf
from grasptask.hand.from_urdf import read_urdf
from grasptask.hand.from_yaml import hand_from_yaml
from grasptask.hand.hand_config import ApproachConfig, ModelHandConfig, PadConfig
from grasptask.hand.hand_model import Hand, Pad
from grasptask.hand.tree import HandOptions, hand_from_tree
from grasptask.io.config_schema import load_yaml, validated
from grasptask.paths import DEFAULT_HAND

URDF_SUFFIXES = (".urdf",)
MJCF_SUFFIXES = (".xml", ".mjcf")


def _unit(value: tuple[float, float, float], source: Path, name: str) -> np.ndarray:
    v = np.array(value, dtype=float)
    if np.linalg.norm(v) < 1e-9:
        raise BadInputError(source, f"field '{name}' must be a non-zero 3-vector")
    return v / np.linalg.norm(v)


def _pads(pads: dict[str | int, PadConfig], source: Path) -> dict[str, Pad]:
    found = {}
    for link, spec in pads.items():
        where = f"pads.{link}"
        normal = _unit(spec.normal, source, f"{where}.normal")
        tangent = _unit(spec.tangent, source, f"{where}.tangent")
        tangent = tangent - (tangent @ normal) * normal
        if np.linalg.norm(tangent) < 1e-6:
            raise BadInputError(source, f"field '{where}.tangent' is parallel to the normal")
        if spec.flat_size_m is not None and spec.radius_m > 0:
            raise BadInputError(source, f"field '{where}': a flat pad (flat_size_m) has no radius_m")
        found[str(link)] = Pad(
            np.array(spec.point_m, dtype=float), normal, tangent / np.linalg.norm(tangent), spec.radius_m,
            flat=spec.flat_size_m is not None,
            half_extents=(0.0, 0.0) if spec.flat_size_m is None else (spec.flat_size_m[0] / 2, spec.flat_size_m[1] / 2),
        )  # fmt: skip
    return found


def _approach(approach: ApproachConfig | None, source: Path) -> np.ndarray | None:
    if approach is None:
        return None
    z = _unit(approach.z, source, "approach.z")
    x = _unit(approach.x or ((1, 0, 0) if abs(z[0]) < 0.9 else (0, 1, 0)), source, "approach.x")
    x = x - (x @ z) * z
    if np.linalg.norm(x) < 1e-6:
        raise BadInputError(source, "fields 'approach.x' and 'approach.z' are parallel")
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def _read_model(path: Path, source: Path) -> Any:
    suffix = path.suffix.lower()
    if suffix in URDF_SUFFIXES:
        return read_urdf(path)
    if suffix in MJCF_SUFFIXES:
        return read_mjcf(path)
    raise BadInputError(source, f"unknown hand model format '{suffix}' (known: .urdf, .xml, .mjcf)")


def _with_model(data: dict, source: Path) -> Hand:
    config = validated(ModelHandConfig, data, source)
    model = source.parent / config.model
    existing_file(model, "hand model file")
    options = HandOptions(
        name=config.name,
        palm_link=config.palm_link,
        fingertips=None if config.fingertips is None else tuple(config.fingertips),
        finger_names=None if config.finger_names is None else tuple(config.finger_names),
        pads=_pads(config.pads, source),
        grasping=None if config.grasping_fingers is None else tuple(config.grasping_fingers),
        approach=_approach(config.approach, source),
        compliance_m=config.compliance_m,
        held=dict(config.held_joints),
        efforts=dict(config.efforts),
        velocities=dict(config.velocities),
        config=source,
    )
    hand = hand_from_tree(_read_model(model, source), model, options)
    return replace(hand, sources=dict(config.sources))


def _with_base(data: dict, path: Path, seen: tuple[Path, ...] = ()) -> dict:
    """A project hand YAML with ``base: FILE`` is that file's hand with this one's fields in place of its own, and
    its tendon tables in place of the same fingers' tables (e.g. the paper's thumb strengths)."""
    if "base" not in data:
        return data
    base = existing_file(path.parent / str(data["base"]), "base hand file")
    if base.resolve() in seen:
        raise BadInputError(path, f"field 'base': '{data['base']}' leads back to this file")
    merged = _with_base(load_yaml(base), base, (*seen, path.resolve()))
    for key, value in data.items():
        if key == "tendons" and isinstance(value, dict) and isinstance(merged.get("tendons"), dict):
            merged["tendons"] = {**merged["tendons"], **value}
        elif key != "base":
            merged[key] = value
    return merged


#: a hand YAML's suffixes (anything else that is not a URDF or MJCF is refused with the kinds it may be)
YAML_SUFFIXES = (".yaml", ".yml")


def load_hand(path: str | Path = DEFAULT_HAND) -> Hand:
    """The hand described by ``path``; a one-line error names the file and the field, link or joint at fault."""
    path = existing_file(path, "hand file")
    if path.suffix.lower() in URDF_SUFFIXES + MJCF_SUFFIXES:
        return hand_from_tree(_read_model(path, path), path)
    if path.suffix.lower() not in YAML_SUFFIXES:  # a mesh given as a hand said "not a text file"
        raise BadInputError(
            path, "not a hand file: give a URDF (.urdf), an MJCF (.xml) or a hand YAML (.yaml, with model: FILE)"
        )
    data = _with_base(load_yaml(path), path)
    return _with_model(data, path) if "model" in data else hand_from_yaml(data, path)
