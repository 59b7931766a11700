"""``grasptask pipeline run``: a pipeline file's stages in order, each skipped when unchanged."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from grasptask.pipeline.runner import Outcome, PipelineSpec, Stage, load_pipeline, run_pipeline


def run_pipeline_file(
    path: str | Path,
    runner: Callable[[Stage], int],
    force: bool = False,
    dry_run: bool = False,
    echo: Callable[[str], Any] = print,
    check: Callable[[Stage], None] | None = None,
) -> tuple[PipelineSpec, Outcome]:
    """Load and run the pipeline file at ``path``; ``runner`` runs one stage's command and returns its exit
    code, ``check`` refuses a stage's command line before any runs (the CLI passes its own, so that the runner
    does not import the CLI)."""
    spec = load_pipeline(path)
    return spec, run_pipeline(spec, runner, force=force, dry_run=dry_run, echo=echo, check=check)
