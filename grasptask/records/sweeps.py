"""A sweep read back: the files a solutions table was made from, and its rows as grasps of a hand.

The grasp-record layer, above the hand, the objects and the task: ``verify``, ``physics`` and ``export`` open a
finished sweep through :meth:`Sweep.open`, so that each input is read once, the same way, and none of those
stages imports another."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from grasptask.errors import BadInputError
from grasptask.grasp.grasp_pose import Grasp
from grasptask.grasp.grasp_settings import GraspSettings, load_grasp_settings
from grasptask.hand import load_hand
from grasptask.hand.hand_model import GraspingHand
from grasptask.io.config_schema import read_json
from grasptask.io.tables import read_table
from grasptask.objects import load_object
from grasptask.objects.surface import ImplicitObject
from grasptask.paths import DEFAULT_GRASP_CONFIG, DEFAULT_HAND, DEFAULT_OBJECT, ROOT
from grasptask.records.solutions import fingers_in, grasp_from_row, implausible_column, joint_columns
from grasptask.task.task_model import TaskModel, load_task_model


@dataclass(frozen=True)
class SweepFiles:
    """The inputs a solutions table was made from: as given, else as its sweep's ``run.json`` records them,
    else the package defaults (no default for the task models and the task)."""

    hand: Path
    object: Path
    grasp_config: Path
    fingers: tuple[str, ...] | None
    tasks: Path | None
    task: str | None

    def named_task(self, solutions: str | Path) -> tuple[Path, str]:
        """The task models and the task, given or from run.json; one line when neither names them."""
        if self.tasks is None or self.task is None:
            message = "no run.json beside it names the task models and the task: give --tasks, --task"
            raise BadInputError(solutions, message)
        return self.tasks, self.task

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
    ) -> SweepFiles:
        run_file = Path(solutions).parent / "run.json"
        used = read_json(run_file) if run_file.is_file() else {}

        def pick(given: str | Path | None, key: str, default: Path | None) -> Path | None:
            if given is not None:
                return Path(given)
            chosen = used.get(key, default)
            if chosen is not None and not isinstance(chosen, (str, Path)):
                raise BadInputError(run_file, f"field '{key}' must be a path, got {chosen!r}")
            return None if chosen is None else recorded_path(Path(chosen), run_file.parent)

        recorded = used.get("fingers")
        if recorded is not None and not (isinstance(recorded, list) and all(isinstance(f, str) for f in recorded)):
            raise BadInputError(run_file, f"field 'fingers' must be a list of finger names, got {recorded!r}")
        if task is None and not isinstance(used.get("task", ""), str):
            raise BadInputError(run_file, f"field 'task' must be a name, got {used['task']!r}")
        swept = used.get("task")
        if task is not None and isinstance(swept, str) and swept != task:  # judged under another task's wrenches
            raise BadInputError(run_file, f"the sweep is of task '{swept}', not '{task}' (--task)")

        hand_path, object_path = pick(hand, "hand", DEFAULT_HAND), pick(object, "object", DEFAULT_OBJECT)
        config = pick(grasp_config, "grasp_config", DEFAULT_GRASP_CONFIG)
        assert hand_path is not None and object_path is not None and config is not None
        return cls(
            hand=hand_path,
            object=object_path,
            grasp_config=config,
            fingers=fingers or (tuple(recorded) if recorded else None),
            tasks=pick(tasks, "tasks", None),
            task=task if task is not None else used.get("task"),
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


def read_grasps(
    solutions_path: str | Path, hand_path: str | Path, fingers: tuple[str, ...] | None = None
) -> SolvedGrasps:
    """Every start of ``solutions_path`` as a grasp of ``hand_path``'s ``fingers`` (default: those the table
    holds contacts of); a table from another hand, or with an implausible value, is one line naming the
    column (and row)."""
    solutions_path = Path(solutions_path)
    solutions = read_table(solutions_path, ("start_id", "palm_x", "palm_r00"))
    whole = load_hand(hand_path)
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
    rows: list[tuple[dict, Grasp | None]] = []
    for number, row in enumerate(solutions.to_dict("records"), start=1):
        if pd.isna(row["palm_x"]):
            rows.append((row, None))
            continue
        wrong = implausible_column(row, hand.joint_names)
        if wrong is not None:
            raise BadInputError(solutions_path, f"not a plausible value: {row[wrong]!r}", row=number, column=wrong)
        rows.append((row, grasp_from_row(row, hand.joint_names)))
    return SolvedGrasps(hand, rows)


@dataclass(frozen=True)
class Sweep:
    """A finished sweep, opened once: the files it was made from, its task model, the grasp settings, and every
    start's row and grasp of the grasping hand. The object is loaded when asked for (a mesh's repair or a GP's
    fit takes seconds, and not every reader needs it)."""

    solutions: Path
    files: SweepFiles
    tasks: Path
    task: str
    task_model: TaskModel
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
    ) -> Sweep:
        """The sweep of ``solutions``: every input left None is the one its ``run.json`` records, else the
        package's default; ``fingers`` defaults to those the table holds contacts of. A missing or malformed
        input is one line naming the file and the field."""
        files = SweepFiles.of(solutions, hand, object, grasp_config, fingers, tasks, task)
        tasks_file, task_name = files.named_task(solutions)
        return cls(
            Path(solutions),
            files,
            tasks_file,
            task_name,
            load_task_model(tasks_file, task_name),
            load_grasp_settings(files.grasp_config),
            read_grasps(solutions, files.hand, files.fingers),
            dict(object_overrides or {}),
        )

    @property
    def hand(self) -> GraspingHand:
        return self.solved.hand

    @property
    def rows(self) -> list[tuple[dict, Grasp | None]]:
        return self.solved.rows

    def load_object(self, say: Callable[[str], Any] = lambda _: None) -> ImplicitObject:
        """The sweep's object; ``say`` hears what was repaired in a mesh (synthesize said it once already)."""
        return load_object(self.files.object, say=say, **self.object_overrides)


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
