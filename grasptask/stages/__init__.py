"""Every ``grasptask`` command as a function: inputs and options in, artifacts on disk, a summary out.

The CLI is a thin layer over these, and a notebook can call them directly (or the lower-level functions in
:mod:`grasptask.task`, :mod:`grasptask.synthesis` and :mod:`grasptask.grasp`, which work on arrays and tables
without touching the disk). One module per command; the names below are imported on first use, so that
``grasptask --help`` does not load Pyomo, CasADi or matplotlib.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from grasptask.errors import BadInputError
from grasptask.paths import (
    DEFAULT_GRASP_CONFIG,
    DEFAULT_HAND,
    DEFAULT_OBJECT,
    DEFAULT_PHYSICS_CONFIG,
    DEFAULT_SIMULATE_CONFIG,
    DEFAULT_SOLVER_CONFIG,
)
from grasptask.task.units import FORCE_UNITS, TIME_UNITS, TORQUE_UNITS

if TYPE_CHECKING:
    from grasptask.report.browser import check_page, check_screenshot_path, find_chromium
    from grasptask.stages.distances import run_distances
    from grasptask.stages.export import run_export
    from grasptask.stages.fit_task import FitOptions, Preprocess, entries_from_inputs, run_fit_task
    from grasptask.stages.hand import HandDescription, describe_hand
    from grasptask.stages.physics import PhysicsInputs, run_physics
    from grasptask.stages.pipeline import run_pipeline_file
    from grasptask.stages.report import ReportSummary, build_report
    from grasptask.stages.simulate import run_simulate
    from grasptask.stages.synthesize import SweepInterrupted, SynthesisOptions, run_synthesize, summarise
    from grasptask.stages.verify import run_verify

_LAZY = {
    "run_simulate": "grasptask.stages.simulate",
    "run_fit_task": "grasptask.stages.fit_task",
    "entries_from_inputs": "grasptask.stages.fit_task",
    "FitOptions": "grasptask.stages.fit_task",
    "Preprocess": "grasptask.stages.fit_task",
    "run_distances": "grasptask.stages.distances",
    "describe_hand": "grasptask.stages.hand",
    "HandDescription": "grasptask.stages.hand",
    "SynthesisOptions": "grasptask.stages.synthesize",
    "SweepInterrupted": "grasptask.stages.synthesize",
    "run_synthesize": "grasptask.stages.synthesize",
    "summarise": "grasptask.stages.synthesize",
    "run_verify": "grasptask.stages.verify",
    "build_report": "grasptask.stages.report",
    "ReportSummary": "grasptask.stages.report",
    "check_page": "grasptask.report.browser",
    "check_screenshot_path": "grasptask.report.browser",
    "find_chromium": "grasptask.report.browser",
    "run_pipeline_file": "grasptask.stages.pipeline",
    "PhysicsInputs": "grasptask.stages.physics",
    "run_physics": "grasptask.stages.physics",
    "run_export": "grasptask.stages.export",
}

__all__ = [
    "BadInputError",
    "DEFAULT_GRASP_CONFIG",
    "DEFAULT_HAND",
    "DEFAULT_OBJECT",
    "DEFAULT_PHYSICS_CONFIG",
    "DEFAULT_SIMULATE_CONFIG",
    "DEFAULT_SOLVER_CONFIG",
    "FORCE_UNITS",
    "TIME_UNITS",
    "TORQUE_UNITS",
    "FitOptions",
    "PhysicsInputs",
    "Preprocess",
    "ReportSummary",
    "SweepInterrupted",
    "SynthesisOptions",
    "build_report",
    "check_page",
    "check_screenshot_path",
    "find_chromium",
    "entries_from_inputs",
    "run_distances",
    "describe_hand",
    "HandDescription",
    "run_export",
    "run_fit_task",
    "run_physics",
    "run_pipeline_file",
    "run_simulate",
    "run_synthesize",
    "run_verify",
    "summarise",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'grasptask.stages' has no attribute {name!r}")
