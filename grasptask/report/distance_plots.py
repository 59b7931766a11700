"""Figure 9 (distance heatmap ordered by task and grasp type) and a 2D embedding of the ellipsoids."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from grasptask.report.style import GRASP_MARKERS, apply_style, save_figure, task_colour
from grasptask.task.distances import Distances


def _group_spans(groups: np.ndarray) -> list[tuple[str, int, int]]:
    spans, start = [], 0
    for i in range(1, len(groups) + 1):
        if i == len(groups) or groups[i] != groups[start]:
            spans.append((str(groups[start]), start, i))
            start = i
    return spans


#: beyond this many ellipsoids the heatmap shows block means; a figure cannot show more pixels anyway
MAX_HEATMAP_CELLS = 600


def _block_mean(matrix: np.ndarray, size: int) -> np.ndarray:
    """``matrix`` averaged over about ``size`` x ``size`` equal blocks (unchanged if already small enough)."""
    k = len(matrix)
    if k <= size:
        return matrix
    edges = np.linspace(0, k, size + 1).astype(int)
    rows = np.add.reduceat(matrix, edges[:-1], axis=0) / np.diff(edges)[:, None]
    return np.add.reduceat(rows, edges[:-1], axis=1) / np.diff(edges)[None, :]


def plot_heatmap(distances: Distances, path: Path) -> None:
    apply_style()
    groups = distances.table["group"].to_numpy()
    fig, ax = plt.subplots(figsize=(7.2, 6.2))
    shown = _block_mean(distances.normalised, MAX_HEATMAP_CELLS)
    k = len(groups)
    image = ax.imshow(
        shown, cmap="viridis", vmin=0, vmax=1, interpolation="nearest", extent=(-0.5, k - 0.5, k - 0.5, -0.5)
    )
    fig.colorbar(image, ax=ax, label="normalised Log-Euclidean distance")
    ticks, labels = [], []
    for name, start, stop in _group_spans(groups):
        for edge in (start - 0.5, stop - 0.5):
            ax.axhline(edge, color="white", lw=0.8)
            ax.axvline(edge, color="white", lw=0.8)
        ticks.append((start + stop - 1) / 2)
        labels.append(f"{name}\n(n={stop - start})")
    ax.set_xticks(ticks, labels, rotation=30, ha="right")
    ax.set_yticks(ticks, labels)
    ax.set_title("Distances between task ellipsoids (cf. paper Figure 9)")
    save_figure(fig, path)
    plt.close(fig)


def plot_embedding(distances: Distances, path: Path) -> None:
    apply_style()
    table = distances.table
    tasks = list(dict.fromkeys(table["task"]))
    fig, ax = plt.subplots(figsize=(6.4, 5.2))
    for (task, grasp), rows in table.groupby(["task", "grasp"], sort=False):
        xy = distances.embedding[rows.index.to_numpy()]
        ax.scatter(
            xy[:, 0],
            xy[:, 1],
            c=task_colour(task, tasks),
            marker=GRASP_MARKERS.get(grasp, "x"),
            label=f"{task} ({grasp})",
            alpha=0.8,
            edgecolors="black",
            linewidths=0.4,
        )
    ax.set_xlabel("embedding axis 1 (log-space units)")
    ax.set_ylabel("embedding axis 2 (log-space units)")
    ax.set_title("Task ellipsoids, classical MDS of Log-Euclidean distances")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.3)
    save_figure(fig, path)
    plt.close(fig)
