"""``grasptask pipeline run``: a pipeline file's stages, each a command line checked as Click would take it before
any runs, and run in this process through its command's stage (:data:`~grasptask.cli.commands.STAGE_COMMANDS`):
its options made from the parsed line, the stage function, and what the command says of it."""

from __future__ import annotations

from pathlib import Path

import click

from grasptask import stages
from grasptask.cli.commands import STAGE_COMMANDS, StageCommand, run_command
from grasptask.cli.group import main, one_line_errors
from grasptask.stages import BadInputError


@main.group()
def pipeline():
    """Run declarative pipelines (pipelines/*.yaml)."""


@pipeline.command("run")
@click.argument("pipeline_file", type=click.Path(path_type=Path))
@click.option("--force", is_flag=True, help="Run every stage even if its inputs and config are unchanged.")
@click.option(
    "--dry-run", is_flag=True, help="Check every stage's command line and say which would run; run and write nothing."
)
def pipeline_run(**params):
    """Run PIPELINE_FILE's stages in order, skipping a stage whose inputs and config are unchanged. Every
    stage's command line is checked first; a sweep stage stopped part-way goes on where it stopped."""
    run_command("pipeline run", params)


def _pipeline_options(pipeline_file, force, dry_run):
    return stages.PipelineOptions(path=pipeline_file, runner=run_stage, check=check_stage, force=force, dry_run=dry_run)


def _pipeline_said(options, done) -> None:
    if done.outcome.failed:
        raise click.exceptions.Exit(done.outcome.exit_code)
    if done.spec.final_message and not options.dry_run:
        click.echo(done.spec.final_message)


STAGE_COMMANDS["pipeline run"] = StageCommand(
    _pipeline_options, lambda options: stages.run_pipeline_file(options, echo=click.echo), _pipeline_said
)


def _parsed(stage, args: list[str]) -> tuple[click.Command, click.Context | None]:
    """The command a pipeline stage's command line names, and the line parsed and checked as Click would take
    it (None: ``--help``); a line Click refuses is one line naming the stage."""
    command: click.Command = main
    ctx = click.Context(main, info_name="grasptask")
    try:
        while isinstance(command, click.Group):  # a group's own options are none a stage gives
            name, found, args = command.resolve_command(ctx, args)
            if found is None or name is None:
                raise click.UsageError(f"No such command {name!r}.")
            command, ctx = found, click.Context(found, info_name=name, parent=ctx)
        return command, command.make_context(ctx.info_name, list(args), parent=ctx.parent)
    except click.exceptions.Exit:  # --help
        return command, None
    except click.UsageError as exc:
        raise BadInputError(stage.name, f"grasptask {' '.join(stage.run)}: {exc.format_message()}") from None


def check_stage(stage) -> None:
    """A pipeline stage's command line as Click would take it, or one line naming the stage: what ``pipeline
    run`` checks of every stage before it runs any."""
    _parsed(stage, [*stage.run, *stage.args])


def run_stage(stage) -> int:
    """Run one pipeline stage's command in this process, through its stage; its exit code. A command line Click
    refuses (an unknown command or option) is one line naming the stage, not Click's usage block; what the stage
    refuses is one line and exit code 2, as on the command line. A stage to resume runs with ``--resume`` when
    its command has that option."""
    args = [*stage.run, *stage.args]
    command, ctx = _parsed(stage, args)
    resumable = any("--resume" in getattr(p, "opts", ()) for p in command.params)
    if getattr(stage, "resume", False) and resumable and "--resume" not in args:
        _, ctx = _parsed(stage, [*args, "--resume"])  # parsed again only when the line changes
    if ctx is None:  # --help: said, nothing run
        return 0
    try:
        with ctx, one_line_errors(stage.name):
            STAGE_COMMANDS[ctx.command_path.removeprefix("grasptask ")](ctx.params)
    except click.exceptions.Exit as stop:
        return stop.exit_code
    return 0
