"""``load_hand``: a hand from the file a user has, checked once here.

- a URDF (``.urdf``), parsed with yourdfpy;
- an MJCF file (``.xml``, ``.mjcf``), compiled with MuJoCo;
- the project's own hand YAML (``configs/hands/human.yaml``);
- a YAML that points at a URDF or MJCF file (``model: path``, relative to the YAML) and adds what the file
  cannot say: ``name``, ``palm_link``, ``fingertips`` (link names) with ``finger_names``, ``grasping_fingers``,
  ``pads`` (per fingertip link, ``point_m``, ``normal`` and ``tangent`` in its frame), ``approach`` (``z`` and
  ``x`` in the palm frame), ``compliance_m`` (how far a fingertip gives at a contact, 0.5 mm unless given) and
  ``sources`` (where each value came from). A pad may give ``radius_m``, its fingertip's radius of curvature,
  for the contact to roll over it.
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
from grasptask.hand.model import DEFAULT_COMPLIANCE_M, Hand, Pad
from grasptask.hand.tree import HandOptions, hand_from_tree
from grasptask.io.config import load_yaml, number, numbers, reject_unknown
from grasptask.paths import DEFAULT_HAND

URDF_SUFFIXES = (".urdf",)
MJCF_SUFFIXES = (".xml", ".mjcf")
MODEL_FIELDS = {
    "model", "name", "description", "palm_link", "fingertips", "finger_names", "grasping_fingers", "pads",
    "approach", "sources", "compliance_m",
}  # fmt: skip


def _names(data: dict, key: str, source: Path) -> tuple[str, ...] | None:
    value = data.get(key)
    if value is None:
        return None
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise BadInputError(source, f"field '{key}' must be a list of names, got {value!r}")
    return tuple(value)


def _unit(value: Any, source: Path, name: str) -> np.ndarray:
    v = numbers(value, source, name, 3)
    if np.linalg.norm(v) < 1e-9:
        raise BadInputError(source, f"field '{name}' must be a non-zero 3-vector")
    return v / np.linalg.norm(v)


def _pads(value: Any, source: Path) -> dict[str, Pad]:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise BadInputError(source, "field 'pads' must map fingertip links to point_m, normal and tangent")
    pads = {}
    for link, spec in value.items():
        where = f"pads.{link}"
        if not isinstance(spec, dict):
            raise BadInputError(source, f"field '{where}' must be a mapping")
        reject_unknown(spec, {"point_m", "normal", "tangent", "radius_m"}, source, f"{where}.")
        normal = _unit(spec.get("normal"), source, f"{where}.normal")
        tangent = _unit(spec.get("tangent"), source, f"{where}.tangent")
        tangent = tangent - (tangent @ normal) * normal
        if np.linalg.norm(tangent) < 1e-6:
            raise BadInputError(source, f"field '{where}.tangent' is parallel to the normal")
        point = numbers(spec.get("point_m"), source, f"{where}.point_m", 3)
        radius = number(spec.get("radius_m", 0.0), source, f"{where}.radius_m", minimum=0.0)
        pads[str(link)] = Pad(point, normal, tangent / np.linalg.norm(tangent), radius)
    return pads


def _approach(value: Any, source: Path) -> np.ndarray | None:
    if value is None:
        return None
    if not isinstance(value, dict):
        raise BadInputError(source, "field 'approach' must give z (towards the object) and x, in the palm frame")
    reject_unknown(value, {"z", "x"}, source, "approach.")
    z = _unit(value.get("z"), source, "approach.z")
    x = _unit(value.get("x", [1, 0, 0] if abs(z[0]) < 0.9 else [0, 1, 0]), source, "approach.x")
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
    reject_unknown(data, MODEL_FIELDS, source)
    model = source.parent / str(data["model"])
    existing_file(model, "hand model file")
    options = HandOptions(
        name=str(data["name"]) if "name" in data else None,
        palm_link=str(data["palm_link"]) if "palm_link" in data else None,
        fingertips=_names(data, "fingertips", source),
        finger_names=_names(data, "finger_names", source),
        pads=_pads(data.get("pads"), source),
        grasping=_names(data, "grasping_fingers", source),
        approach=_approach(data.get("approach"), source),
        compliance_m=number(data.get("compliance_m", DEFAULT_COMPLIANCE_M), source, "compliance_m", minimum=0.0),
    )
    hand = hand_from_tree(_read_model(model, source), model, options)
    sources = data.get("sources") or {}
    if not isinstance(sources, dict):
        raise BadInputError(source, "field 'sources' must map what to where it came from")
    return replace(hand, sources={str(k): str(v) for k, v in sources.items()})


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
