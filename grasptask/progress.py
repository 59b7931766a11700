"""Progress on long stages: a bar on a terminal; when stderr is not one (a log file, CI, a batch job), a short
line at intervals and one at the end, with what is done, the stage's own counts and the time left.

A log never goes quiet for longer than the interval while a stage runs: where nothing has been said for that
long (a start that takes minutes, a model that takes ten to build), a heartbeat says what is running and for how
long, with the counts so far. What runs is registered by whoever runs it (:func:`working`, :func:`finished`).

The interval is ``GRASPTASK_PROGRESS_S`` seconds (default 30; 0 prints a line for every item, and no
heartbeat)."""

from __future__ import annotations

import functools
import os
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import ExitStack, contextmanager, nullcontext
from dataclasses import dataclass
from typing import IO, Any, ParamSpec, TypeVar

from tqdm import tqdm

from grasptask.errors import BadInputError

T = TypeVar("T")
R = TypeVar("R")
P = ParamSpec("P")
INTERVAL_ENV = "GRASPTASK_PROGRESS_S"
DEFAULT_INTERVAL_S = 30.0


def interval_s() -> float:
    """The seconds between two progress lines, from ``GRASPTASK_PROGRESS_S``."""
    text = os.environ.get(INTERVAL_ENV, "").strip()
    if not text:
        return DEFAULT_INTERVAL_S
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not value >= 0 or value == float("inf"):
        raise BadInputError(INTERVAL_ENV, f"must be a non-negative number of seconds, got {text!r}")
    return value


#: when the running stage began (None: no stage is timed), so that its progress counts its set-up too
_stage_began: float | None = None


def timed_stage(stage: Callable[P, R]) -> Callable[P, R]:
    """``stage`` with every progress line within it counting its elapsed time from the stage's start: a sweep
    that took 30 s said "9 s elapsed", its model building left out."""

    @functools.wraps(stage)
    def timed(*args: P.args, **kwargs: P.kwargs) -> R:
        global _stage_began
        outer = _stage_began
        _stage_began = time.monotonic() if outer is None else outer
        try:
            return stage(*args, **kwargs)
        finally:
            _stage_began = outer

    return timed


#: a set-up that takes longer than this says what it prepares (a quick one, or a refusal, stays quiet)
SAY_PREPARING_AFTER_S = 3.0


#: what the heartbeat speaks of: the stages' bars and set-ups under way (innermost last), the work running (by
#: key: a label and when it began), and when a line was last said
_lock = threading.Lock()
_active: list[Any] = []
_running: dict[Any, tuple[str, float]] = {}
_last_said = [0.0]
_beating: list[threading.Thread] = []
#: set when a stage starts to be heard, so that the heartbeat reads its interval at once, not after its last sleep
_wake = threading.Event()


def _said(text: str, stream: IO[str] | None = None) -> None:
    """Print a progress line, and note when (the heartbeat waits an interval from the last)."""
    print(text, file=stream if stream is not None else sys.stderr, flush=True)
    _last_said[0] = time.monotonic()


def working(key: Any, label: str) -> None:
    """``label`` (``start 17``) is running from now, under ``key``; the heartbeat says it with its time."""
    with _lock:
        _running[key] = (label, time.monotonic())


def finished(key: Any) -> None:
    with _lock:
        _running.pop(key, None)


@dataclass
class _SetUp:
    """A set-up under way (:func:`preparing`): what it prepares, since when, and where it speaks."""

    message: str
    began: float
    speak: Callable[[str], object]


@contextmanager
def _active_while(item: Any) -> Iterator[None]:
    """``item`` is what the heartbeat speaks of while the block runs."""
    with _lock:
        _active.append(item)
        _last_said[0] = max(_last_said[0], time.monotonic())
        _start_heartbeat()
        _wake.set()
    try:
        yield
    finally:
        with _lock:
            _active.remove(item)


def _start_heartbeat() -> None:
    """One daemon thread for the process, started with the first stage that is to be heard (under the lock)."""
    if _beating and _beating[0].is_alive():
        return
    thread = threading.Thread(target=_heartbeat, name="grasptask-heartbeat", daemon=True)
    _beating[:] = [thread]
    thread.start()


def _heartbeat() -> None:
    while True:
        every = _interval_or_none()
        _wake.wait(min(1.0, every / 4) if every else 1.0)
        _wake.clear()
        every = _interval_or_none()
        with _lock:
            if not _active:
                continue
            now = time.monotonic()
            if not every or now - _last_said[0] < every:
                continue
            top = _active[-1]
            line = (
                top.line(now)
                if isinstance(top, Progress)
                else f"{top.message} still at it, {_minutes(now - top.began)}"
            )
            running = sorted(_running.values(), key=lambda item: item[1])
            if running:
                shown = ", ".join(f"{label} for {_minutes(now - began)}" for label, began in running[:6])
                line += f"; running: {shown}" + (f" and {len(running) - 6} more" if len(running) > 6 else "")
            _last_said[0] = now
        try:
            if isinstance(top, Progress):
                if top.bar is None:
                    _said(line, top.stream)
            else:
                top.speak(line)
        except (OSError, ValueError):  # a stream closed under it (a stage that ended meanwhile): said nothing
            continue


def _interval_or_none() -> float | None:
    """The heartbeat's interval; None where a bad setting is left for the stage itself to refuse."""
    try:
        return interval_s()
    except BadInputError:
        return None


@contextmanager
def preparing(message: str, say: Callable[[str], object] | None = None) -> Iterator[None]:
    """Say ``message`` (on stderr, or with ``say``) once the work inside has taken :data:`SAY_PREPARING_AFTER_S`,
    and again with its time at every interval it goes on: a physics check that built its scenes for 50 s said
    nothing until its first grasp, a 21,284-variable model nothing for 11 minutes."""
    speak = say if say is not None else _said
    timer = threading.Timer(SAY_PREPARING_AFTER_S, speak, args=(message,))
    timer.daemon = True
    terminal = bool(getattr(sys.stderr, "isatty", lambda: False)())
    heard = nullcontext() if terminal and say is None else _active_while(_SetUp(message, time.monotonic(), speak))
    with heard:
        timer.start()
        try:
            yield
        finally:
            timer.cancel()


@contextmanager
def building(what: str) -> Iterator[list[str]]:
    """Make something slow: say ``what`` once it has taken :data:`SAY_PREPARING_AFTER_S`, then how long it took,
    with the notes the body adds (where it was kept); a quick one stays quiet."""
    notes: list[str] = []
    began = time.monotonic()
    with preparing(f"{what} ..."):
        yield notes
    took = time.monotonic() - began
    if took >= SAY_PREPARING_AFTER_S:
        _said(f"{what}: done in {_minutes(took)}" + "".join(f"; {n}" for n in notes))


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


class Progress:
    """``update(n, **counts)`` after each item; ``counts`` (e.g. ``verified=3, failing=1``) are shown as they
    stand. Use as a context manager, or call :meth:`close`."""

    def __init__(
        self, total: int, desc: str, unit: str = "it", initial: int = 0, stream: IO[str] | None = None
    ) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.terminal = bool(getattr(self.stream, "isatty", lambda: False)())
        self.total, self.desc, self.unit, self.initial, self.done = total, desc, unit, initial, initial
        self.counts: dict[str, Any] = {}
        self.every = 0.0 if self.terminal else interval_s()
        # the stage's clock for the time elapsed, this bar's for the rate the time left is reckoned at
        self.counting = self.last = time.monotonic()
        self.began = _stage_began if _stage_began is not None else self.counting
        self.bar = tqdm(total=total, initial=initial, desc=desc, unit=unit, file=self.stream, leave=False) if (
            self.terminal
        ) else None  # fmt: skip
        if self.bar is not None:  # the bar's clock from the stage's start too
            self.bar.start_t -= self.counting - self.began
        self._heard = ExitStack()
        if self.bar is None and self.every > 0:  # a log: the heartbeat speaks of it while it runs
            self._heard.enter_context(_active_while(self))

    def update(self, n: int = 1, **counts: Any) -> None:
        self.done += n
        self.counts.update(counts)
        if self.bar is not None:
            if counts:
                self.bar.set_postfix(self.counts, refresh=False)
            self.bar.update(n)
            return
        now = time.monotonic()
        if now - self.last >= self.every and self.done < self.total:
            self.last = now
            _said(self.line(now), self.stream)

    def line(self, now: float | None = None) -> str:
        """``desc: done/total unit (percent), counts, elapsed, time left``."""
        now = now if now is not None else time.monotonic()
        elapsed = now - self.began
        parts = [f"{self.desc}: {self.done}/{self.total} {self.unit}"]
        if self.total:
            parts[0] += f" ({self.done / self.total:.0%})"
        parts += [f"{name} {value}" for name, value in self.counts.items()]
        parts.append(f"{_minutes(elapsed)} elapsed")
        this_run = self.done - self.initial
        if 0 < this_run and self.done < self.total:
            parts.append(f"about {_minutes((now - self.counting) / this_run * (self.total - self.done))} left")
        return ", ".join(parts)

    def close(self, finished: bool = True) -> None:
        """Close the bar, or print the last line, so that a log shows how the stage ended (not when it failed:
        the error is then the one line to read)."""
        self._heard.close()
        if self.bar is not None:
            self.bar.close()
        elif finished and self.done > self.initial:
            _said(self.line(), self.stream)
        self.bar, self.done, self.initial = None, 0, 0  # closed: a second close prints nothing

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *_: object) -> None:
        self.close(finished=exc_type is None)


def progress(items: Iterable[T], desc: str, unit: str = "it") -> Iterator[T]:
    """``items``, with :class:`Progress` over them."""
    listed = list(items)
    shown = Progress(len(listed), desc, unit)
    try:
        for item in listed:
            yield item
            shown.update()
    except BaseException:  # GeneratorExit too: the consumer stopped early, or failed
        shown.close(finished=False)
        raise
    shown.close()
