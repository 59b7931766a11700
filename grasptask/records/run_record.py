"""A sweep's run record, ``run.json``: what ``synthesize`` ran on and how, and what it found.

Only :mod:`grasptask.records.sweeps` reads it and only ``synthesize`` writes it (an import-linter contract), so
that every reader takes each field the same way and a field of the wrong type is the same one line everywhere."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from grasptask.errors import BadInputError
from grasptask.io.config_schema import read_json

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
