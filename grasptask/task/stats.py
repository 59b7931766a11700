"""Ellipsoid statistics in the long format of the paper's Tables 1-10 (``reference/paper_ellipsoid_tables.csv``)."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pandas as pd

from grasptask.errors import BadInputError
from grasptask.task.ellipsoid import FORCE, TORQUE, block_extents, block_lengths, ellipsoid_matrices
from grasptask.task.units import PAPER_TORQUE_UNIT, TORQUE_UNITS

STATS_COLUMNS = ["group", "task", "grasp", "domain", "stat", "axis", "value"]
DOMAINS = {"force": (FORCE, 1.0), "torque": (TORQUE, 1.0 / TORQUE_UNITS[PAPER_TORQUE_UNIT])}
#: the paper's group order (Figure 9): drawing by grasp type, then cutting, then screw driving
PAPER_GROUP_ORDER = ["drawing_tripod", "drawing_cylindrical", "drawing_power", "cutting", "screwdriving"]


def group_order(groups: Iterable[str]) -> list[str]:
    """Groups in the paper's order, any others after them alphabetically."""
    present = list(dict.fromkeys(groups))
    known = [g for g in PAPER_GROUP_ORDER if g in present]
    return known + sorted(g for g in present if g not in PAPER_GROUP_ORDER)


def _moments(values: np.ndarray) -> dict[str, np.ndarray]:
    mu = values.mean(axis=0)
    sigma = values.std(axis=0, ddof=1) if len(values) > 1 else np.zeros_like(mu)
    return {"mu": mu, "sigma": sigma, "cv": np.divide(sigma, mu, out=np.zeros_like(mu), where=mu > 0)}


def group_statistics(matrices: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
    """Per domain: mu/sigma/cv of the ascending axis lengths (paper units), of the lengths normalised to sum 1,
    and the mean normalised extent along x, y, z (``proj``)."""
    out = {}
    for domain, (block, scale) in DOMAINS.items():
        lengths = block_lengths(matrices, block) * scale
        normalised = lengths / lengths.sum(axis=1, keepdims=True)
        extents = block_extents(matrices, block)
        stats = _moments(lengths)
        stats.update({f"{k}_n": v for k, v in _moments(normalised).items()})
        stats["proj"] = (extents / extents.sum(axis=1, keepdims=True)).mean(axis=0)
        out[domain] = stats
    return out


def statistics_table(ellipsoids: pd.DataFrame) -> pd.DataFrame:
    """One row per (group, domain, stat, axis), as in the reference CSV."""
    rows = []
    for group in group_order(ellipsoids["group"]):
        members = ellipsoids[ellipsoids["group"] == group]
        task, grasp = members["task"].iloc[0], members["grasp"].iloc[0]
        for domain, stats in group_statistics(ellipsoid_matrices(members)).items():
            for stat, values in stats.items():
                labels = ["x", "y", "z"] if stat == "proj" else ["1", "2", "3"]
                for label, value in zip(labels, values, strict=True):
                    rows.append([group, task, grasp, domain, stat, label, round(float(value), 6)])
    return pd.DataFrame(rows, columns=STATS_COLUMNS)


def read_reference(path: str | Path) -> pd.DataFrame:
    """A statistics table in the reference CSV's long format (``stats.csv``, or the paper's)."""
    try:
        frame = pd.read_csv(path, comment="#", dtype={"axis": str})
    except (OSError, UnicodeDecodeError, pd.errors.ParserError, pd.errors.EmptyDataError) as exc:
        raise BadInputError(path, f"not a readable statistics CSV ({type(exc).__name__})") from exc
    for column in STATS_COLUMNS:
        if column not in frame.columns:
            raise BadInputError(path, "missing column", column=column)
    values = pd.to_numeric(frame["value"], errors="coerce")
    if values.isna().any():
        raise BadInputError(path, "not a number", row=int(values.isna().to_numpy().argmax()) + 1, column="value")
    return frame.assign(value=values, group=frame["group"].astype(str), axis=frame["axis"].astype(str))


def compare_with_reference(stats: pd.DataFrame, reference: pd.DataFrame) -> pd.DataFrame:
    """Join on the key columns: ``value`` (ours), ``paper`` and ``difference``."""
    keys = ["group", "domain", "stat", "axis"]
    joined = stats.merge(reference[keys + ["value"]].rename(columns={"value": "paper"}), on=keys, how="inner")
    joined["difference"] = joined["value"] - joined["paper"]
    return joined
