"""``grasptask synthesize``: a sweep of starts for one task, written as it goes and summarised at the end.

Each finished start is appended as one JSON line to ``<out>/<task>/solutions.jsonl`` (flushed and synced), so
an interrupted sweep loses nothing and ``--resume`` skips the starts already there. At the end the lines
become ``solutions.parquet``; the distinct verified optima go to ``optima.parquet`` and the counts, timings,
solver versions and model size (as the workers report it) to ``run.json``.
"""

from __future__ import annotations

import errno
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from grasptask.errors import BadInputError
from grasptask.grasp.grasp_settings import load_grasp_settings
from grasptask.hand import load_hand
from grasptask.hand.hand_model import Hand
from grasptask.io.artifacts import (
    Provenance,
    StagedOutput,
    config_hash,
    json_text,
    path_hash,
    plain_name,
    write_text_atomic,
)
from grasptask.io.child_processes import refuse_in_worker_import
from grasptask.io.config_schema import MAX_WORKERS, read_json
from grasptask.io.locking import folder_lock
from grasptask.io.sweep_log import LogContents, LogWriter, read_log, rewrite_log
from grasptask.io.wording import plural
from grasptask.objects import load_object
from grasptask.objects.mesh_object import MeshObject, PointCloudObject
from grasptask.objects.object_files import (
    BareObjectFacts,
    object_config,
    object_facts,
    object_files,
    object_from_config,
)
from grasptask.objects.surface import Symmetry
from grasptask.paths import DEFAULT_GRASP_CONFIG, DEFAULT_HAND, DEFAULT_OBJECT, DEFAULT_SOLVER_CONFIG, as_paths
from grasptask.physics.physics_settings import load_physics_settings
from grasptask.progress import Progress, preparing, timed_stage
from grasptask.records.grasp_library import LibraryEntry, add_to_library, nearest_entry, setup_key
from grasptask.records.reference import PaperSynthesis, read_paper_synthesis
from grasptask.records.run_record import RUN_FILE, read_run, run_outcome, throughput
from grasptask.records.sweeps import SolvedGrasps
from grasptask.synthesis.clustering import cluster
from grasptask.synthesis.context import Job
from grasptask.synthesis.resistance import unresistable
from grasptask.synthesis.solver_config import load_solver_config
from grasptask.synthesis.starts import Start, make_starts, subset, surface_starts, warm_starts
from grasptask.synthesis.sweep import graceful_stop, make_executor
from grasptask.task.task_model import TaskModel, load_task_model

EXECUTORS = ("pool", "serial", "dask")
BACKENDS = ("casadi", "cyipopt")
ROUTES = ("paper", "search")
#: at most this many starts seeded over the object's surface
MAX_SURFACE_STARTS = 1024


@dataclass(frozen=True, kw_only=True)
class SynthesisOptions(BareObjectFacts):
    """What a sweep is run on and how, and what a bare mesh cannot say (:class:`BareObjectFacts`); checked when
    made, so a bad combination fails before any work."""

    tasks: Path
    task: str
    out: Path
    hand: Path = DEFAULT_HAND
    object: Path = DEFAULT_OBJECT
    solver_config: Path = DEFAULT_SOLVER_CONFIG
    grasp_config: Path = DEFAULT_GRASP_CONFIG
    starts: int | None = None
    #: starts seeded over the object's surface too (synthesis.starts.surface_starts); 0: the paper's only
    surface_starts: int = 0
    seed: int = 0
    workers: int = 1
    executor: str = "pool"
    scheduler: str | None = None
    backend: str = "casadi"
    #: paper: every start solved to its end by the Section 6 NLP; search: search, basins, then polish
    route: str = "paper"
    resume: bool = False
    #: the grasping fingers; None: the hand file's choice (the human hand's thumb, index and middle)
    fingers: tuple[str, ...] | None = None
    #: a physics config: hold each verified grasp in MuJoCo too (grasptask.physics); None: no physics check
    physics: Path | None = None
    #: a grasp library folder (grasptask.records.grasp_library): warm starts from the optima of the nearest task
    #: it holds for this setup, and this sweep's optima added to it; None: none, and the sweep reproducible
    library: Path | None = None
    #: solve even when the grasping contacts cannot resist the task wherever they are placed (refused otherwise)
    anyway: bool = False

    def __post_init__(self) -> None:
        as_paths(
            self, "tasks", "out", "hand", "object", "solver_config", "grasp_config", optional=("physics", "library")
        )
        if self.executor not in EXECUTORS:
            raise BadInputError("synthesize", f"unknown executor '{self.executor}' (known: {', '.join(EXECUTORS)})")
        if self.route not in ROUTES:
            raise BadInputError("synthesize", f"unknown route '{self.route}' (known: {', '.join(ROUTES)})")
        if self.backend not in BACKENDS:
            raise BadInputError("synthesize", f"unknown solver '{self.backend}' (known: {', '.join(BACKENDS)})")
        if not 1 <= self.workers <= MAX_WORKERS:
            raise BadInputError("synthesize", f"--workers must be from 1 to {MAX_WORKERS}, got {self.workers}")
        if self.starts is not None and self.starts < 1:
            raise BadInputError("synthesize", "--starts must be at least 1")
        if not 0 <= self.surface_starts <= MAX_SURFACE_STARTS:
            raise BadInputError(
                "synthesize", f"--surface-starts must be from 0 to {MAX_SURFACE_STARTS}, got {self.surface_starts}"
            )
        if self.executor == "serial" and self.workers != 1:
            raise BadInputError(
                "synthesize",
                f"--executor serial solves in this process, one start at a time: drop --workers {self.workers}",
            )
        if self.executor == "dask" and not self.scheduler:
            raise BadInputError("synthesize", "--executor dask needs --scheduler ADDRESS")
        if self.executor != "dask" and self.scheduler:
            raise BadInputError("synthesize", "--scheduler is for --executor dask")

    @property
    def folder(self) -> Path:
        return self.out / self.task

    @property
    def object_used(self) -> Path:
        """The object the sweep records: the given file, or with --unit, --mass or --task-frame the config
        written beside its results (``object.yaml``), which the later stages then read."""
        return self.folder / OBJECT_FILE if self.object_overrides else self.object


@dataclass(frozen=True)
class SynthesisSummary:
    """The sweep's record, as ``run.json`` holds it (verified starts, distinct optima, the best Q, the time per
    start, the statuses, what the user waited for), the task and the folder of its results."""

    folder: Path
    task: str
    run: dict[str, Any]


class SweepInterrupted(KeyboardInterrupt):
    """A sweep stopped by Ctrl-C or SIGTERM; ``str()`` says what of it was kept, and how to go on."""

    def __init__(self, kept: int, log: Path, untouched: bool):
        self.kept, self.log = kept, log
        if kept:
            said = f"{kept} finished starts are kept in {log}; rerun with --resume"
        elif untouched:
            said = "stopped before any start was solved; the sweep that was here is kept as it was"
        else:
            said = "stopped before any start was solved; nothing of this run was kept"
        super().__init__(said)


DEFINITION_FILE = "sweep.json"
OBJECT_FILE = "object.yaml"
LOG_FILE = "solutions.jsonl"


@dataclass(frozen=True)
class _Prepared:
    """Everything a sweep needs, read and checked before anything on disk is touched."""

    job: Job
    starts: list
    fingers: list[str]
    symmetry: Symmetry | None
    hang_after_s: float
    definition: dict[str, Any]
    paper: PaperSynthesis
    #: the object config written beside the results (None: the given file is recorded as it is)
    object_config: dict[str, Any] | None
    object_facts: dict[str, Any]
    library: Library | None = None


@dataclass(frozen=True)
class Library:
    """A sweep's grasp library: its folder, this setup's key in it, the nearest task's entry (None: it holds none
    for this setup yet) and the warm starts made from that entry's optima."""

    folder: Path
    setup: str
    entry: LibraryEntry | None
    starts: list[Start]

    def said(self) -> str:
        if self.entry is None:
            return f"library {self.folder}: nothing yet for this hand, object and fingers; this sweep's optima go in"
        return (
            f"library {self.folder}: {len(self.starts)} warm starts first, the optima of task '{self.entry.task}' "
            f"(Log-Euclidean distance {self.entry.distance:.3g})"
        )

    def record(self) -> dict[str, Any]:
        """What run.json says of it."""
        entry = self.entry
        return {
            "folder": os.path.abspath(self.folder),
            "setup": self.setup,
            "from_task": None if entry is None else entry.task,
            "distance": None if entry is None else entry.distance,
            "warm_starts": len(self.starts),
        }


def _library(options: SynthesisOptions, definition: dict[str, Any], task: TaskModel, hand: Hand) -> Library | None:
    """The library the sweep names, its nearest entry and the warm starts from it; the entry joins the sweep's
    definition, so that a resumed sweep is refused when the library it started from has changed."""
    if options.library is None:
        return None
    setup = setup_key(definition["hand"], definition["object"], definition["fingers"])
    entry = nearest_entry(options.library, setup, task)
    if entry is None:
        return Library(options.library, setup, None, [])
    definition["library"] = path_hash(entry.path)
    starts = warm_starts(entry.optima, hand.grasping_hand().joint_names, entry.path)
    return Library(options.library, setup, entry, starts)


def _definition(options: SynthesisOptions, model: TaskModel, hand: Hand) -> dict[str, Any]:
    """What makes a sweep the run it is (``sweep.json``): a resume with another of these is refused."""
    definition: dict[str, Any] = {
        "task": options.task,
        "seed": options.seed,
        "solver": options.backend,
        "task model": config_hash(model.ellipsoid.S.tolist()),
        "hand": path_hash(options.hand),
        "object": config_hash([path_hash(p) for p in object_files(options.object)] + [options.object_overrides]),
        "solver config": path_hash(options.solver_config),
        "grasp config": path_hash(options.grasp_config),
        "fingers": list(hand.grasping),
    }
    if options.physics is not None:  # a sweep with the physics check is another run than one without
        definition["physics config"] = path_hash(options.physics)
    if options.route != "paper":  # the paper route's definition is as it always was: its sweeps still resume
        definition["route"] = options.route
    if options.surface_starts:
        definition["surface starts"] = options.surface_starts
    return definition


def _prepare(options: SynthesisOptions) -> _Prepared:
    from grasptask.synthesis.backends import check_ipopt_options  # deferred: CasADi and Pyomo

    model = load_task_model(options.tasks, options.task)
    plain_name(options.task, options.tasks, "task name")
    solver = load_solver_config(options.solver_config)
    check_ipopt_options(solver.ipopt, options.solver_config)
    settings = load_grasp_settings(options.grasp_config)
    physics = load_physics_settings(options.physics) if options.physics is not None else None
    hand = load_hand(options.hand)
    if options.fingers:
        try:
            hand = hand.with_grasping(options.fingers)
        except KeyError as exc:
            known = ", ".join(hand.fingers)
            raise BadInputError("--fingers", f"hand '{hand.name}' has no finger {exc} (it has {known})") from None
        if len(set(options.fingers)) < 2 or len(set(options.fingers)) != len(options.fingers):
            raise BadInputError("--fingers", "name at least two different fingers")
    config = object_config(options.object, **options.object_overrides)
    obj = load_object(options.object) if config is None else object_from_config(config, options.object)
    every = make_starts(obj.bounds(), options.seed)
    if options.starts is not None and options.starts > len(every):
        raise BadInputError("synthesize", f"--starts {options.starts}: there are {len(every)} starts")
    definition = _definition(options, model, hand)
    seeded: list[Start] = []
    if options.surface_starts:
        seeded = surface_starts(obj.surface.points, obj.surface.normals, options.surface_starts)
    library = _library(options, definition, model, hand)
    # the workers get the hand, the object and the task model as loaded here, by value; a mesh's or cloud's
    # signed-distance grid (3.3 s for a YCB mug) is made here once, not once in every worker
    if isinstance(obj, MeshObject | PointCloudObject):
        obj.distance_grid  # noqa: B018 - a cached property, pickled with the object
    job = Job(
        hand,
        obj,
        model,
        options.backend,
        solver,
        settings=settings,
        physics=physics,
        key=config_hash(definition),
        route=options.route,
    )
    return _Prepared(
        job,
        (library.starts if library is not None else []) + subset(every, options.starts) + seeded,
        list(hand.grasping),
        obj.symmetry,
        solver.hang_after_s,
        definition,
        read_paper_synthesis(),
        config,
        object_facts(obj),
        library,
    )


def _previous_run(folder: Path) -> dict[str, Any]:
    try:
        return read_run(folder)
    except BadInputError:
        return {}


def _check_resume(folder: Path, prepared: _Prepared, done: LogContents, definition: Path) -> None:
    """Refuse to resume a different run: another seed, task, task model, hand, object, configuration or
    solver (as ``definition`` records the run); or starts done here that the new selection does not hold."""
    if not done.rows:
        return
    try:
        recorded = read_json(definition).get("definition", {})
    except BadInputError:
        raise BadInputError(
            folder, f"--resume: no readable {DEFINITION_FILE} says what run these {len(done.rows)} starts belong to"
        ) from None
    current = prepared.definition
    shown = ("task", "seed", "solver")
    differ = [  # a key either run lacks counts too: a search sweep resumed on the paper's route is another run
        f"{key} ({recorded.get(key)!r}, now {current.get(key)!r})" if key in shown else key
        for key in {**current, **recorded}
        if recorded.get(key) != current.get(key)
    ]
    if differ:
        raise BadInputError(
            folder,
            f"--resume: this sweep was run with another {', '.join(differ)}; use the same options or a new --out",
        )
    outside = sorted(done.start_ids - {s.start_id for s in prepared.starts})
    if outside:
        raise BadInputError(
            folder,
            f"--resume: {len(outside)} start(s) done here (e.g. {outside[0]}) are not among the {len(prepared.starts)}"
            " this --starts selects; resume with the --starts of that run or more",
        )


def _check_fresh(folder: Path, done: LogContents, rerun: LogContents | None) -> None:
    """A run without --resume replaces a finished sweep's log (``done``), but never an unfinished one's rows, nor
    those of an unfinished rerun staged beside a finished sweep (``rerun``)."""
    if rerun is not None and rerun.rows:
        raise BadInputError(
            folder,
            f"holds an unfinished rerun ({len(rerun.rows)} starts done, in {_staged(folder, LOG_FILE).name}) beside "
            f"a finished sweep; continue it with --resume and its options, or remove "
            f"{_staged(folder, LOG_FILE)} to start again",
        )
    if not done.rows:
        return
    previous = _previous_run(folder)
    if previous.get("log_rows", previous.get("starts")) != len(done.rows):
        raise BadInputError(
            folder,
            f"holds an unfinished sweep ({len(done.rows)} starts done); continue it with --resume, or remove "
            f"{folder / LOG_FILE} to start again",
        )


@timed_stage
def run_synthesize(options: SynthesisOptions, echo: Callable[[str], Any] = print) -> SynthesisSummary:
    """Solve the task's starts, verify every solution, and write ``solutions.parquet``, ``optima.parquet`` and
    ``run.json`` under ``options.folder``; ``echo`` hears the sweep's progress.

    Every input is checked, and a worker has built the model, before anything of an earlier sweep in the
    folder is touched; the folder is locked for the run."""
    refuse_in_worker_import()  # a script without a __main__ guard, re-imported by a solver worker: ends it
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # inherited by the solver processes
    prepared = _prepare(options)
    job = prepared.job
    why = unresistable(job.hand.grasping_hand(), job.task, job.settings)
    if why is not None and not options.anyway:
        raise BadInputError("synthesize", f"{why}; no start can hold it: solve anyway with --anyway")
    if why is not None:
        echo(f"note: {why}; solving anyway (--anyway)")
    with folder_lock(options.folder, f"synthesize {options.task}"):
        log = _log_to_write(options, prepared)
        done = read_log(log)
        rows: list[dict] = []  # this run's, as they finish: what a stop keeps
        try:
            run = _run_locked(options, prepared, done, rows, echo, log)
        except KeyboardInterrupt:
            untouched = log.name != LOG_FILE and not options.resume  # a finished sweep sits beside a rerun's log
            raise SweepInterrupted(len(rows), log, untouched=untouched) from None
    return SynthesisSummary(options.folder, options.task, run)


def _staged(folder: Path, name: str) -> Path:
    """Where a rerun keeps file ``name`` until it finishes, beside the finished sweep's own."""
    return folder / f".{name}.new"


def _log_to_write(options: SynthesisOptions, prepared: _Prepared) -> Path:
    """The log this run goes on from and writes to: the sweep's own; or, for a rerun over a finished sweep, its
    staged log, so that the finished sweep's files stay as they are until the rerun is finished (a rerun that
    fails part-way is resumed with its own options, and the finished sweep with its own)."""
    folder = options.folder
    main, staged = folder / LOG_FILE, _staged(folder, LOG_FILE)
    if options.resume:
        try:
            recorded = read_json(_staged(folder, DEFINITION_FILE)).get("definition")
        except BadInputError:
            recorded = None
        return staged if staged.is_file() and recorded == prepared.definition else main
    return staged if read_log(main).rows else main


def _go_on_from(options: SynthesisOptions, prepared: _Prepared, done: LogContents, rows: list[dict], staged: bool):
    """The run checked against what the folder holds, and the rows it goes on from put in ``rows``."""
    folder = options.folder
    if options.resume:
        _check_resume(folder, prepared, done, _staged(folder, DEFINITION_FILE) if staged else folder / DEFINITION_FILE)
        rows.extend(done.rows)
    else:
        _check_fresh(folder, read_log(folder / LOG_FILE) if staged else done, done if staged else None)


def _rerun_files(folder: Path, prepared: _Prepared) -> dict[str, Path]:
    """A rerun's log and records, all its starts solved: they take the finished sweep's place in the same swap as
    its tables, so that a failure before it (a full disk) leaves the finished sweep whole and resumable."""
    return {name: _staged(folder, name) for name in [LOG_FILE, *_records(folder, prepared)]}


def _run_locked(
    options: SynthesisOptions,
    prepared: _Prepared,
    done: LogContents,
    rows: list[dict],
    echo: Callable[[str], Any],
    log: Path,
) -> dict:
    """The sweep in its locked folder: the starts left solved, each row appended to ``rows`` and ``log``, which a
    rerun over a finished sweep moves in place of the finished one's only once all its starts are solved."""
    folder = options.folder
    staged = log.name != LOG_FILE
    _go_on_from(options, prepared, done, rows, staged)
    finished = {row["start_id"] for row in rows}
    todo = [s for s in prepared.starts if s.start_id not in finished]
    echo(f"{options.task}: {plural(len(prepared.starts), 'start')}, {len(finished)} already done")
    if prepared.library is not None:
        echo(prepared.library.said())
    model_size = None if todo else _previous_run(folder).get("model_size")
    workers = max(1, min(options.workers, len(todo)))
    executor = make_executor(prepared.job, options.executor, workers, prepared.hang_after_s, options.scheduler, echo)
    wall_start = time.perf_counter()
    with graceful_stop(notify=echo):
        try:
            if todo:
                with preparing(f"{options.task}: building the NLP in {plural(workers, 'worker')} ...", echo):
                    model_size = executor.start()
                _say_model(model_size, prepared.paper, echo)
            # the run is known to work: only now is the folder changed
            _begin(folder, prepared, log, options.resume, done, rows, echo)
            if todo:  # a resumed sweep may have nothing left to solve
                try:
                    if options.route == "paper":
                        _solve(executor, todo, rows, log, options.task, len(prepared.starts), wall_start)
                    else:
                        _solve_by_search(executor, todo, rows, log, wall_start, prepared)
                except BadInputError:
                    if staged and not options.resume and not read_log(log).rows:  # nothing of it to resume
                        _discard_rerun(folder, prepared)
                    raise
        finally:
            executor.close()
    run = summarise(
        options,
        rows,
        model_size=model_size,
        wall_seconds=time.perf_counter() - wall_start,
        solved=len(todo),
        symmetry=prepared.symmetry,
        fingers=prepared.fingers,
        paper=prepared.paper,
        object_facts=prepared.object_facts,
        job=prepared.job,
        library=prepared.library,
        carried=_rerun_files(folder, prepared) if staged else None,
    )
    if prepared.library is not None:
        _add_to_library(prepared.library, prepared.job.task, folder, echo)
    return run


def _add_to_library(library: Library, task: TaskModel, folder: Path, echo: Callable[[str], Any]) -> None:
    """The sweep's distinct verified optima kept in its library, in place of an earlier sweep's of the task; the
    sweep's own results are written already, and a library that cannot be written is said, not fatal."""
    optima = pd.read_parquet(folder / "optima.parquet")
    try:
        kept = add_to_library(library.folder, library.setup, task, optima)
    except OSError as exc:
        echo(f"library {library.folder}: not added to ({exc.strerror or exc}); the sweep's results are kept")
        return
    if kept is not None:
        echo(f"library: the {plural(len(optima), 'optimum')} of task '{task.name}' kept in {kept}")


def _say_model(size: dict[str, Any], paper: PaperSynthesis, echo: Callable[[str], Any]) -> None:
    held = "; the grasp's turn about the object's axis held (solver config hold_axis_rotation)"
    warmup, option = size.get("geometric_iterations"), "geometric_iterations"
    if size.get("held_axis_rotation"):
        option = "held_geometric_iterations, or geometric_iterations if null"
    geometric = f"; each start's first {warmup} iterations without eq. 10 ({option})" if warmup else ""
    near = ""
    if "spheres" in size:  # a search route's model on a hand of many spheres: its polishes carry the near ones
        near = (
            f"; none of the hand's {size['hand_spheres']} collision spheres: each polish carries those near its "
            "grasp (search config polish_all_spheres_max, polish_sphere_distance_m)"
        )
    echo(
        f"model {size['variables']} variables x {size['constraints']} constraints"
        f" (paper: {paper.variables} x {paper.constraints}){held if size.get('held_axis_rotation') else ''}{geometric}"
        f"{near}"
    )


def _records(folder: Path, prepared: _Prepared) -> dict[str, str]:
    """What defines the run, as the files beside its log hold it: ``sweep.json`` and, with --unit, --mass or
    --task-frame, ``object.yaml``."""
    records = {DEFINITION_FILE: json_text({"definition": prepared.definition})}
    if prepared.object_config is not None:
        records[OBJECT_FILE] = yaml.safe_dump(prepared.object_config, sort_keys=False)
    return records


def _discard_rerun(folder: Path, prepared: _Prepared) -> None:
    """A rerun's staged files, gone: it failed before it had a row to resume."""
    for name in [LOG_FILE, *_records(folder, prepared)]:
        _staged(folder, name).unlink(missing_ok=True)


def _begin(
    folder: Path,
    prepared: _Prepared,
    log: Path,
    resume: bool,
    done: LogContents,
    rows: list[dict],
    echo: Callable[[str], Any],
) -> None:
    """The run's folder, its records beside its log (staged beside a finished sweep's, for a rerun), and a fresh
    run's empty log or a resumed one's repairs. A fresh run that cannot write them (a full disk) takes them back,
    and leaves the folder as it was."""
    folder.mkdir(parents=True, exist_ok=True)
    if resume and done.repairs:  # the same run goes on: its records are this run's already
        for repair in done.repairs:
            echo(f"{log}: {repair}")
        rewrite_log(log, rows)
    staged = log.name != LOG_FILE
    paths = {(_staged(folder, n) if staged else folder / n): text for n, text in _records(folder, prepared).items()}
    try:
        for path, text in paths.items():
            write_text_atomic(path, text)
        if not resume:
            rewrite_log(log, [])
    except OSError as exc:
        if staged and not resume:
            _discard_rerun(folder, prepared)
        reason = "no space left on device" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
        kept = "; the sweep that was here is kept as it was" if staged else ""
        raise BadInputError(folder, f"{reason} writing the run's records{kept}") from exc


def _solve(
    executor: Any,
    todo: list,
    rows: list[dict],
    log: Path,
    task: str,
    total: int,
    began: float,
) -> None:
    """Run the executor over ``todo``, appending each row to the log (and ``rows``), with progress. Each row
    records when it came in, in seconds from ``began`` (``found_after_s``): what a user waited for it."""
    counts = {
        "verified": sum(bool(r.get("verified")) for r in rows),
        "failing": sum(not r.get("verified") for r in rows),
    }
    with (
        _recorded(log, rows, began) as record,
        Progress(total, f"synthesize {task}", "starts", initial=len(rows)) as shown,
    ):

        def on_result(row: dict) -> None:
            record(row)
            counts["verified" if row.get("verified") else "failing"] += 1
            shown.update(1, **counts)

        executor.run(todo, on_result)


@contextmanager
def _recorded(log: Path, rows: list[dict], began: float) -> Iterator[Callable[[dict], None]]:
    """What takes each finished row: stamped with when it came in, in seconds from ``began`` (``found_after_s``:
    what a user waited for it), appended to the log and to ``rows``."""
    writer = LogWriter(log)

    def record(row: dict) -> None:
        row["found_after_s"] = time.perf_counter() - began
        writer.append(row)
        rows.append(row)

    try:
        yield record
    finally:
        writer.close()


def _solve_by_search(executor: Any, todo: list, rows: list[dict], log: Path, began: float, prepared: _Prepared) -> None:
    """The search route over ``todo`` (:class:`~grasptask.synthesis.rounds.Route`), each round's rows appended
    to the log (and ``rows``) as the round ends; a resumed sweep's basins read back from its rows."""
    from grasptask.synthesis.rounds import Route, known_basins

    solver = prepared.job.solver
    route = Route(
        executor,
        prepared.job.hand.grasping_hand().joint_names,
        prepared.fingers,
        prepared.symmetry,
        solver.search_round,
        solver.polish_per_basin,
        solver.search.batch_size,
        known_basins(rows),
    )
    with _recorded(log, rows, began) as record:
        route.run(todo, record)


def summarise(
    options: SynthesisOptions,
    rows: list[dict],
    *,
    model_size: dict[str, Any] | None,
    wall_seconds: float,
    symmetry: Symmetry | None,
    solved: int | None = None,
    fingers: list[str],
    paper: PaperSynthesis,
    object_facts: dict[str, Any] | None = None,
    job: Job | None = None,
    library: Library | None = None,
    carried: dict[str, Path] | None = None,
) -> dict:
    """Write the sweep's ``solutions.parquet``, ``optima.parquet`` and ``run.json`` from its rows; the run
    summary. ``solved`` is how many of the rows this run solved in its ``wall_seconds`` (None: all of them).
    With the ``job``'s physics settings, also the physics check's summary and its best grasp's trace."""
    import casadi  # deferred, as the solver stack is: only for their versions
    import pyomo.version  # deferred with casadi

    solutions = pd.DataFrame(rows).sort_values("start_id").reset_index(drop=True)
    solutions["verified"] = solutions["verified"].fillna(False).astype(bool)
    optima = cluster(solutions, fingers, symmetry)
    seconds = solutions["seconds"].astype(float)
    run = {
        **_run_inputs(options, fingers, object_facts, library),
        **run_outcome(solutions, optima, options.task, len(rows)),
        "seconds_per_start": {
            "median": float(seconds.median()),
            "p90": float(np.percentile(seconds, 90)),
            "mean": float(seconds.mean()),
            "sd": float(seconds.std(ddof=1)) if len(seconds) > 1 else 0.0,
        },
        "sweep_wall_seconds_this_run": wall_seconds,
        # what a user waits for: starts resolved and distinct verified optima a second of this run's wall time,
        # and when the best optimum's start came in (from its run's start)
        "throughput": throughput(solutions, optima, len(solutions) if solved is None else solved, wall_seconds),
        "model_size": model_size,
        "paper": paper.figures_for(options.task),
        "versions": {"casadi": casadi.CasadiMeta.version(), "pyomo": pyomo.version.version},
    }
    config = {k: str(v) for k, v in asdict(options).items() if k != "out"}
    inputs = [options.tasks, options.hand, options.object_used, options.solver_config, options.grasp_config]
    judge = _physics_judge(solutions, job) if job is not None and job.physics is not None else None
    with StagedOutput(options.folder, Provenance.of("synthesize", config, inputs, options.seed)) as staged:
        for name, source in (carried or {}).items():  # a rerun's log and records, in place of the finished sweep's
            staged.carry(name, source)
        staged.write_parquet("solutions.parquet", solutions)
        staged.write_parquet("optima.parquet", optima)
        staged.write_json(RUN_FILE, run)
        if judge is not None:
            from grasptask.physics.judge import traced_rows, write_physics_results  # deferred: MuJoCo

            traced = [judge.trace(k, filmed) for k, filmed in traced_rows(judge, optima)]
            write_physics_results(
                staged, solutions, options.task, judge.holding.settings, traced, table_name=None, judge=judge
            )
    return run


def _run_inputs(
    options: SynthesisOptions, fingers: list[str], object_facts: dict[str, Any] | None, library: Library | None
) -> dict:
    """What the sweep was run on and how, for run.json; paths absolute: export, report and physics read them from
    any working directory."""
    return {
        "task": options.task,
        "object": os.path.abspath(options.object_used),
        # the object's task frame in its file's coordinates and how it was chosen, its unit and its mass (None:
        # not given; the physics check then assumes its config's object_mass_kg)
        **(object_facts or {}),
        "object_options": options.object_overrides,
        "hand": os.path.abspath(options.hand),
        "grasp_config": os.path.abspath(options.grasp_config),
        "tasks": os.path.abspath(options.tasks),
        "fingers": fingers,
        # the physics config of synthesize --physics (None: not checked; a physics_summary.json beside this
        # run.json is then an earlier run's)
        "physics_config": os.path.abspath(options.physics) if options.physics is not None else None,
        # the grasp library the sweep started from and added to (None: none, the sweep reproducible)
        "library": library.record() if library is not None else None,
        "backend": options.backend,
        "executor": options.executor,
        "workers": options.workers,
    }


def _physics_judge(solutions: pd.DataFrame, job: Job) -> Any:
    """The physics check's judge over this sweep's own solutions, for the best grasp's trace and the summary
    (the workers checked every verified start already)."""
    from grasptask.physics.judge import Holding, Judge  # deferred: MuJoCo

    assert job.physics is not None
    friction, torsion = job.settings.friction_coefficient, job.settings.torsional_friction_m
    solved = SolvedGrasps.of(solutions, job.hand.grasping_hand())
    return Judge(solved, job.task, Holding.of(job.obj, friction, job.physics, pad_torsion=torsion))
