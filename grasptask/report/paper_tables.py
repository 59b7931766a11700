"""The paper's Tables 1-10 recomputed beside the published values, and the synthesis figures beside
Section 7.3 and Tables 11-12."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from grasptask.records.reference import PaperSynthesis
from grasptask.records.solutions import retried
from grasptask.report.inputs import paper_setup, verifier_q
from grasptask.task.stats import compare_with_reference

DRAWING_GROUPS = ("drawing_tripod", "drawing_cylindrical", "drawing_power")
#: Tables 6-10 compare the tasks; their drawing rows are the tripod-grasp group
TASK_GROUPS = ("drawing_tripod", "cutting", "screwdriving")
RAW = ("mu", "sigma", "cv")
NORMALISED = ("mu_n", "sigma_n", "cv_n")


@dataclass(frozen=True)
class PaperTable:
    number: int
    title: str
    groups: tuple[str, ...]
    domains: tuple[str, ...]
    stats: tuple[str, ...]


def _tables() -> list[PaperTable]:
    tables = []
    for first, groups, subject in ((1, DRAWING_GROUPS, "circles drawing, 3 grasp types"), (6, TASK_GROUPS, "3 tasks")):
        tables += [
            PaperTable(first, f"Force ellipsoid axis lengths (N), {subject}", groups, ("force",), RAW),
            PaperTable(first + 1, f"Torque ellipsoid axis lengths (N.cm), {subject}", groups, ("torque",), RAW),
            PaperTable(
                first + 2, f"Normalised force ellipsoid axis lengths, {subject}", groups, ("force",), NORMALISED
            ),
            PaperTable(
                first + 3, f"Normalised torque ellipsoid axis lengths, {subject}", groups, ("torque",), NORMALISED
            ),
            PaperTable(
                first + 4,
                f"Normalised extent of the ellipsoids along the object axes x, y, z, {subject}",
                groups,
                ("force", "torque"),
                ("proj",),
            ),
        ]
    return tables


PAPER_TABLES = _tables()


def comparison(stats: pd.DataFrame, reference: pd.DataFrame, table: PaperTable) -> pd.DataFrame:
    """One row per (group, domain, axis); per statistic the recomputed value, the paper's and the difference.
    Groups the run did not produce are left out (the caller says so)."""
    joined = compare_with_reference(stats, reference)
    joined = joined[
        joined["group"].isin(table.groups) & joined["domain"].isin(table.domains) & joined["stat"].isin(table.stats)
    ]
    if joined.empty:
        return pd.DataFrame()
    long = joined.melt(
        id_vars=["group", "domain", "axis", "stat"],
        value_vars=["value", "paper", "difference"],
        var_name="kind",
        value_name="number",
    )
    wide = long.pivot_table(index=["group", "domain", "axis"], columns=["stat", "kind"], values="number")
    labels = {"value": "", "paper": " paper", "difference": " diff"}
    wide = wide.reindex(columns=[(s, k) for s in table.stats for k in labels if (s, k) in wide.columns])
    wide.columns = [f"{s}{labels[k]}" for s, k in wide.columns]
    order = {g: i for i, g in enumerate(table.groups)}
    wide = wide.reset_index()
    wide = wide.sort_values(["group", "domain", "axis"], key=lambda c: c.map(order) if c.name == "group" else c)
    if len(table.domains) == 1:
        wide = wide.drop(columns="domain")
    return wide.round(3).reset_index(drop=True)


def groups_not_in_paper(stats: pd.DataFrame, reference: pd.DataFrame) -> pd.DataFrame:
    """The axis-length statistics of the groups the paper does not have, one row per (group, domain, axis)."""
    own = stats[~stats["group"].isin(set(reference["group"])) & stats["stat"].isin(RAW + NORMALISED)]
    if own.empty:
        return pd.DataFrame()
    wide = own.pivot_table(index=["group", "domain", "axis"], columns="stat", values="value", sort=False)
    return wide.reindex(columns=[s for s in RAW + NORMALISED if s in wide.columns]).round(3).reset_index()


def largest_differences(stats: pd.DataFrame, reference: pd.DataFrame) -> dict:
    """A summary for the page: the largest absolute differences of normalised values and of raw means."""
    joined = compare_with_reference(stats, reference)
    normalised = joined[joined["stat"].isin(["mu_n", "proj"])]
    raw = joined[joined["stat"] == "mu"]
    relative = (raw["difference"].abs() / raw["paper"].abs()).replace(np.inf, np.nan)
    return {
        "compared_values": int(len(joined)),
        "max_abs_diff_normalised": float(normalised["difference"].abs().max()) if len(normalised) else None,
        "max_rel_diff_raw_mu": float(relative.max()) if len(relative) else None,
    }


def _median(solutions: pd.DataFrame, verified: pd.Series, column: str) -> float | None:
    """The median of a verifier figure over the verified grasps (None: a table without it, or none verified)."""
    if column not in solutions or not verified.any():
        return None
    return round(float(solutions.loc[verified, column].astype(float).median()), 3)


def sweep_table(sweeps: dict, paper: PaperSynthesis) -> pd.DataFrame:
    """Per task: starts, statuses, verified fraction, distinct optima, the verified grasps' median strength margin
    and friction needed, and time per start, beside the paper."""
    rows = []
    for task, sweep in sweeps.items():
        seconds = sweep.table["seconds"].astype(float)
        statuses = sweep.table["status"].value_counts()
        verified = sweep.table["verified"]
        on_retry = int((verified & retried(sweep.table)).sum())
        rows.append(
            {
                "task": task,
                "starts": len(sweep.table),
                "statuses": ", ".join(f"{s} {n}" for s, n in statuses.items()),
                "verified": f"{int(verified.sum())} ({verified.mean():.0%}; {on_retry} on a retry)",
                "distinct optima": len(sweep.optima),
                "paper optima": paper.optima.get(task) if paper_setup(sweep.files) else None,
                "median strength margin": _median(sweep.table, verified, "verify_strength_margin"),
                "median friction needed": _median(sweep.table, verified, "verify_friction_margin"),
                "median s/start": round(float(seconds.median()), 2),
                "p90 s/start": round(float(np.percentile(seconds, 90)), 2),
                "mean +- sd s/start": f"{seconds.mean():.1f} +- {seconds.std(ddof=1) if len(seconds) > 1 else 0:.1f}",
                "paper s/solution": f"{paper.mean_s:.0f} +- {paper.sd_s:.0f}" if paper_setup(sweep.files) else None,
                "paper mean / our median": round(paper.mean_s / float(seconds.median()), 1)
                if paper_setup(sweep.files)
                else None,
            }
        )
    return _without_empty_paper_columns(pd.DataFrame(rows))


def _without_empty_paper_columns(table: pd.DataFrame) -> pd.DataFrame:
    """The paper's columns only where a row is of the paper's own setup (the human hand, its tool, its tasks)."""
    empty = [c for c in table.columns if "paper" in c and table[c].isna().all()]
    return table.drop(columns=empty).fillna({c: "-" for c in table.columns if "paper" in c and c not in empty})


def quality_table(sweeps: dict, paper: PaperSynthesis, shown_q: dict | None = None) -> pd.DataFrame:
    """Tables 11-12: the Q of every distinct optimum (best first), with the values the paper shows. ``shown_q``:
    the Q the report's views show, by (task, optimum), where the verifier was run again."""
    rows = []
    for task, sweep in sweeps.items():
        shown = (
            ", ".join(f"{v:g}" for v in paper.quality_shown.get(task, [])) or "-" if paper_setup(sweep.files) else None
        )
        for _, optimum in sweep.optima.iterrows():
            rows.append(
                {
                    "task": task,
                    "optimum": int(optimum["optimum_id"]),
                    "Q": (shown_q or {}).get((task, int(optimum["optimum_id"])), verifier_q(optimum)),
                    "starts reaching it": int(optimum["members"]),
                    "epsilon": round(float(optimum.get("verify_epsilon", np.nan)), 4),
                    "torque effort": round(float(optimum.get("verify_torque_effort", np.nan)), 3),
                    "strength margin": round(float(optimum.get("verify_strength_margin", np.nan)), 3),
                    "friction needed": round(float(optimum.get("verify_friction_margin", np.nan)), 3),
                    "Q shown in the paper": shown,
                }
            )
    return _without_empty_paper_columns(pd.DataFrame(rows))
