"""A sweep's run record, ``run.json``: what ``synthesize`` ran on and how, and what it found.

Only :mod:`grasptask.records.sweeps` reads it and only ``synthesize`` writes it (an import-linter contract), so
that every reader takes each field the same way and a field of the wrong type is the same one line everywhere."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from grasptask.errors import BadInputError
from grasptask.io.config_schema import read_json
from grasptask.records.solutions import STATUSES, retried, solved_with_all_axes, why_few_verified

RUN_FILE = "run.json"

#: the fields readers take, with the type each must have and what that is, said in an error
FIELDS: dict[str, tuple[type | tuple[type, ...], str]] = {
    "task": (str, "a name"),
    "tasks": (str, "a path"),
    "hand": (str, "a path"),
    "object": (str, "a path"),
    "grasp_config": (str, "a path"),
    "fingers": (list, "a list of finger names"),
    "model_size": ((dict, type(None)), "two counts"),
    "log_rows": ((int, type(None)), "a count"),
    "library": ((dict, type(None)), "the grasp library a sweep started from"),
}


def run_file(folder: str | Path) -> Path:
    return Path(folder) / RUN_FILE


def read_run(folder: str | Path) -> dict[str, Any]:
    """The run record in ``folder`` ({} where there is none); a field of the wrong type is one line."""
    path = run_file(folder)
    if not path.is_file():
        return {}
    run = read_json(path)
    for name, (kind, what) in FIELDS.items():
        if name in run and not isinstance(run[name], kind):
            raise BadInputError(path, f"field '{name}' must be {what}, got {run[name]!r}")
    if not all(isinstance(f, str) for f in run.get("fingers") or []):
        raise BadInputError(path, f"field 'fingers' must be a list of finger names, got {run['fingers']!r}")
    size = run.get("model_size") or {}
    if size and not all(isinstance(size.get(k), int) for k in ("variables", "constraints")):
        raise BadInputError(path, f"field 'model_size' must be two counts, got {size!r}")
    return run


def summarised_rows(folder: str | Path) -> int | None:
    """How many rows of the sweep's log its run record summarises; None when it has none, or none readable (a
    sweep interrupted, or running)."""
    try:
        rows = json.loads(run_file(folder).read_text()).get("log_rows")
    except (OSError, ValueError, AttributeError):
        return None
    return rows if isinstance(rows, int) else None


def run_outcome(solutions: pd.DataFrame, optima: pd.DataFrame, task: str, log_rows: int) -> dict:
    """What the sweep found, for run.json: statuses, verified starts, retries and the distinct optima. On the
    search route the verified fraction and why few verified are those of the polished starts, the ones the
    Section 6 NLP solved (a start that joined a basin was not)."""
    again = retried(solutions)
    judged = solutions[solutions["outcome"] == "polished"] if "outcome" in solutions else solutions
    return {
        "starts": int(len(solutions)),
        "log_rows": log_rows,
        "status_counts": {s: int((solutions["status"] == s).sum()) for s in STATUSES},
        "verified": int(solutions["verified"].sum()),
        "verified_fraction": float(judged["verified"].mean()) if len(judged) else 0.0,
        # where few starts verified, why: the hand's strength, or the checks most starts failed (None: most did)
        "why_few_verified": why_few_verified(judged, task),
        # starts solved again from the solver config's retry postures, and those of them the verifier accepted
        "retried_starts": int(again.sum()),
        "verified_on_retry": int((again & solutions["verified"]).sum()),
        # starts with an attempt solved again with eq. 10 for all six task axes (solver config torque_axes)
        "all_axes_starts": int(solved_with_all_axes(solutions).sum()),
        "distinct_optima": int(len(optima)),
        "best_Q": float(optima["Q"].min()) if len(optima) else None,
        # the verifier's own Q of that optimum, which the report shows: the two differ where the NLP's contact
        # model is not the verifier's (a fitted pad sphere against the fingertip's mesh)
        "best_Q_verifier": verifier_q_of_best(optima),
        # the search route's starts: polished, joined a basin without a polish, or a search that failed
        "route": route_outcome(solutions),
    }


def route_outcome(solutions: pd.DataFrame) -> dict | None:
    """What became of the search route's starts (None: the paper's route)."""
    if "outcome" not in solutions:
        return None
    outcome = solutions["outcome"].fillna("search-failed")
    polished = solutions[outcome == "polished"]
    return {
        "name": "search",
        "polished": int(len(polished)),
        "polished_verified": int(polished["verified"].sum()),
        "same_basin": int((outcome == "same-basin").sum()),
        "search_failed": int((outcome == "search-failed").sum()),
        "basins": int(solutions["basin"].nunique()) if "basin" in solutions else 0,
        "polish_model": polish_model(polished),
    }


def polish_model(polished: pd.DataFrame) -> dict | None:
    """The median polish's model where polishes carried only the collision spheres near their grasp (None: every
    polish carried them all)."""
    if "polish_spheres" not in polished or not polished["polish_spheres"].notna().any():
        return None
    columns = {"spheres": "polish_spheres", "variables": "polish_variables", "constraints": "polish_constraints"}
    return {key: int(polished[column].median()) for key, column in columns.items()}


def throughput(solutions: pd.DataFrame, optima: pd.DataFrame, solved: int, wall_seconds: float) -> dict:
    per_second = 1.0 / wall_seconds if wall_seconds > 0 else float("nan")
    best_after = None
    if len(optima) and "found_after_s" in optima:
        value = float(optima.loc[optima["Q"].idxmin(), "found_after_s"])
        best_after = value if np.isfinite(value) else None
    return {
        "starts_per_s": solved * per_second,
        "optima_per_s": len(optima) * per_second,
        "best_Q_after_s": best_after,
    }


def verifier_q_of_best(optima: pd.DataFrame) -> float | None:
    if not len(optima) or "verify_Q" not in optima:
        return None
    value = float(optima.loc[optima["Q"].idxmin(), "verify_Q"])
    return value if np.isfinite(value) else None
