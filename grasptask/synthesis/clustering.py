"""Distinct local optima: verified solutions grouped by a descriptor that respects the object's symmetry."""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.cluster.hierarchy import fcluster, linkage

from grasptask.records.solutions import contacts_from_row, palm_normal_from_row, palm_position_from_row

#: solutions closer than this (contacts and palm position in metres, palm normal x 0.05 m) are one optimum
THRESHOLD = 0.01


def _rotation_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def descriptor(
    contacts: np.ndarray, palm_position: np.ndarray, palm_normal: np.ndarray, symmetry: dict | None
) -> np.ndarray:
    """Contacts, palm centre and palm normal, brought to a canonical pose under the object's symmetry.

    For a body of revolution about z that may also be flipped end for end (the tool), the grasp is turned
    about z until the thumb's contact lies on +x, then turned half a turn about x if the thumb is below the
    middle, so that equivalent grasps get equal descriptors.
    """
    points = np.vstack([contacts, palm_position])
    normal = np.asarray(palm_normal, dtype=float)
    if symmetry and symmetry.get("rotation_axis") == "z":
        turn = _rotation_z(-np.arctan2(points[0, 1], points[0, 0]))
        points, normal = points @ turn.T, turn @ normal
        if symmetry.get("flip_axis") == "z" and points[0, 2] < 0:
            flip = np.diag([1.0, -1.0, -1.0])
            points, normal = points @ flip.T, flip @ normal
    return np.concatenate([points.ravel(), 0.05 * normal])


def labels(verified: pd.DataFrame, fingers: list[str], symmetry: dict | None) -> np.ndarray:
    """Which optimum each of the ``verified`` rows belongs to: rows whose descriptors lie within
    :data:`THRESHOLD` of each other (average linkage) share a label."""
    if len(verified) <= 1:
        return np.ones(len(verified), dtype=int)
    vectors = np.stack(
        [
            descriptor(
                contacts_from_row(row, fingers),
                palm_position_from_row(row),
                palm_normal_from_row(row),
                symmetry,
            )
            for _, row in verified.iterrows()
        ]
    )
    return fcluster(linkage(vectors, method="average"), THRESHOLD, criterion="distance")


def cluster(solutions: pd.DataFrame, fingers: list[str], symmetry: dict | None) -> pd.DataFrame:
    """One row per distinct verified optimum: its best member (lowest Q), the member count and Q range."""
    verified = solutions[solutions["verified"]].reset_index(drop=True)
    if verified.empty:
        return verified.assign(optimum_id=pd.Series(dtype=int), members=pd.Series(dtype=int))
    verified = verified.assign(_label=labels(verified, fingers, symmetry))
    rows = []
    for _, members in verified.groupby("_label"):
        best = members.loc[members["Q"].idxmin()]
        rows.append({**best.drop("_label").to_dict(), "members": len(members), "Q_max": members["Q"].max()})
    optima = pd.DataFrame(rows).sort_values("Q").reset_index(drop=True)
    optima.insert(0, "optimum_id", np.arange(len(optima)))
    return optima
