"""Force and torque ellipsoids of a task projected on the object's coordinate planes, with the data points and
main axes (the paper's Figures 2, 7 and 10)."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from grasptask.errors import BadInputError
from grasptask.report.style import apply_style, save_figure, task_colour
from grasptask.task.ellipsoid import FORCE, TORQUE, semi_axes
from grasptask.task.fit import ellipsoid_matrices, entry_tool, expand_trials, load_wrenches
from grasptask.task.manifest import read_manifest
from grasptask.task.units import PAPER_TORQUE_UNIT, TORQUE_UNITS

PLANES = ((0, 1), (0, 2), (1, 2))
AXIS_NAMES = "xyz"
#: (block, factor from SI to the plotted unit, label)
DOMAINS = (
    (FORCE, 1.0, "force", "N"),
    (TORQUE, 1.0 / TORQUE_UNITS[PAPER_TORQUE_UNIT], "torque", PAPER_TORQUE_UNIT),
)
MAIN_AXIS = "magenta"


def recording_samples(
    manifest: Path, ids: Iterable[str], per_recording: int = 150, seed: int = 0
) -> dict[str, np.ndarray]:
    """Up to ``per_recording`` preprocessed object-frame wrench samples (N, N.m) of each recording in ``ids``."""
    wanted = set(ids)
    rng = np.random.default_rng(seed)
    tools: dict[Path, Any] = {}
    samples: dict[str, np.ndarray] = {}
    for entry in expand_trials(read_manifest(manifest), tools):  # a .mat row of {*} is one recording a trial
        if entry.id not in wanted:
            continue
        wrenches = load_wrenches(entry, entry_tool(entry, tools)).wrenches
        pick = rng.choice(len(wrenches), min(per_recording, len(wrenches)), replace=False)
        samples[entry.id] = wrenches[np.sort(pick)]
    return samples


def _ellipse(block2: np.ndarray, n: int = 100) -> np.ndarray:
    """Boundary of the shadow of an ellipsoid ``{S^(1/2) u : |u| <= 1}`` on a plane: ``S``'s 2x2 block."""
    values, vectors = np.linalg.eigh(block2)
    t = np.linspace(0, 2 * np.pi, n)
    circle = np.stack([np.cos(t), np.sin(t)])
    return (vectors @ (np.sqrt(np.clip(values, 0, None))[:, None] * circle)).T


def plot_task_ellipsoids(
    task: str,
    ellipsoids: pd.DataFrame,
    model_matrix: np.ndarray,
    path: Path,
    samples: dict[str, np.ndarray] | None = None,
    known_tasks: list[str] | None = None,
) -> None:
    """One row per domain (force, torque), one column per coordinate plane of the object frame."""
    apply_style()
    colour = task_colour(task, known_tasks)
    matrices = ellipsoid_matrices(ellipsoids)
    fig, axes = plt.subplots(2, 3, figsize=(11, 7))
    for row, (block, factor, name, unit) in enumerate(DOMAINS):
        scale2 = factor**2
        points = None
        if samples:
            points = np.vstack([samples[i] for i in ellipsoids["id"] if i in samples])[:, block] * factor
        model_block = model_matrix[block, block] * scale2
        model_axes = semi_axes(model_block)
        for col, (i, j) in enumerate(PLANES):
            ax = axes[row, col]
            if points is not None:
                ax.scatter(points[:, i], points[:, j], s=2, color="0.35", alpha=0.3, label="data points", zorder=1)
            for k, matrix in enumerate(matrices):
                block3 = matrix[block, block] * scale2
                outline = _ellipse(block3[np.ix_([i, j], [i, j])])
                ax.plot(*outline.T, color=colour, lw=0.6, alpha=0.45, label="trial ellipsoids" if k == 0 else None)
                axis = semi_axes(block3)[0]
                ax.plot([-axis[i], axis[i]], [-axis[j], axis[j]], color=MAIN_AXIS, lw=0.6, alpha=0.6,
                        label="trial main axes" if k == 0 else None)  # fmt: skip
            outline = _ellipse(model_block[np.ix_([i, j], [i, j])])
            ax.plot(*outline.T, color=colour, lw=2.4, label="task model (mean)", zorder=3)
            for k, axis in enumerate(model_axes):  # the model's semi-axes, as arrows from the origin
                ax.annotate("", xy=(axis[i], axis[j]), xytext=(0, 0), zorder=4,
                            arrowprops={"arrowstyle": "-|>", "color": "black" if k == 0 else "0.45",
                                        "lw": 2.0 if k == 0 else 1.2})  # fmt: skip
            ax.plot([], [], color="black", lw=2.0, label="task model's axes")
            ax.set_xlabel(f"{name} {AXIS_NAMES[i]} ({unit})")
            ax.set_ylabel(f"{name} {AXIS_NAMES[j]} ({unit})")
            ax.set_aspect("equal", adjustable="datalim")
            ax.grid(alpha=0.3)
            ax.set_title(f"{name}, {AXIS_NAMES[i]}-{AXIS_NAMES[j]} plane")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=5, markerscale=4, frameon=False)
    fig.suptitle(
        f"{task}: force and torque ellipsoids of {len(matrices)} recordings in the object frame "
        "(shadows of the 1-RMS ellipsoids; cf. paper Figures 2, 7, 10)",
        color=colour,
    )
    fig.tight_layout(rect=(0, 0.05, 1, 0.96))
    save_figure(fig, path)
    plt.close(fig)


def load_samples_or_note(manifest: Path, ids: Iterable[str]) -> tuple[dict[str, np.ndarray] | None, str | None]:
    """The data points, or why they cannot be shown (the figures are drawn without them)."""
    if not manifest.is_file():
        return None, f"no recordings manifest at {manifest}, so the ellipsoid figures show no data points"
    try:
        return recording_samples(manifest, ids), None
    except BadInputError as exc:
        return None, f"data points not shown: {exc}"
