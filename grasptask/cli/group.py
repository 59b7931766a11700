"""The ``grasptask`` command group: bad input, an unwritable output folder and a stop each become one line and
an exit code, never a traceback or a half-written artifact."""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import click

from grasptask import __version__
from grasptask.stages import BadInputError


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


@contextmanager
def one_line_errors(where: str) -> Iterator[None]:
    """:class:`BadInputError`, and an output folder that cannot be written (read-only, a full disk), as one line
    on stderr and exit code 2; a stop as exit code 130. ``where`` names what ran, for an error without a file."""
    try:
        yield
    except BadInputError as exc:
        click.echo(f"error: {exc}", err=True)
        raise click.exceptions.Exit(2) from None
    except OSError as exc:
        click.echo(f"error: {exc.filename or where}: {exc.strerror or exc}", err=True)
        raise click.exceptions.Exit(2) from None
    except KeyboardInterrupt:
        click.echo("interrupted: nothing half-written was kept", err=True)
        raise click.exceptions.Exit(130) from None


class _Group(click.Group):
    """Errors as :func:`one_line_errors` says them; SIGTERM as the same orderly stop as Ctrl-C (exit code 130),
    so that no half-written artifact, staging folder or lock is left behind."""

    def invoke(self, ctx):
        main_thread = threading.current_thread() is threading.main_thread()
        previous: dict[int, Any] = {}
        if main_thread:
            # a parent may hand down SIGINT ignored or a mask that blocks it (a test runner's or a script's
            # background job): a stop must get through from the start, as it does once a sweep runs
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})
            previous = {
                signal.SIGINT: signal.signal(signal.SIGINT, signal.default_int_handler),
                signal.SIGTERM: signal.signal(signal.SIGTERM, _interrupt),
            }
        try:
            with one_line_errors(ctx.invoked_subcommand or "grasptask"):
                return super().invoke(ctx)
        finally:
            for number, handler in previous.items():
                signal.signal(number, handler)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="grasptask")
def main():
    """Task-oriented grasps for a multi-fingered hand, from sensorized-tool demonstrations.

    \b
    Stages read and write files:
      simulate (or your recordings) -> fit-task -> distances   the tasks' ellipsoids, compared
      synthesize -> verify, physics                            grasps, and their two judges
      export, report                                           for other tools, and for people
      hand FILE                                                what grasptask reads in your hand
    Run `grasptask COMMAND --help` for each, or `grasptask pipeline run pipelines/demo.yaml` for them all.
    """
