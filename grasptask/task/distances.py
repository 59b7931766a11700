"""Log-Euclidean distances between task ellipsoids (paper eq. 15, without its stray minus sign) and how well
they separate tasks.

Each matrix log is taken once (:func:`grasptask.task.spd.log_vectors`); the distance matrix is then the
pairwise Euclidean distance of the vectorised logs.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.linalg import eigh
from scipy.spatial.distance import pdist, squareform
from sklearn.metrics import silhouette_samples

from grasptask.errors import BadInputError
from grasptask.io.tables import read_table
from grasptask.task.ellipsoid import ellipsoid_matrices, torque_axes_weight, torque_to_force
from grasptask.task.spd import log_vectors
from grasptask.task.stats import group_order
from grasptask.task.task_model import mean_models


def distance_matrix(matrices: np.ndarray) -> np.ndarray:
    """``D[i, j] = ||log S_i - log S_j||_F`` for a ``(k, 6, 6)`` stack."""
    return squareform(pdist(log_vectors(matrices)))


def _fix_signs(coords: np.ndarray) -> np.ndarray:
    """Each axis signed so that its largest coordinate is positive: the same data give the same picture."""
    signs = np.sign(coords[np.argmax(np.abs(coords), axis=0), [0, 1]])
    return coords * np.where(signs == 0, 1.0, signs)


def embedding_2d(matrices: np.ndarray) -> np.ndarray:
    """2D coordinates whose Euclidean distances best approximate the Log-Euclidean ones.

    The distances are Euclidean in log space, so classical MDS reduces to PCA of the vectorised logs.
    """
    vectors = log_vectors(matrices)
    centred = vectors - vectors.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    coords = np.zeros((len(vectors), 2))
    coords[:, : min(2, len(vt))] = centred @ vt[:2].T
    return _fix_signs(coords)


def embedding_from_distances(raw: np.ndarray) -> np.ndarray:
    """Classical MDS of a Euclidean distance matrix: the same coordinates as :func:`embedding_2d` of the
    matrices the distances came from, for when only the distances are at hand."""
    k = len(raw)
    centring = np.eye(k) - 1.0 / k
    gram = -0.5 * centring @ (raw**2) @ centring
    values, vectors = eigh(gram, subset_by_index=[max(k - 2, 0), k - 1])
    order = np.argsort(values)[::-1]
    coords = np.zeros((k, 2))
    coords[:, : len(order)] = vectors[:, order] * np.sqrt(np.maximum(values[order], 0.0))
    return _fix_signs(coords)


def loo_1nn_accuracy(distances: np.ndarray, labels: np.ndarray) -> float:
    """Leave-one-out 1-nearest-neighbour accuracy of ``labels``."""
    d = distances.copy()
    np.fill_diagonal(d, np.inf)
    return float(np.mean(labels[np.argmin(d, axis=1)] == labels))


def separation_summary(distances: np.ndarray, labels: np.ndarray) -> dict:
    """LOO 1-NN accuracy, silhouette (overall and per label), mean within- and between-label distances."""
    labels = np.asarray(labels)
    largest = distances.max()
    same = labels[:, None] == labels[None, :]
    off_diagonal = ~np.eye(len(labels), dtype=bool)
    unique = list(dict.fromkeys(labels))
    summary = {
        "n_ellipsoids": int(len(labels)),
        "labels": unique,
        "loo_1nn_accuracy": loo_1nn_accuracy(distances, labels),
        "max_distance": float(largest),
        "mean_within": float(distances[same & off_diagonal].mean()) if (same & off_diagonal).any() else None,
        "mean_between": float(distances[~same].mean()) if (~same).any() else None,
    }
    if len(unique) > 1 and len(unique) < len(labels):
        per_sample = silhouette_samples(distances, labels, metric="precomputed")
        summary["silhouette"] = float(per_sample.mean())
        summary["silhouette_by_label"] = {str(u): float(per_sample[labels == u].mean()) for u in unique}
    for key in ("mean_within", "mean_between"):
        if summary[key] is not None:
            summary[f"{key}_normalised"] = summary[key] / largest if largest > 0 else 0.0
    return summary


@dataclass
class Distances:
    """Distances between the ellipsoids of a table, in the paper's order (Figure 9)."""

    table: pd.DataFrame  # the ellipsoid rows, reordered
    raw: np.ndarray
    embedding: np.ndarray

    @property
    def normalised(self) -> np.ndarray:
        largest = self.raw.max()
        return self.raw / largest if largest > 0 else self.raw

    def summary(self) -> dict:
        return {
            "by_task": separation_summary(self.raw, self.table["task"].to_numpy()),
            "by_group": separation_summary(self.raw, self.table["group"].to_numpy()),
            "tasks": task_comparison(self.table, float(self.raw.max())),
        }

    def long_table(self) -> pd.DataFrame:
        """Every ordered pair ``(id_a, id_b)``; ids are categorical, so k^2 rows cost k strings."""
        ids = self.table["id"].astype(str).to_numpy()
        k = len(ids)
        codes = np.arange(k, dtype=np.int32)
        return pd.DataFrame(
            {
                "id_a": pd.Categorical.from_codes(np.repeat(codes, k), categories=ids),
                "id_b": pd.Categorical.from_codes(np.tile(codes, k), categories=ids),
                "distance": self.raw.ravel(),
                "distance_normalised": self.normalised.ravel(),
            }
        )


def torque_scaled(matrices: np.ndarray, factor: float) -> np.ndarray:
    """``D S D`` for each ``S``, ``D = diag(1, 1, 1, f, f, f)``: the ellipsoids with torques in another unit
    (``factor`` 100: N.cm)."""
    scale = np.array([1.0, 1.0, 1.0, factor, factor, factor])
    return matrices * scale[:, None] * scale[None, :]


def task_comparison(ellipsoids: pd.DataFrame, largest: float) -> dict:
    """Which task is like which: the Log-Euclidean distances between the task models (each task's mean
    ellipsoid; raw, and normalised by ``largest``, the largest distance between two recordings), each task's
    nearest, and how force and torque are weighed (SI units: each task's RMS torque over its RMS force, the share
    of eq. 12's weights its torque axes hold, and how much the task distances change with torques in N.cm)."""
    models = mean_models(ellipsoids, "task")
    names = list(models)
    matrices = np.stack([m.ellipsoid.S for m in models.values()])
    raw = distance_matrix(matrices)
    nearest = {}
    if len(names) > 1:
        masked = raw + np.diag(np.full(len(names), np.inf))
        for k, name in enumerate(names):
            other = int(np.argmin(masked[k]))
            nearest[name] = {
                "task": names[other],
                "distance": float(raw[k, other]),
                "distance_normalised": float(raw[k, other] / largest) if largest > 0 else 0.0,
            }
    in_cm = distance_matrix(torque_scaled(matrices, 100.0))
    off = ~np.eye(len(names), dtype=bool)
    change = float(np.max(np.abs(in_cm[off] / raw[off] - 1.0))) if off.any() and (raw[off] > 0).all() else 0.0
    return {
        "names": names,
        "distances": raw.tolist(),
        "nearest": nearest,
        "torque_to_force": {n: torque_to_force(m.ellipsoid.S) for n, m in models.items()},
        "torque_axes_weight": {n: torque_axes_weight(m.ellipsoid) for n, m in models.items()},
        "change_with_torque_in_Ncm": change,
    }


def weighing_line(tasks: dict) -> str:
    """One sentence on how force and torque are weighed, with this set's figures (a :func:`task_comparison`)."""
    ratios = tasks["torque_to_force"].values()
    weights = tasks["torque_axes_weight"].values()
    return (
        "Forces and torques are weighed in SI units, N against N.m (SPEC 3), so a 1 N.m torque counts as a "
        f"1 N force: here the RMS torque is {100 * min(ratios):.2g}-{100 * max(ratios):.2g}% of the RMS force, "
        f"the task models' torque-dominated axes hold {100 * min(weights):.2g}-{100 * max(weights):.2g}% of eq. "
        "12's weights, and with torques in N.cm the distances between task models would change by up to "
        f"{100 * tasks['change_with_torque_in_Ncm']:.2g}% (the Log-Euclidean distance feels the unit only "
        "through the coupling of force and torque)."
    )


def paper_order(ellipsoids: pd.DataFrame) -> pd.DataFrame:
    """Sort by group (paper order), then subject and trial."""
    rank = {g: i for i, g in enumerate(group_order(ellipsoids["group"]))}
    keyed = ellipsoids.assign(_rank=ellipsoids["group"].map(rank))
    return (
        keyed.sort_values(["_rank", "subject", "trial", "id"], kind="stable")
        .drop(columns="_rank")
        .reset_index(drop=True)
    )


def compute_distances(ellipsoids: pd.DataFrame) -> Distances:
    table = paper_order(ellipsoids)
    matrices = ellipsoid_matrices(table)
    return Distances(table=table, raw=distance_matrix(matrices), embedding=embedding_2d(matrices))


def read_distances(path: str | Path, ellipsoids: pd.DataFrame) -> Distances:
    """The :class:`Distances` that ``grasptask distances`` wrote to ``path`` for ``ellipsoids``, without
    recomputing them; every ordered pair of the ellipsoids' ids must be in the file."""
    table = paper_order(ellipsoids)
    long = read_table(path, ("id_a", "id_b", "distance"))
    ids = pd.Index(table["id"].astype(str))
    rows, cols = ids.get_indexer(long["id_a"].astype(str)), ids.get_indexer(long["id_b"].astype(str))
    k = len(ids)
    if (rows < 0).any() or (cols < 0).any() or len(long) != k * k:
        raise BadInputError(path, f"does not hold the {k} x {k} distances of the ellipsoids it is read with")
    values = pd.to_numeric(long["distance"], errors="coerce").to_numpy(dtype=float)
    bad = ~(np.isfinite(values) & (values >= 0))
    if bad.any():
        raise BadInputError(path, "not a finite distance >= 0", row=int(bad.argmax()) + 1, column="distance")
    raw = np.full((k, k), np.nan)
    raw[rows, cols] = values
    if np.isnan(raw).any():
        raise BadInputError(path, "a pair of ellipsoids is missing or repeated")
    return Distances(table=table, raw=raw, embedding=embedding_from_distances(raw))
