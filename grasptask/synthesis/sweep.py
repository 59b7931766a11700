"""Solving many starts: the per-worker solver context, a process pool that survives crashed and hung workers,
a Dask executor, and the result row of one start (solution, status, timing and the verifier's figures).

Every worker builds the model once from a :class:`Job` (hand, object, task model, solver options) and then
re-solves it from each start's initial point. A start whose worker dies is recorded as ``crashed``, one that
outlives its time limit by the configured grace as ``hung``; either way the worker is replaced and the sweep
goes on.
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
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from grasptask.io import solutions as schema
from grasptask.synthesis.config import SolverConfig
from grasptask.synthesis.starts import Start

# a test hook: a start whose id is listed here makes its worker exit abruptly (to exercise crash handling)
CRASH_ENV = "GRASPTASK_CRASH_STARTS"
#: set by the sweep's SIGINT handler; the sweep stops once the starts in progress are recorded
STOP = threading.Event()


def _check_stop() -> None:
    if STOP.is_set():
        raise KeyboardInterrupt


class stop_on_sigint:
    """Within this block Ctrl-C only sets :data:`STOP`: IPOPT and CasADi finish the start they are on (so it
    is recorded, not lost), and the sweep then stops with ``KeyboardInterrupt``."""

    def __enter__(self):
        STOP.clear()
        self.previous = None
        if threading.current_thread() is threading.main_thread():
            self.previous = signal.signal(signal.SIGINT, lambda *_: STOP.set())
        return self

    def __exit__(self, *exc):
        if self.previous is not None:
            signal.signal(signal.SIGINT, self.previous)
        STOP.clear()


OnResult = Callable[[dict], None]
OnModel = Callable[[dict[str, int]], None]


def _ignore(size: dict[str, int]) -> None:
    pass


@dataclass(frozen=True)
class Job:
    """Everything a worker needs to rebuild the model; plain paths and values, so it pickles."""

    hand_path: str
    object_path: str
    tasks_path: str
    task: str
    backend: str = "casadi"
    solver: SolverConfig = SolverConfig()
    settings_path: str = ""


class SolverContext:
    """A worker's model and solver, built once; ``size`` is the model's variable and constraint count."""

    def __init__(self, job: Job):
        from grasptask.grasp.settings import GraspSettings, load_grasp_settings
        from grasptask.hand import load_hand
        from grasptask.objects import load_object
        from grasptask.synthesis.backends import BACKENDS, write_nl
        from grasptask.synthesis.model import build_model
        from grasptask.task.model import load_task_models

        self.job = job
        self.hand = load_hand(job.hand_path)
        self.obj = load_object(job.object_path)
        self.task = load_task_models(job.tasks_path)[job.task]
        self.settings = load_grasp_settings(job.settings_path) if job.settings_path else GraspSettings()
        self.nlp = build_model(
            self.hand, self.obj, self.task, self.settings, job.solver.bounds, job.solver.regularisation
        )
        self.size = self.nlp.size()
        text, self.order = write_nl(self.nlp.model)
        self.nlp.compile()  # now, so that its one-off cost is not counted in the first start's seconds
        self.backend = BACKENDS[job.backend](text, job.solver.ipopt)
        self.bounds = self.obj.bounds()
        self.fingers = list(self.nlp.hand.fingers)
        self.joint_names = self.nlp.hand.joint_names

    def solve(self, start: Start) -> dict:
        from grasptask.grasp.verify import Grasp, verify
        from grasptask.io.solutions import grasp_columns
        from grasptask.synthesis.placement import place

        if str(start.start_id) in os.environ.get(CRASH_ENV, "").split(","):
            os._exit(13)
        row: dict[str, Any] = {
            "start_id": start.start_id,
            "orientation": start.orientation,
            "position": start.position_name,
        }
        joints = self.nlp.hand.mid_range()
        began = time.perf_counter()
        if self.job.solver.placement:
            row["placement_backoff_m"] = place(self.nlp, start, self.bounds, joints)
        else:
            self.nlp.initialise(start.palm_rotation, start.palm_position, joints)
        row["placement_seconds"] = placed = time.perf_counter() - began
        result = self.backend.solve(_values(self.order))
        # a start's seconds are all it took to solve it: placement (or initialisation) and IPOPT
        row.update(
            status=result.status, iterations=result.iterations, seconds=result.seconds + placed, message=result.message
        )
        if result.x is None:
            return {**row, "Q": float("nan"), "verified": False}
        _assign(self.order, result.x)
        solution = self.nlp.read()
        row["Q"] = float(solution["Q"])
        grasp = Grasp(solution["palm_rotation"], solution["palm_position"], solution["joint_angles"])
        row.update(grasp_columns(grasp, self.joint_names, self.fingers, solution["contacts"], solution["normals"]))
        check = verify(grasp, self.hand, self.obj, self.task, self.settings)
        row.update(check.record(self.fingers))
        return row


def _values(order: list) -> np.ndarray:
    return np.array([v.value if v.value is not None else 0.0 for v in order], dtype=float)


def _assign(order: list, x: np.ndarray) -> None:
    for var, value in zip(order, x, strict=True):
        var.set_value(float(value), skip_validation=True)


def failed_row(start: Start, status: str, seconds: float, message: str) -> dict:
    return schema.failed_row(start.start_id, start.orientation, start.position_name, status, seconds, message)


def run_serial(job: Job, starts: Iterable[Start], on_result: OnResult, on_model: OnModel = _ignore) -> None:
    context = SolverContext(job)
    on_model(context.size)
    for start in starts:
        on_result(_guarded(context, start))
        _check_stop()


def _guarded(context: SolverContext, start: Start) -> dict:
    began = time.perf_counter()
    try:
        return context.solve(start)
    except Exception as exc:  # noqa: BLE001 - a failed start is a recorded status, never a crashed sweep
        return failed_row(start, "error", time.perf_counter() - began, f"{type(exc).__name__}: {exc}"[:300])


def _worker(job: Job, tasks, results, worker_id: int) -> None:
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop and ends its workers
    try:
        context = SolverContext(job)
    except Exception:  # noqa: BLE001
        results.put(("failed", worker_id, traceback.format_exc()))
        return
    results.put(("ready", worker_id, context.size))
    parent = mp.parent_process()
    while (start := _next_start(tasks, parent)) is not None:
        results.put(("done", worker_id, _guarded(context, start)))


def _next_start(tasks, parent, poll_s: float = 1.0) -> Start | None:
    """The worker's next start, or None when the parent says stop or has died: a sweep killed outright (SIGKILL,
    SIGTERM) cannot end its workers, which would otherwise wait on their queues for ever."""
    while True:
        try:
            return tasks.get(timeout=poll_s)
        except queue.Empty:
            if parent is not None and not parent.is_alive():
                return None


def run_pool(
    job: Job,
    starts: list[Start],
    workers: int,
    on_result: OnResult,
    hang_after_s: float,
    on_model: OnModel = _ignore,
    max_restarts: int = 20,
) -> None:
    """Solve ``starts`` on ``workers`` processes; ``on_result`` gets each row as it finishes, ``on_model`` the
    model size each worker reports when it is ready.

    The parent hands each worker one start at a time through the worker's own queue, so it always knows which
    start a worker holds: a worker that dies (a message it was sending may die with it) or outlives the hang
    limit is replaced, and its start is recorded as ``crashed`` or ``hung``.
    """
    ctx = mp.get_context("spawn")
    results = ctx.Queue()
    pending = list(starts)
    procs: dict[int, tuple] = {}  # worker id -> (process, its task queue)
    holding: dict[int, tuple[Start, float]] = {}
    restarts = 0
    ids = itertools.count()

    def spawn() -> None:
        worker_id = next(ids)
        tasks = ctx.Queue()
        proc = ctx.Process(target=_worker, args=(job, tasks, results, worker_id), daemon=True)
        proc.start()
        procs[worker_id] = (proc, tasks)

    def assign(worker_id: int) -> None:
        if pending and worker_id in procs:
            start = pending.pop(0)
            holding[worker_id] = (start, time.time())
            procs[worker_id][1].put(start)

    for _ in range(min(workers, len(starts))):
        spawn()
    outstanding = len(starts)
    try:
        while outstanding:
            _check_stop()
            try:
                kind, worker_id, payload = results.get(timeout=0.5)
            except queue.Empty:
                kind = None
            if kind == "failed":
                raise RuntimeError(f"a solver worker could not build the model:\n{payload}")
            if kind == "ready":
                on_model(payload)
                assign(worker_id)
            elif kind == "done" and worker_id in holding:
                holding.pop(worker_id)
                outstanding -= 1
                on_result(payload)
                assign(worker_id)
            now = time.time()
            for worker_id, (proc, _) in list(procs.items()):
                held = holding.get(worker_id)
                hung = held is not None and now - held[1] > hang_after_s
                if proc.is_alive() and not hung:
                    continue
                if hung:
                    proc.kill()
                proc.join(timeout=5)
                procs.pop(worker_id)
                if held is not None:
                    holding.pop(worker_id)
                    start, began = held
                    message = (
                        f"worker killed after {now - began:.0f} s" if hung else f"worker exit code {proc.exitcode}"
                    )
                    outstanding -= 1
                    on_result(failed_row(start, "hung" if hung else "crashed", now - began, message))
                else:
                    restarts += 1
                    if restarts > max_restarts:
                        raise RuntimeError("solver workers keep dying before they are ready")
                if pending:
                    spawn()
    finally:
        for _, tasks in procs.values():
            tasks.put(None)
        # idle workers exit at once, but one holding a GP object's model takes seconds to free it; after Ctrl-C
        # or an error, workers still solving are not waited for
        grace = 30 if outstanding == 0 else 2
        for proc, _ in procs.values():
            proc.join(timeout=grace)
            if proc.is_alive():
                proc.kill()


_DASK_CONTEXTS: dict = {}


def _dask_solve(job: Job, start: Start) -> tuple[dict[str, int], dict]:
    """Runs on a Dask worker: the context is built once per worker process and job. The model size and the row."""
    key = (os.getpid(), repr(job))
    if key not in _DASK_CONTEXTS:
        _DASK_CONTEXTS[key] = SolverContext(job)
    context = _DASK_CONTEXTS[key]
    return context.size, _guarded(context, start)


def run_dask(
    job: Job,
    starts: list[Start],
    scheduler: str,
    on_result: OnResult,
    timeout_s: float,
    on_model: OnModel = _ignore,
) -> None:
    """Solve the starts on a Dask cluster at ``scheduler``; a start whose task fails is recorded as crashed."""
    from dask.distributed import Client, as_completed

    with Client(scheduler) as client:
        futures = {
            client.submit(_dask_solve, job, s, pure=False, key=f"grasp-start-{s.start_id}-{time.time_ns()}"): s
            for s in starts
        }
        for future in as_completed(futures):
            _check_stop()
            start = futures[future]
            try:
                size, row = future.result(timeout=timeout_s)
            except Exception as exc:  # noqa: BLE001
                on_result(failed_row(start, "crashed", 0.0, f"{type(exc).__name__}: {exc}"[:300]))
                continue
            on_model(size)
            on_result(row)
