"""Synthesis sweep statistics: how the starts ended, time per start beside the paper's 459 +- 186 s, and the
verified fraction and distinct optima beside the paper's 7 / 20 / 3."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import MaxNLocator

from grasptask.records.solutions import STATUSES
from grasptask.report.style import apply_style, save_figure, task_colour

STATUS_COLOURS = {
    "optimal": "#1a9850",
    "acceptable": "#91cf60",
    "infeasible": "#d73027",
    "max-iter": "#fc8d59",
    "time-limit": "#fee08b",
    "error": "#7f7f7f",
    "crashed": "#4d4d4d",
    "hung": "#000000",
    "same-basin": "#74add1",  # the search route: joined a basin another start's polish stands for
}


def plot_sweeps(sweeps: dict, paper_mean_s: float | None, paper_sd_s: float, paper_optima: dict, path: Path) -> None:
    """Three panels: status counts per task, a histogram of seconds per start (log scale, with the paper's
    mean +- sd unless ``paper_mean_s`` is None), and verified fraction with distinct optima against the paper's
    (for the tasks ``paper_optima`` has)."""
    apply_style()
    tasks = list(sweeps)
    fig, (ax_status, ax_time, ax_found) = plt.subplots(1, 3, figsize=(14, 4.4))
    bottom = np.zeros(len(tasks))
    for status in dict.fromkeys([*STATUSES, *STATUS_COLOURS]):
        counts = np.array([(sweeps[t].table["status"] == status).sum() for t in tasks], dtype=float)
        if counts.any():
            ax_status.bar(tasks, counts, bottom=bottom, color=STATUS_COLOURS.get(status, "#cccccc"), label=status,
                          edgecolor="white")  # fmt: skip
            bottom += counts
    ax_status.set_ylabel("starts")
    ax_status.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax_status.set_title("How each start ended (IPOPT status)")
    ax_status.legend(fontsize=8)

    seconds = {t: sweeps[t].table["seconds"].astype(float).clip(lower=1e-2).to_numpy() for t in tasks}
    shaded = [] if paper_mean_s is None else [paper_mean_s + paper_sd_s]
    high = max([*shaded, *(s.max() for s in seconds.values())]) * 1.5
    low = min(s.min() for s in seconds.values()) / 1.5
    bins = np.geomspace(low, high, 40)
    for task in tasks:
        ax_time.hist(seconds[task], bins=bins, histtype="step", lw=2, color=task_colour(task, tasks),
                     label=f"{task} (median {np.median(seconds[task]):.1f} s)")  # fmt: skip
    if paper_mean_s is not None:
        ax_time.axvspan(paper_mean_s - paper_sd_s, paper_mean_s + paper_sd_s, color="0.85", label="paper: mean +- sd")
        ax_time.axvline(paper_mean_s, color="black", ls="--", label=f"paper: {paper_mean_s:.0f} s per solution")
    ax_time.set_xscale("log")
    ax_time.set_xlabel("seconds per start (log scale)")
    ax_time.set_ylabel("starts")
    ax_time.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax_time.set_title("Time per start")
    ax_time.legend(fontsize=8)

    x = np.arange(len(tasks))
    fractions = [sweeps[t].table["verified"].mean() * 100 for t in tasks]
    ax_found.bar(x, fractions, color=[task_colour(t, tasks) for t in tasks], alpha=0.8)
    for k, task in enumerate(tasks):
        ours, paper = len(sweeps[task].optima), paper_optima.get(task)
        label = f"{ours} optim{'um' if ours == 1 else 'a'}" + (f"\n(paper {paper:.0f})" if paper is not None else "")
        ax_found.text(k, fractions[k] + 2, label, ha="center", va="bottom", fontsize=9)
    ax_found.set_xticks(x, tasks)
    ax_found.set_ylim(0, 119)
    ax_found.set_ylabel("starts ending in a verified grasp (%)")
    ax_found.set_title("Verified grasps and distinct optima")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
