"""``grasptask``: the command-line interface, a thin layer over :mod:`grasptask.stages`: the command group
(:mod:`~grasptask.cli.group`), the option groups commands share (:mod:`~grasptask.cli.options`), the stage
commands (:mod:`~grasptask.cli.commands`), what each says when done (:mod:`~grasptask.cli.summaries`) and
``pipeline run`` (:mod:`~grasptask.cli.pipeline_run`)."""

from grasptask.cli import commands, pipeline_run  # noqa: F401 - each registers its commands on the group
from grasptask.cli.group import main
from grasptask.cli.pipeline_run import check_stage, run_stage

__all__ = ["check_stage", "main", "run_stage"]
