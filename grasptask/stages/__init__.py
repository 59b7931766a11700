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
    from grasptask.report.browser_check import check_page, check_screenshot_path, find_chromium
    from grasptask.stages.fit_task import FitOptions, Preprocess, entries_from_inputs, run_fit_task
    from grasptask.stages.grasp_export import ExportOptions, ExportSummary, run_export
    from grasptask.stages.hand_description import HandDescription, describe_hand
    from grasptask.stages.html_report import ReportSummary, build_report
    from grasptask.stages.physics_check import PhysicsOptions, run_physics
    from grasptask.stages.pipeline_file import run_pipeline_file
    from grasptask.stages.reverify import VerifyOptions, VerifySummary, run_verify
    from grasptask.stages.simulated_recordings import run_simulate
    from grasptask.stages.synthesize import SweepInterrupted, SynthesisOptions, run_synthesize, summarise
    from grasptask.stages.task_distances import run_distances

_LAZY = {
    "run_simulate": "grasptask.stages.simulated_recordings",
    "run_fit_task": "grasptask.stages.fit_task",
    "entries_from_inputs": "grasptask.stages.fit_task",
    "FitOptions": "grasptask.stages.fit_task",
    "Preprocess": "grasptask.stages.fit_task",
    "run_distances": "grasptask.stages.task_distances",
    "describe_hand": "grasptask.stages.hand_description",
    "HandDescription": "grasptask.stages.hand_description",
    "SynthesisOptions": "grasptask.stages.synthesize",
    "SweepInterrupted": "grasptask.stages.synthesize",
    "run_synthesize": "grasptask.stages.synthesize",
    "summarise": "grasptask.stages.synthesize",
    "run_verify": "grasptask.stages.reverify",
    "VerifyOptions": "grasptask.stages.reverify",
    "VerifySummary": "grasptask.stages.reverify",
    "build_report": "grasptask.stages.html_report",
    "ReportSummary": "grasptask.stages.html_report",
    "check_page": "grasptask.report.browser_check",
    "check_screenshot_path": "grasptask.report.browser_check",
    "find_chromium": "grasptask.report.browser_check",
    "run_pipeline_file": "grasptask.stages.pipeline_file",
    "PhysicsOptions": "grasptask.stages.physics_check",
    "run_physics": "grasptask.stages.physics_check",
    "run_export": "grasptask.stages.grasp_export",
    "ExportOptions": "grasptask.stages.grasp_export",
    "ExportSummary": "grasptask.stages.grasp_export",
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
    "ExportOptions",
    "ExportSummary",
    "PhysicsOptions",
    "Preprocess",
    "ReportSummary",
    "SweepInterrupted",
    "SynthesisOptions",
    "VerifyOptions",
    "VerifySummary",
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
