"""What the paper reports of its grasp synthesis (Section 7.3, Tables 11-12): one reader for the reference CSV,
shared by ``synthesize`` (``run.json``), the report and the benchmark."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from grasptask.paths import REFERENCE_DIR

PAPER_SYNTHESIS = REFERENCE_DIR / "paper_synthesis_results.csv"


@dataclass(frozen=True)
class PaperSynthesis:
    """What the paper reports of its synthesis (Section 7.3, Tables 11-12), read from the reference CSV."""

    variables: int
    constraints: int
    optima: dict[str, int]
    mean_s: float
    sd_s: float
    quality_shown: dict[str, list[float]]

    @property
    def seconds(self) -> str:
        return f"{self.mean_s:.0f} +- {self.sd_s:.0f} s"

    def figures_for(self, task: str) -> dict[str, object]:
        """What a sweep's ``run.json`` records of the paper beside its own figures."""
        return {
            "variables": self.variables,
            "constraints": self.constraints,
            "seconds_per_solution_mean": self.mean_s,
            "seconds_per_solution_sd": self.sd_s,
            "distinct_optima": self.optima.get(task),
        }


def read_paper_synthesis(path: str | Path = PAPER_SYNTHESIS) -> PaperSynthesis:
    table = pd.read_csv(path, comment="#")

    def rows(quantity):
        return table[table["quantity"] == quantity]

    def single(quantity):
        return float(rows(quantity)["value"].iloc[0])

    shown = rows("quality_shown")
    return PaperSynthesis(
        variables=int(single("nlp_variables")),
        constraints=int(single("nlp_constraints")),
        optima={t: int(v) for t, v in zip(*rows("distinct_local_optima")[["task", "value"]].T.values, strict=True)},
        mean_s=single("mean_seconds_per_solution"),
        sd_s=single("sd_seconds_per_solution"),
        quality_shown={t: list(g["value"]) for t, g in shown.groupby("task", sort=False)},
    )
