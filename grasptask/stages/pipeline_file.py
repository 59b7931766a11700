"""``grasptask pipeline run``: a pipeline file's stages in order, each skipped when unchanged."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from grasptask.paths import as_paths
from grasptask.pipeline.runner import Outcome, PipelineSpec, Stage, load_pipeline, run_pipeline


@dataclass(frozen=True, kw_only=True)
class PipelineOptions:
    """The pipeline file to run; ``force``: run every stage even if unchanged; ``dry_run``: check every stage's
    command line and say which would run, running and writing nothing. ``runner`` runs one stage's command line
    and returns its exit code; ``check`` refuses a stage's command line before any runs (the CLI gives its own,
    so that the runner does not import the CLI)."""

    path: Path
    runner: Callable[[Stage], int]
    check: Callable[[Stage], None] | None = None
    force: bool = False
    dry_run: bool = False

    def __post_init__(self) -> None:
        as_paths(self, "path")


@dataclass(frozen=True)
class PipelineSummary:
    """The pipeline as read, and which of its stages ran, were skipped or failed."""

    spec: PipelineSpec
    outcome: Outcome


def run_pipeline_file(options: PipelineOptions, echo: Callable[[str], Any] = print) -> PipelineSummary:
    """Load and run the pipeline file; ``echo`` hears each stage's progress."""
    spec = load_pipeline(options.path)
    outcome = run_pipeline(
        spec, options.runner, force=options.force, dry_run=options.dry_run, echo=echo, check=options.check
    )
    return PipelineSummary(spec, outcome)
