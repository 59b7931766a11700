"""Solving many starts: in this process, on a pool of processes that survives crashed and hung workers, or on a
Dask cluster.

An executor is started first (:meth:`Executor.start`): it returns the model size once a worker has built the
model, or fails with one line when none can, so that nothing of an earlier sweep is touched before the run is
known to work. :meth:`Executor.run` then solves the starts, handing each row to ``on_result`` as it finishes.
A start whose worker dies is recorded as ``crashed``, one that outlives its time limit by the configured grace
as ``hung``; either way the worker is replaced and the sweep goes on.

Stopping (:func:`graceful_stop`): the first Ctrl-C or SIGTERM stops handing out starts and waits for the ones
in progress, so they are recorded, not lost; a second one stops at once.
"""

from __future__ import annotations

import itertools
import multiprocessing as mp
import os
import queue
import signal
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, Protocol

from grasptask.errors import BadInputError
from grasptask.io.child_processes import UNGUARDED_SCRIPT_EXIT, die_with_parent
from grasptask.progress import finished, working
from grasptask.synthesis.context import Job, SolverContext, build_failure, failed_row, solve_guarded
from grasptask.synthesis.starts import Start

OnResult = Callable[[Any], None]


def _unguarded(procs: Any) -> BadInputError | None:
    """The one-line refusal when a worker ended on the user's unguarded script (None: none did)."""
    if not any(proc.exitcode == UNGUARDED_SCRIPT_EXIT for proc, _ in procs):
        return None
    import __main__

    script = getattr(__main__, "__file__", None) or "your script"
    return BadInputError(
        script,
        "the sweep runs at import, and every solver worker re-imports the script: put it under `if __name__ == "
        '"__main__":`, or use executor="serial"',
    )


#: set by the first SIGINT or SIGTERM: hand out no more starts, finish the ones in progress
STOP = threading.Event()
#: set by the second: stop now
FORCE = threading.Event()


def _check_stop() -> None:
    if FORCE.is_set() or STOP.is_set():
        raise KeyboardInterrupt


@contextmanager
def graceful_stop(notify: Callable[[str], Any] = print) -> Iterator[None]:
    """Within this block the first SIGINT or SIGTERM sets :data:`STOP` (and says so), the second sets
    :data:`FORCE` and interrupts at once."""
    STOP.clear()
    FORCE.clear()
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: Any) -> None:
        if STOP.is_set():
            FORCE.set()
            raise KeyboardInterrupt
        STOP.set()
        notify(f"{signal.Signals(signum).name}: finishing the starts in progress (again to stop at once)")

    previous = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
        STOP.clear()
        FORCE.clear()


class Executor(Protocol):
    """Runs a worker's jobs (starts of the paper's route, searches, polishes: anything with a ``start_id``) and
    hands each result to ``on_result`` as it comes in."""

    def start(self) -> dict[str, int]: ...

    def run(self, starts: list[Any], on_result: OnResult) -> None: ...

    def close(self) -> None: ...


def _label(start: Any) -> str:
    """What a log's heartbeat calls a start (a search's, a polish's) while it runs."""
    if type(start).__name__ == "SearchBatch":
        ids = [s.start_id for s in start.starts]
        return f"search of starts {ids[0]}-{ids[-1]}" if len(ids) > 1 else f"search of start {ids[0]}"
    kind = "polish of start" if type(start).__name__ == "Polish" else "start"
    return f"{kind} {getattr(start, 'start_id', '?')}"


class SerialExecutor:
    """Every start in this process, one after the other."""

    def __init__(self, job: Job):
        self.job = job
        self.context: SolverContext | None = None

    def start(self) -> dict[str, int]:
        try:
            self.context = SolverContext(self.job)
        except BadInputError:
            raise
        except Exception as exc:  # noqa: BLE001 - one line, naming what failed
            raise BadInputError("synthesize", f"the model could not be built: {build_failure(exc)}") from exc
        return self.context.size

    def run(self, starts: list[Start], on_result: OnResult) -> None:
        assert self.context is not None, "start() first"
        for start in starts:
            _check_stop()
            working(self, _label(start))
            try:
                row = solve_guarded(self.context, start)
            finally:
                finished(self)
            on_result(row)
        _check_stop()

    def close(self) -> None:
        self.context = None


def _worker(tasks: Any, results: Any, worker_id: int) -> None:
    """A pool worker: its job (the first item on its queue), its models built, then its starts one by one."""
    die_with_parent()  # at once, rather than at its next poll of the parent (_next_start)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    # the parent decides when to stop and ends its workers: a Ctrl-C or SIGTERM to the process group must not
    # kill a start half-way (it would be recorded as crashed)
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)
    job = _next_start(tasks, mp.parent_process())
    if job is None:
        return
    try:
        context = SolverContext(job)
    except Exception as exc:  # noqa: BLE001
        results.put(("failed", worker_id, (build_failure(exc), traceback.format_exc())))
        return
    results.put(("ready", worker_id, context.size))
    parent = mp.parent_process()
    while (start := _next_start(tasks, parent)) is not None:
        results.put(("done", worker_id, solve_guarded(context, start)))


def _next_start(tasks: Any, parent: Any, poll_s: float = 1.0) -> Any:
    """The worker's next start, or None when the parent says stop or has died: a sweep killed outright
    (SIGKILL) cannot end its workers, which would otherwise wait on their queues for ever."""
    while True:
        try:
            return tasks.get(timeout=poll_s)
        except queue.Empty:
            if parent is not None and not parent.is_alive():
                return None


class PoolExecutor:
    """Starts on ``workers`` processes. The parent hands each worker one start at a time through the worker's
    own queue, so it always knows which start a worker holds: a worker that dies (a message it was sending may
    die with it) or outlives the hang limit is replaced, and its start is recorded as ``crashed`` or ``hung``."""

    def __init__(self, job: Job, workers: int, hang_after_s: float, max_restarts: int = 20):
        self.job, self.workers, self.hang_after_s, self.max_restarts = job, workers, hang_after_s, max_restarts
        self.ctx = mp.get_context("spawn")
        self.results = self.ctx.Queue()
        self.procs: dict[int, tuple[Any, Any]] = {}  # worker id -> (process, its task queue)
        self.ready: list[int] = []
        self._ids = itertools.count()
        self._restarts = 0

    def _spawn(self) -> None:
        """A worker, handed its job through its queue. Not as the process's argument: that is written to the new
        process in one go while it imports the user's script, and a script that ends it there (a sweep at import,
        :func:`~grasptask.io.child_processes.refuse_in_worker_import`) left this process blocked on the write for
        ever. The queue's feeder thread writes instead, and is not waited for at exit."""
        worker_id = next(self._ids)
        tasks = self.ctx.Queue()
        tasks.cancel_join_thread()
        proc = self.ctx.Process(target=_worker, args=(tasks, self.results, worker_id), daemon=True)
        proc.start()
        tasks.put(self.job)
        self.procs[worker_id] = (proc, tasks)

    def start(self) -> dict[str, int]:
        """Spawn the workers and wait until the first has built the model."""
        for _ in range(self.workers):
            self._spawn()
        while True:
            _check_stop()
            try:
                kind, worker_id, payload = self.results.get(timeout=0.5)
            except queue.Empty:
                refusal = _unguarded(self.procs.values())
                if refusal is not None:
                    raise refusal from None
                if not any(proc.is_alive() for proc, _ in self.procs.values()):
                    raise BadInputError("synthesize", "every solver worker died while building the model") from None
                continue
            if kind == "failed":
                raise BadInputError("synthesize", f"a solver worker could not build the model: {payload[0]}")
            if kind == "ready":
                self.ready.append(worker_id)
                return payload

    def run(self, starts: list[Start], on_result: OnResult) -> None:
        pending = list(starts)
        holding: dict[int, tuple[Start, float]] = {}

        def assign(worker_id: int) -> None:
            if pending and worker_id in self.procs and not STOP.is_set():
                start = pending.pop(0)
                holding[worker_id] = (start, time.time())
                working((self, worker_id), _label(start))
                self.procs[worker_id][1].put(start)

        for worker_id in self.ready:
            assign(worker_id)
        while pending or holding:
            if FORCE.is_set():
                raise KeyboardInterrupt
            if STOP.is_set() and not holding:
                raise KeyboardInterrupt  # the starts in progress are recorded; the rest wait for --resume
            try:
                kind, worker_id, payload = self.results.get(timeout=0.5)
            except queue.Empty:
                kind = None
            if kind == "failed":
                raise BadInputError("synthesize", f"a solver worker could not build the model: {payload[0]}")
            if kind == "ready":  # a worker that built its model after start(): it serves later runs too
                self.ready.append(worker_id)
                assign(worker_id)
            elif kind == "done" and worker_id in holding:
                holding.pop(worker_id)
                finished((self, worker_id))
                on_result(payload)
                assign(worker_id)
            self._replace_lost(holding, on_result, spawn=bool(pending) and not STOP.is_set())

    def _replace_lost(self, holding: dict[int, tuple[Start, float]], on_result: OnResult, spawn: bool) -> None:
        """Record the start of every worker that died or hung, and replace the worker."""
        now = time.time()
        for worker_id, (proc, _) in list(self.procs.items()):
            held = holding.get(worker_id)
            hung = held is not None and now - held[1] > self.hang_after_s
            if proc.is_alive() and not hung:
                continue
            if hung:
                proc.kill()
            proc.join(timeout=5)
            self.procs.pop(worker_id)
            if held is not None:
                holding.pop(worker_id)
                finished((self, worker_id))
                start, began = held
                message = f"worker killed after {now - began:.0f} s" if hung else f"worker exit code {proc.exitcode}"
                on_result(failed_row(start, "hung" if hung else "crashed", now - began, message))
            else:
                self._restarts += 1
                if self._restarts > self.max_restarts:
                    raise BadInputError("synthesize", "solver workers keep dying before they are ready")
            if spawn:
                self._spawn()

    def close(self) -> None:
        for _, tasks in self.procs.values():
            tasks.put(None)
        # idle workers exit at once, but one holding a GP object's model takes seconds to free it
        grace = 2 if FORCE.is_set() else 30
        for proc, _ in self.procs.values():
            proc.join(timeout=grace)
            if proc.is_alive():
                proc.kill()
        self.procs.clear()


_DASK_CONTEXTS: dict = {}
#: one build or solve at a time in a Dask worker process. A worker runs a task on each of its threads (one per
#: core by default): two threads solving one shared model crashed it (``free(): invalid next size``, then signal
#: 11), and with a model each they took turns on the GIL, so that a solve's wall-clock limit counted the other's
#: time (half of 4 starts ended "time-limit" that solve in a process of their own)
_DASK_LOCK = threading.Lock()


def _dask_context(job: Job) -> SolverContext:
    """Runs on a Dask worker, under :data:`_DASK_LOCK`: the context is built once per worker process and job."""
    key = (os.getpid(), job.key)
    if key not in _DASK_CONTEXTS:
        from threadpoolctl import threadpool_limits  # deferred: only in pool workers

        threadpool_limits(1)  # a worker's environment is not ours: one BLAS thread per solve, as in the pool
        _DASK_CONTEXTS[key] = SolverContext(job)
    return _DASK_CONTEXTS[key]


def _the_job(job: Job) -> Job:
    return job


def _dask_size(job: Job) -> dict[str, int]:
    with _DASK_LOCK:
        return _dask_context(job).size


def _dask_solve(job: Job, start: Start) -> dict:
    with _DASK_LOCK:  # the time a start waits here is not its solve's: its clock starts inside
        return solve_guarded(_dask_context(job), start)


class DaskExecutor:
    """Starts on a Dask cluster. The scheduler exchanges pickles, so its address is trusted to run code.

    A cluster cannot say which starts are in progress: the first Ctrl-C cancels the rest, and ``--resume``
    solves what was not recorded. While the scheduler has no worker the sweep waits, and says so."""

    #: how long (s) the scheduler may go without a worker before the sweep says so, and how often it asks
    SAY_NO_WORKER_AFTER_S, WORKERS_EVERY_S = 5.0, 1.0

    def __init__(
        self,
        job: Job,
        scheduler: str,
        timeout_s: float,
        connect_timeout_s: float = 5.0,
        notify: Callable[[str], Any] = print,
    ):
        self.job, self.scheduler, self.timeout_s, self.connect_timeout_s = job, scheduler, timeout_s, connect_timeout_s
        self.notify = notify
        self.client: Any = None
        self.shared: Any = None  # the job, as the future every start depends on
        self._alone_since: float | None = None
        self._asked = 0.0
        self._said = False

    def _watch_workers(self) -> None:
        """Say once when the scheduler has had no worker for a while, and again when one is back."""
        now = time.monotonic()
        if now - self._asked < self.WORKERS_EVERY_S:
            return
        self._asked = now
        try:
            alive = len(self.client.nthreads())
        except Exception:  # noqa: BLE001 - the scheduler itself gone: the futures will say so
            return
        if alive:
            if self._said:
                self.notify(f"{self.scheduler}: {alive} Dask worker(s) back, the sweep goes on")
            self._alone_since, self._said = None, False
            return
        self._alone_since = self._alone_since or now
        if not self._said and now - self._alone_since >= self.SAY_NO_WORKER_AFTER_S:
            self._said = True
            self.notify(
                f"{self.scheduler}: no Dask worker alive; waiting for one (start one with `dask worker "
                f"{self.scheduler}`), or Ctrl-C to stop and --resume later"
            )

    def _wait(self, future: Any) -> Any:
        from dask.distributed import TimeoutError as DaskTimeout  # deferred: only with --executor dask

        while True:
            _check_stop()
            self._watch_workers()
            try:
                return future.result(timeout=0.5)
            except (DaskTimeout, TimeoutError):
                continue

    def start(self) -> dict[str, int]:
        from dask.distributed import Client  # deferred: only with --executor dask

        try:
            self.client = Client(self.scheduler, timeout=f"{self.connect_timeout_s}s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise BadInputError(
                self.scheduler, f"no Dask scheduler answered within {self.connect_timeout_s:g} s ({type(exc).__name__})"
            ) from exc
        try:
            # the job sent once, as a task of its own that every start depends on, not pickled into each start's
            # task: a worker that joins later fetches it, and the scheduler makes it again if every worker holding
            # it died (scattered data would be lost with them, and with it every start left)
            self.shared = self.client.submit(_the_job, self.job, pure=False)
            size = self._wait(self.client.submit(_dask_size, self.shared, pure=False))
        except KeyboardInterrupt:
            raise
        except Exception as exc:  # noqa: BLE001
            raise BadInputError("synthesize", f"a Dask worker could not build the model: {build_failure(exc)}") from exc
        threads = max(self.client.nthreads().values(), default=1)
        if threads > 1:
            self.notify(
                f"{self.scheduler}: Dask workers with {threads} threads solve one start at a time each; to use "
                f"every core, start them as `dask worker {self.scheduler} --nworkers N --nthreads 1`"
            )
        return size

    def run(self, starts: list[Start], on_result: OnResult) -> None:
        from dask.distributed import as_completed  # deferred: only with --executor dask

        futures = {
            self.client.submit(
                _dask_solve, self.shared, s, pure=False, key=f"grasp-start-{s.start_id}-{time.time_ns()}"
            ): s
            for s in starts
        }
        finished = as_completed(futures)
        try:
            while not finished.is_empty():
                _check_stop()
                batch = finished.next_batch(block=False)
                if not batch:  # polled, so that a signal or a cluster without workers is seen at once
                    self._watch_workers()
                    time.sleep(0.1)
                    continue
                for future in batch:
                    start = futures[future]
                    try:
                        row = future.result(timeout=self.timeout_s)
                    except Exception as exc:  # noqa: BLE001
                        row = failed_row(start, "crashed", 0.0, f"{type(exc).__name__}: {exc}"[:300])
                    on_result(row)
        finally:
            self.client.cancel([f for f in futures if not f.done()])

    def close(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None


def make_executor(
    job: Job,
    kind: str,
    workers: int,
    hang_after_s: float,
    scheduler: str | None = None,
    notify: Callable[[str], Any] = print,
) -> Executor:
    if kind == "serial":
        return SerialExecutor(job)
    if kind == "dask":
        assert scheduler is not None, "checked by SynthesisOptions"
        return DaskExecutor(job, scheduler, hang_after_s, notify=notify)
    return PoolExecutor(job, workers, hang_after_s)
