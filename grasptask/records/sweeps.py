"""A sweep read back: the files a solutions table was made from, and its rows as grasps of a hand.

The grasp-record layer, above the hand, the objects and the task: ``verify``, ``physics``, ``export`` and the
report open a finished sweep through :meth:`Sweep.open`, so that each input is read once, the same way, and
none of those stages imports another."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import pandas as pd

from grasptask.errors import BadInputError
from grasptask.grasp.grasp_pose import Grasp
from grasptask.grasp.grasp_settings import GraspSettings, load_grasp_settings
from grasptask.hand import load_hand
from grasptask.hand.hand_model import GraspingHand, Hand
from grasptask.io.sweep_log import read_log
from grasptask.io.tables import check_numbers, read_table
from grasptask.objects import load_object
from grasptask.objects.surface import ImplicitObject
from grasptask.paths import DEFAULT_GRASP_CONFIG, DEFAULT_HAND, DEFAULT_OBJECT, ROOT
from grasptask.records.run_record import RUN_FILE, read_run, run_file, summarised_rows
from grasptask.records.solutions import (
    GRASP_PREFIXES,
    fingers_in,
    grasp_from_row,
    implausible_column,
    joint_columns,
)
from grasptask.task.task_model import TaskModel, load_task_model

#: the tables a sweep's folder holds beside its run record
SOLUTIONS, OPTIMA, LOG = "solutions.parquet", "optima.parquet", "solutions.jsonl"


@dataclass(frozen=True)
class SweepFiles:
    """The inputs a solutions table was made from: as given, else as its sweep's ``run.json`` records them,
    else the package defaults (no default for the task models; the task defaults to the sweep's folder's name,
    as ``synthesize --out X`` writes ``X/<task>/``)."""

    hand: Path
    object: Path
    grasp_config: Path
    fingers: tuple[str, ...] | None
    tasks: Path | None
    task: str

    def task_models(self, solutions: str | Path) -> Path:
        """The task models, given or from run.json; one line when neither names them."""
        if self.tasks is None:
            raise BadInputError(solutions, "no run.json beside it names the task models: give --tasks")
        return self.tasks

    @classmethod
    def of(
        cls,
        solutions: str | Path,
        hand: str | Path | None = None,
        object: str | Path | None = None,
        grasp_config: str | Path | None = None,
        fingers: tuple[str, ...] | None = None,
        tasks: str | Path | None = None,
        task: str | None = None,
        run: dict[str, Any] | None = None,
    ) -> SweepFiles:
        """``run``: the sweep's run record, where the caller has read it already."""
        folder = Path(solutions).parent
        used = read_run(folder) if run is None else run
        swept = used.get("task")
        if task is not None and swept is not None and swept != task:  # judged under another task's wrenches
            raise BadInputError(run_file(folder), f"the sweep is of task '{swept}', not '{task}' (--task)")

        def pick(given: str | Path | None, key: str) -> Path | None:
            if given is not None:
                return Path(given)
            chosen = used.get(key)
            return None if chosen is None else recorded_path(Path(chosen), folder)

        recorded = used.get("fingers")
        return cls(
            hand=pick(hand, "hand") or DEFAULT_HAND,
            object=pick(object, "object") or DEFAULT_OBJECT,
            grasp_config=pick(grasp_config, "grasp_config") or DEFAULT_GRASP_CONFIG,
            fingers=fingers or (tuple(recorded) if recorded else None),
            tasks=pick(tasks, "tasks"),
            task=task or swept or folder.resolve().name,
        )


def recorded_path(path: Path, beside: Path) -> Path:
    """A path a sweep's ``run.json`` recorded. Older sweeps recorded them relative to where they ran: such a path
    is taken from the working directory when it is there, else from the ``run.json``'s folder and its parents,
    else from the project (the bundled configs)."""
    if path.is_absolute() or path.exists():
        return path
    for folder in (beside.resolve(), *beside.resolve().parents, ROOT):
        if (folder / path).exists():
            return folder / path
    return path


@dataclass(frozen=True)
class SolvedGrasps:
    """A solutions table read for re-judging: the grasping hand it was made with, and each start's row and
    grasp (None where the start has no solution)."""

    hand: GraspingHand
    rows: list[tuple[dict, Grasp | None]]

    @classmethod
    def of(cls, solutions: pd.DataFrame, hand: GraspingHand, path: str | Path = "solutions") -> SolvedGrasps:
        """Each row of ``solutions`` as a grasp of ``hand``; an implausible value is one line naming the row
        and column of ``path``."""
        rows: list[tuple[dict, Grasp | None]] = []
        for number, row in enumerate(solutions.to_dict("records"), start=1):
            if pd.isna(row.get("palm_x")):
                rows.append((row, None))
                continue
            wrong = implausible_column(row, hand.joint_names)
            if wrong is not None:
                raise BadInputError(path, f"not a plausible value: {row[wrong]!r}", row=number, column=wrong)
            rows.append((row, grasp_from_row(row, hand.joint_names)))
        return cls(hand, rows)


def read_grasps(solutions_path: str | Path, whole: Hand, fingers: tuple[str, ...] | None = None) -> SolvedGrasps:
    """Every start of ``solutions_path`` as a grasp of the hand ``whole``'s ``fingers`` (default: those the
    table holds contacts of); a table from another hand, or with an implausible value, is one line naming the
    column (and row)."""
    solutions_path = Path(solutions_path)
    solutions = read_table(solutions_path, ("start_id", "palm_x", "palm_r00"))
    chosen = list(fingers) if fingers else fingers_in(list(solutions.columns), list(whole.fingers))
    if len(chosen) < 2:
        raise BadInputError(solutions_path, f"holds contacts of fewer than two of hand '{whole.name}''s fingers")
    try:
        hand = whole.with_grasping(chosen).grasping_hand()
    except KeyError as exc:
        raise BadInputError("--fingers", f"hand '{whole.name}' has no finger {exc}") from None
    for column in joint_columns(hand.joint_names):
        if column not in solutions.columns:
            raise BadInputError(solutions_path, "missing column", column=column)
    if not pd.api.types.is_integer_dtype(solutions["start_id"]):
        raise BadInputError(solutions_path, "must hold whole numbers", column="start_id")
    if solutions.empty:
        raise BadInputError(solutions_path, "holds no starts")
    repeated = solutions["start_id"].duplicated()
    if repeated.any():
        number = int(repeated.to_numpy().argmax()) + 1
        raise BadInputError(
            solutions_path, f"start {solutions['start_id'].iloc[number - 1]} again", row=number, column="start_id"
        )
    # "False" as text is a true value to Python: a verdict column must be booleans (missing: not verified)
    if "verified" in solutions.columns and not (
        pd.api.types.is_bool_dtype(solutions["verified"]) or solutions["verified"].isna().all()
    ):
        raise BadInputError(
            solutions_path, f"must hold true or false, not {solutions['verified'].dtype} values", column="verified"
        )
    if "seconds" in solutions.columns:  # a failed start has no time
        check_numbers(solutions_path, solutions, ["seconds"], missing_ok=True)
    return SolvedGrasps.of(solutions, hand, solutions_path)


@dataclass(frozen=True)
class Sweep:
    """A finished sweep, opened once: the files it was made from, its run record, the grasp settings, and every
    start's row and grasp of the grasping hand. The task model, the optima table and the object are read when
    asked for (a mesh's repair or a GP's fit takes seconds, and not every reader needs each)."""

    solutions: Path
    files: SweepFiles
    #: what run.json records ({} for a table with none beside it)
    run: dict[str, Any]
    settings: GraspSettings
    solved: SolvedGrasps
    #: --unit, --mass, --task-frame and --task-frame-outside for the object, where given
    object_overrides: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def open(
        cls,
        solutions: str | Path,
        *,
        tasks: str | Path | None = None,
        task: str | None = None,
        hand: str | Path | None = None,
        object: str | Path | None = None,
        grasp_config: str | Path | None = None,
        fingers: tuple[str, ...] | None = None,
        object_overrides: dict[str, Any] | None = None,
        hands: dict[Path, Hand] | None = None,
    ) -> Sweep:
        """The sweep of ``solutions``: every input left None is the one its ``run.json`` records, else the
        package's default; ``fingers`` defaults to those the table holds contacts of. ``hands``: hands already
        loaded, by path (a mesh hand's cover takes seconds). A missing or malformed input is one line naming the
        file and the field."""
        run = read_run(Path(solutions).parent)
        files = SweepFiles.of(solutions, hand, object, grasp_config, fingers, tasks, task, run)
        hands = {} if hands is None else hands
        whole = hands.get(files.hand) or hands.setdefault(files.hand, load_hand(files.hand))
        return cls(
            Path(solutions),
            files,
            run,
            load_grasp_settings(files.grasp_config),
            read_grasps(solutions, whole, files.fingers),
            dict(object_overrides or {}),
        )

    @property
    def folder(self) -> Path:
        return self.solutions.parent

    @property
    def run_file(self) -> Path:
        return run_file(self.folder)

    @property
    def task(self) -> str:
        return self.files.task

    @property
    def tasks(self) -> Path:
        return self.files.task_models(self.solutions)

    @cached_property
    def task_model(self) -> TaskModel:
        return load_task_model(self.tasks, self.task)

    @property
    def hand(self) -> GraspingHand:
        return self.solved.hand

    @property
    def rows(self) -> list[tuple[dict, Grasp | None]]:
        return self.solved.rows

    @cached_property
    def table(self) -> pd.DataFrame:
        """The solutions table, every start a row, as a frame."""
        return pd.DataFrame([row for row, _ in self.rows])

    @cached_property
    def optima(self) -> pd.DataFrame:
        """The sweep's distinct verified optima (``optima.parquet`` beside it), best first; a table of another
        hand, or with a value that is not a finite number, is one line naming the column."""
        path = self.folder / OPTIMA
        optima = read_table(path)
        hand = self.hand
        wanted = [*joint_columns(hand.joint_names), *(f"contact_{f}_x" for f in hand.fingers)]
        absent = next((c for c in wanted if c not in optima.columns), None)
        if not optima.empty and absent is not None:
            raise BadInputError(
                path, f"not a table of hand '{hand.name}' ({self.files.hand}): fingers {list(hand.fingers)}, no "
                f"column '{absent}'",
            )  # fmt: skip
        numeric = [c for c in optima.columns if c.startswith(GRASP_PREFIXES) or c == "Q"]
        check_numbers(path, optima, numeric + (["verify_Q"] if "verify_Q" in optima.columns else []), False)
        return optima

    def load_object(self, say: Callable[[str], Any] = lambda _: None) -> ImplicitObject:
        """The sweep's object; ``say`` hears what was repaired in a mesh (synthesize said it once already)."""
        return load_object(self.files.object, say=say, **self.object_overrides)


def finished_sweeps(root: str | Path) -> list[Path]:
    """The folders under ``root`` that hold a finished sweep (a run record beside its solutions), at any depth,
    not in hidden folders (a stage's staging folder)."""
    return _beside_a_sweep(Path(root), RUN_FILE)


def unfinished_sweeps(root: str | Path) -> list[Path]:
    """The folders under ``root`` whose per-start log holds rows that no run record summarises: a sweep
    interrupted or still running (with or without the run record of an earlier, finished sweep)."""
    return [f for f in _beside_a_sweep(Path(root), LOG) if summarised_rows(f) != len(read_log(f / LOG).rows)]


def unfinished_state(folder: Path) -> str:
    """What an unfinished sweep's folder holds, said as what it is: a run that ended before any start finished
    (an empty log), or starts that no run record summarises (interrupted, or still running)."""
    rows, summarised = len(read_log(folder / LOG).rows), summarised_rows(folder)
    if rows == 0:
        earlier = f"; the run record summarises {summarised} starts the log no longer holds" if summarised else ""
        return (
            f"{folder}: a sweep that ended before any start finished ({LOG} is empty){earlier}; run it again, or "
            "go on with synthesize --resume"
        )
    said = f"{rows} start" + ("" if rows == 1 else "s")
    record = "no run.json summarises" if summarised is None else f"its run.json summarises {summarised} of"
    return (
        f"{folder}: {LOG} holds {said}, and {record} them (interrupted, or still running); finish the sweep "
        "with synthesize --resume"
    )


def _beside_a_sweep(root: Path, name: str) -> list[Path]:
    found = []
    for path in root.rglob(name):
        inside = path.parent.relative_to(root).parts
        if any(part.startswith(".") for part in inside):
            continue
        if any((path.parent / kept).is_file() for kept in (SOLUTIONS, LOG)):
            found.append(path.parent)
    return sorted(found)


@dataclass(frozen=True, kw_only=True)
class SweepInputs:
    """Which finished sweep a stage reads, and which of its inputs to replace: each left None is the one its
    ``run.json`` records, else the package's default; ``fingers`` defaults to those the table holds contacts of.
    The options of ``verify``, ``physics`` and ``export`` start from these."""

    solutions: Path
    tasks: Path | None = None
    task: str | None = None
    hand: Path | None = None
    object: Path | None = None
    grasp_config: Path | None = None
    fingers: tuple[str, ...] | None = None

    def open_sweep(self, object_overrides: dict[str, Any] | None = None) -> Sweep:
        return Sweep.open(
            self.solutions, tasks=self.tasks, task=self.task, hand=self.hand, object=self.object,
            grasp_config=self.grasp_config, fingers=self.fingers, object_overrides=object_overrides,
        )  # fmt: skip
