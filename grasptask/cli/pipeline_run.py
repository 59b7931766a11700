"""``grasptask pipeline run``: a pipeline file's stages, each a command line checked as Click would take it before
any runs, and run in this process."""

from __future__ import annotations

from pathlib import Path

import click

from grasptask import stages
from grasptask.cli.group import main
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
def pipeline_run(pipeline_file, force, dry_run):
    """Run PIPELINE_FILE's stages in order, skipping a stage whose inputs and config are unchanged. Every
    stage's command line is checked first; a sweep stage stopped part-way goes on where it stopped."""
    spec, outcome = stages.run_pipeline_file(
        pipeline_file, run_stage, force=force, dry_run=dry_run, echo=click.echo, check=check_stage
    )
    if outcome.failed:
        raise click.exceptions.Exit(outcome.exit_code)
    if spec.final_message and not dry_run:
        click.echo(spec.final_message)


def _stage_command(stage) -> click.Command:
    """The command a pipeline stage's command line runs, its options parsed and checked as Click would parse
    them, without running it; a command line Click refuses is one line naming the stage."""
    args = [*stage.run, *stage.args]
    command: click.Command = main
    ctx = click.Context(main, info_name="grasptask")
    try:
        while isinstance(command, click.Group):  # a group's own options are none a stage gives
            name, found, args = command.resolve_command(ctx, args)
            if found is None or name is None:
                raise click.UsageError(f"No such command {name!r}.")
            command, ctx = found, click.Context(found, info_name=name, parent=ctx)
        command.make_context(ctx.info_name, list(args), parent=ctx.parent)
    except click.exceptions.Exit:  # --help
        pass
    except click.UsageError as exc:
        raise BadInputError(stage.name, f"grasptask {' '.join(stage.run)}: {exc.format_message()}") from None
    return command


def check_stage(stage) -> None:
    """A pipeline stage's command line as Click would take it, or one line naming the stage: what ``pipeline
    run`` checks of every stage before it runs any."""
    _stage_command(stage)


def run_stage(stage) -> int:
    """Run one pipeline stage's command in this process; its exit code. A command line Click refuses (an
    unknown command or option) is one line naming the stage, not Click's usage block. A stage to resume runs
    with ``--resume`` when its command has that option."""
    args = [*stage.run, *stage.args]
    resumable = any("--resume" in getattr(p, "opts", ()) for p in _stage_command(stage).params)
    if getattr(stage, "resume", False) and resumable and "--resume" not in args:
        args.append("--resume")
    try:
        code = main.main(args=args, prog_name="grasptask", standalone_mode=False)
    except click.UsageError as exc:
        raise BadInputError(stage.name, f"grasptask {' '.join(stage.run)}: {exc.format_message()}") from None
    return code if isinstance(code, int) else 0
