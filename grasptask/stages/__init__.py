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
from grasptask.io.wording import plural
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
    from grasptask.stages.fit_task import FitOptions, FitSummary, FitTaskOptions, Preprocess, run_fit_task
    from grasptask.stages.grasp_export import ExportOptions, ExportSummary, run_export
    from grasptask.stages.hand_description import HandDescription, HandOptions, describe_hand
    from grasptask.stages.html_report import ReportOptions, ReportSummary, run_report
    from grasptask.stages.physics_check import PhysicsOptions, PhysicsSummary, run_physics
    from grasptask.stages.pipeline_file import PipelineOptions, PipelineSummary, run_pipeline_file
    from grasptask.stages.reverify import VerifyOptions, VerifySummary, run_verify
    from grasptask.stages.simulated_recordings import SimulateOptions, SimulateSummary, run_simulate
    from grasptask.stages.synthesize import (
        SweepInterrupted,
        SynthesisOptions,
        SynthesisSummary,
        run_synthesize,
        summarise,
    )
    from grasptask.stages.task_distances import DistanceOptions, DistanceSummary, run_distances

_LAZY = {
    "run_simulate": "grasptask.stages.simulated_recordings",
    "SimulateOptions": "grasptask.stages.simulated_recordings",
    "SimulateSummary": "grasptask.stages.simulated_recordings",
    "run_fit_task": "grasptask.stages.fit_task",
    "FitTaskOptions": "grasptask.stages.fit_task",
    "FitSummary": "grasptask.stages.fit_task",
    "FitOptions": "grasptask.stages.fit_task",
    "Preprocess": "grasptask.stages.fit_task",
    "run_distances": "grasptask.stages.task_distances",
    "DistanceOptions": "grasptask.stages.task_distances",
    "DistanceSummary": "grasptask.stages.task_distances",
    "describe_hand": "grasptask.stages.hand_description",
    "HandOptions": "grasptask.stages.hand_description",
    "HandDescription": "grasptask.stages.hand_description",
    "SynthesisOptions": "grasptask.stages.synthesize",
    "SynthesisSummary": "grasptask.stages.synthesize",
    "SweepInterrupted": "grasptask.stages.synthesize",
    "run_synthesize": "grasptask.stages.synthesize",
    "summarise": "grasptask.stages.synthesize",
    "run_verify": "grasptask.stages.reverify",
    "VerifyOptions": "grasptask.stages.reverify",
    "VerifySummary": "grasptask.stages.reverify",
    "run_report": "grasptask.stages.html_report",
    "ReportOptions": "grasptask.stages.html_report",
    "ReportSummary": "grasptask.stages.html_report",
    "run_pipeline_file": "grasptask.stages.pipeline_file",
    "PipelineOptions": "grasptask.stages.pipeline_file",
    "PipelineSummary": "grasptask.stages.pipeline_file",
    "PhysicsOptions": "grasptask.stages.physics_check",
    "PhysicsSummary": "grasptask.stages.physics_check",
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
    "DistanceOptions",
    "DistanceSummary",
    "ExportOptions",
    "ExportSummary",
    "FitOptions",
    "FitSummary",
    "FitTaskOptions",
    "HandDescription",
    "HandOptions",
    "PhysicsOptions",
    "PhysicsSummary",
    "PipelineOptions",
    "PipelineSummary",
    "Preprocess",
    "ReportOptions",
    "ReportSummary",
    "SimulateOptions",
    "SimulateSummary",
    "SweepInterrupted",
    "SynthesisOptions",
    "SynthesisSummary",
    "VerifyOptions",
    "VerifySummary",
    "describe_hand",
    "plural",
    "run_distances",
    "run_export",
    "run_fit_task",
    "run_physics",
    "run_pipeline_file",
    "run_report",
    "run_simulate",
    "run_synthesize",
    "run_verify",
    "summarise",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'grasptask.stages' has no attribute {name!r}")
