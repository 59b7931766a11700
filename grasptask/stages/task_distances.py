"""``grasptask distances``: Log-Euclidean distances between the ellipsoids, how well they separate tasks, and
the paper's Figure 9."""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.paths import as_paths
from grasptask.report.distance_plots import plot_embedding, plot_heatmap
from grasptask.task.distances import compute_distances, weighing_line
from grasptask.task.fit import read_ellipsoids


@dataclass(frozen=True, kw_only=True)
class DistanceOptions:
    """The ellipsoids to compare (``ellipsoids.parquet``, as ``fit-task`` writes it) and where to write."""

    ellipsoids: Path
    out: Path

    def __post_init__(self) -> None:
        as_paths(self, "ellipsoids", "out")


@dataclass(frozen=True)
class DistanceSummary:
    """What ``distance_summary.json`` holds: how well the distances separate the tasks (``by_task``: the
    leave-one-out 1-NN accuracy, the silhouette, the mean distances within and between tasks), and more."""

    out: Path
    summary: dict[str, Any]

    @property
    def by_task(self) -> dict[str, Any]:
        return self.summary["by_task"]

    @property
    def weighing(self) -> str:
        """The sentence on how force and torque are weighed, with this set's figures."""
        return weighing_line(self.summary["tasks"])


def run_distances(options: DistanceOptions) -> DistanceSummary:
    """Write ``distances.parquet``, ``distance_summary.json`` and the heatmap and embedding PNGs."""
    ellipsoids_path, out = options.ellipsoids, options.out
    ellipsoids = read_ellipsoids(ellipsoids_path)
    distances = compute_distances(ellipsoids)
    summary = distances.summary()
    with StagedOutput(out, Provenance.of("distances", {}, [ellipsoids_path])) as staged:
        # k^2 rows of floats that do not compress: no codec, dictionaries and statistics only for the ids
        staged.write_parquet(
            "distances.parquet",
            distances.long_table(),
            compression="none",
            use_dictionary=["id_a", "id_b"],
            write_statistics=["id_a", "id_b"],
        )
        staged.write_json("distance_summary.json", summary)
        staged.write_with("distance_heatmap.png", partial(plot_heatmap, distances))
        staged.write_with("distance_embedding.png", partial(plot_embedding, distances))
    return DistanceSummary(out, summary)
