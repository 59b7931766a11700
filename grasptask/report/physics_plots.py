"""The physics check in pictures: the object's translation and rotation under each task's best grasp over the
whole protocol (settle, then every test wrench from the settled state), phases laid end to end, with the pass
thresholds."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from grasptask.report.style import apply_style, save_figure, task_colour


def protocol_time(trace: pd.DataFrame) -> tuple[np.ndarray, list[tuple[str, float, float]]]:
    """Each sample's time on one axis (``trace`` indexed 0 .. n-1), the phases one after another in their
    recorded order, and each phase's name, start and end on that axis."""
    times = np.empty(len(trace))
    phases, offset = [], 0.0
    for phase, rows in trace.groupby("phase", sort=False):
        length = float(rows["time_s"].max())
        times[rows.index.to_numpy()] = offset + rows["time_s"].to_numpy(float)
        phases.append((str(phase), offset, offset + length))
        offset += length
    return times, phases


def plot_physics_traces(traces: dict[str, pd.DataFrame], thresholds: dict[str, dict], path: Path) -> None:
    """One row per task: the best grasp's object translation (mm) and rotation (deg) over the protocol, the
    task's own wrenches on white, DexGraspBench's forces shaded, our thresholds dashed, theirs dotted."""
    apply_style()
    tasks = list(traces)
    fig, axes = plt.subplots(len(tasks), 2, figsize=(14, 2.9 * len(tasks) + 0.6), squeeze=False)
    for row, task in enumerate(tasks):
        trace = traces[task].reset_index(drop=True)
        times, phases = protocol_time(trace)
        limits = thresholds[task]
        panels = (
            ("translation_m", 1e3, "translation (mm)", "max_translation_m", "benchmark_translation_m"),
            ("rotation_deg", 1.0, "rotation (deg)", "max_rotation_deg", "benchmark_rotation_deg"),
        )
        for ax, (column, scale, label, ours, theirs) in zip(axes[row], panels, strict=True):
            values = trace[column].to_numpy(float) * scale
            for name, begin, end in phases:  # one line per phase: each test starts again from the settled state
                if name.startswith("dexgraspbench"):
                    ax.axvspan(begin, end, color="0.92", lw=0)
                ax.axvline(begin, color="0.75", lw=0.5)
                inside = (times > begin) & (times <= end)
                ax.plot(times[inside], values[inside], color=task_colour(task, tasks), lw=1.2)
            ax.axhline(limits[ours] * scale, color="black", ls="--", lw=1, label="our threshold")
            ax.axhline(limits[theirs] * scale, color="black", ls=":", lw=1, label="DexGraspBench's")
            ax.set_yscale("symlog", linthresh=0.1)
            # a dropped object flies off: show up to well past DexGraspBench's threshold, not all the way
            top = min(float(values.max(initial=0.0)), 4 * limits[theirs] * scale)
            ax.set_ylim(0, max(top, limits[theirs] * scale) * 1.3)
            ax.set_ylabel(label)
            ax.set_title(f"{task}: start {int(trace['start_id'].iloc[0])}, {label.split(' ')[0]}", fontsize=10)
            ax.set_xticks([(b + e) / 2 for _, b, e in phases], [n for n, _, _ in phases], rotation=90, fontsize=7)
            ax.set_xlim(0, phases[-1][2])
        axes[row][0].legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)
