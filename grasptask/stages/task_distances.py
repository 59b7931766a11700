"""``grasptask distances``: Log-Euclidean distances between the ellipsoids, how well they separate tasks, and
the paper's Figure 9."""

from __future__ import annotations

from functools import partial
from pathlib import Path

from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.report.distance_plots import plot_embedding, plot_heatmap
from grasptask.task.distances import compute_distances
from grasptask.task.fit import read_ellipsoids


def run_distances(ellipsoids_path: str | Path, out: str | Path) -> dict:
    """Write ``distances.parquet``, ``distance_summary.json`` and the heatmap and embedding PNGs."""
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
    return summary
