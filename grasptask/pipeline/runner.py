"""Run a pipeline file.

A pipeline file (YAML) lists stages; each runs one ``grasptask`` command with the arguments you would type::

    name: demo
    state: results/demo/.pipeline.json     # optional; where the runner remembers what it ran
    final_message: "report: results/demo/report/index.html"   # optional, printed at the end
    stages:
      - name: simulate
        run: simulate
        args: [--out, results/demo/recordings, --seed, "0"]
        inputs: [configs/simulate.yaml]          # files or folders the stage reads
        outputs: [results/demo/recordings]       # what it makes

A stage is skipped when its outputs exist, are as it left them, and the hash of its command, arguments and
inputs (every file under an input folder included) matches the last successful run. Arguments that name
existing files count as inputs too; a command's default config files are not arguments, so a stage that relies
on them lists them under ``inputs``, or an edit to them goes unseen. A stage whose outputs exist but were made
or changed by someone else is not run (its files would be overwritten) unless ``--force``. Paths are relative
to the folder the runner is started from.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Annotated, Any

from pydantic import Field, Strict
from pydantic.dataclasses import dataclass as pydantic_dataclass

from grasptask.errors import BadInputError
from grasptask.io.artifacts import config_hash, path_hash, write_json_atomic
from grasptask.io.config_schema import SCHEMA, Text, load_yaml, validated
from grasptask.io.locking import folder_lock


@dataclass(frozen=True)
class Stage:
    name: str
    run: list[str]
    args: list[str]
    inputs: list[Path]
    outputs: list[Path]
    #: the stage was stopped part-way with these same inputs: its command goes on from where it stopped (a
    #: sweep's --resume) rather than refusing its unfinished outputs
    resume: bool = False

    def input_paths(self) -> list[Path]:
        """Declared inputs plus any argument that names an existing path outside this stage's outputs."""
        found = list(self.inputs)
        for token in self.args:
            path = Path(token)
            if token and not token.startswith("-") and path.exists() and not self._is_output(path):
                found.append(path)
        return list(dict.fromkeys(found))

    def _is_output(self, path: Path) -> bool:
        """The path is an output, lies inside one, or is a folder that holds one (such as ``--out``)."""
        resolved = path.resolve()
        for output in (o.resolve() for o in self.outputs):
            if resolved == output or output in resolved.parents or resolved in output.parents:
                return True
        return False

    def key(self) -> str:
        inputs = {}
        for path in self.input_paths():
            inputs[str(path)] = path_hash(path) if path.exists() else "missing"
        return config_hash({"run": self.run, "args": self.args, "inputs": inputs})


@dataclass(frozen=True)
class PipelineSpec:
    name: str
    path: Path
    stages: list[Stage]
    state_path: Path
    final_message: str = ""


@dataclass
class Outcome:
    ran: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    failed: str | None = None
    exit_code: int = 0


#: a stage argument as a YAML file may give it: text, or a number (["--starts", 4] is "--starts 4")
Argument = Annotated[str, Strict()] | Annotated[int, Strict()] | Annotated[float, Strict()]


@pydantic_dataclass(frozen=True, config=SCHEMA)
class StageFile:
    """One stage of a pipeline file: the grasptask command it runs, its arguments, what it reads and makes."""

    #: the grasptask command, as typed after grasptask (e.g. synthesize, or pipeline run)
    run: Text
    #: what the stage makes: it reruns when any of them is missing or changed
    outputs: Annotated[list[Text], Field(min_length=1)]
    #: what the runner calls the stage (default: stage-N)
    name: Text | None = None
    #: its arguments, as typed
    args: list[Argument] = field(default_factory=list)
    #: files or folders the stage reads that its arguments do not name (its default configs)
    inputs: list[Text] = field(default_factory=list)


@pydantic_dataclass(frozen=True, config=SCHEMA)
class PipelineFile:
    """A pipeline file's schema (``grasptask pipeline run FILE``)."""

    #: the pipeline's name
    name: Text
    stages: Annotated[list[StageFile], Field(min_length=1)]
    description: str = ""
    #: where the runner remembers what it ran (default: results/.pipeline/NAME.json)
    state: Text | None = None
    #: printed when the run ends
    final_message: str = ""


def load_pipeline(path: str | Path) -> PipelineSpec:
    path = Path(path)
    spec = validated(PipelineFile, load_yaml(path), path)
    stages, names = [], set()
    for index, item in enumerate(spec.stages, start=1):
        stage_name = item.name or f"stage-{index}"
        if stage_name in names:
            raise BadInputError(path, f"duplicate stage name '{stage_name}'")
        names.add(stage_name)
        stages.append(
            Stage(
                name=stage_name,
                run=item.run.split(),
                args=[str(a) for a in item.args],
                inputs=[Path(p) for p in item.inputs],
                outputs=[Path(p) for p in item.outputs],
            )
        )
    state = Path(spec.state or f"results/.pipeline/{spec.name}.json")
    return PipelineSpec(spec.name, path, stages, state, spec.final_message)


def _load_state(path: Path, force: bool) -> dict[str, dict]:
    """What the runner recorded of its last runs. An unreadable state file is an error, not a reason to rerun
    (and overwrite) everything; ``--force`` sets it aside."""
    if not path.exists():
        return {}
    try:
        state = json.loads(path.read_text())
        if not isinstance(state, dict) or not all(isinstance(v, dict) for v in state.values()):
            raise ValueError("not a mapping of stage records")
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        if force:
            return {}
        raise BadInputError(
            path, f"not a pipeline state file ({exc}); delete it, or run with --force to rerun every stage"
        ) from exc
    return state


def _save_state(path: Path, state: dict) -> None:
    """The state written whole; an empty one is no file (a run that ran nothing leaves none)."""
    if not state:
        path.unlink(missing_ok=True)
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(path, state)


def _outputs_hash(stage: Stage) -> str:
    return config_hash({str(o): path_hash(o) if o.exists() else "missing" for o in stage.outputs})


def _finished_unrecorded(stage: Stage, record: dict) -> bool:
    """Whether a stage this pipeline started, and that was stopped before its record was saved (a Ctrl-C after
    its commit, a full disk at the save), left its outputs whole: every one is there, made since it started,
    from the inputs it started with."""
    started = record.get("started")
    if not record.get("running") or not isinstance(started, (int, float)) or record.get("key") != stage.key():
        return False
    return all(o.exists() and _newest_mtime(o) >= started for o in stage.outputs)


def _newest_mtime(path: Path) -> float:
    """A file's modification time; a folder's is the newest of its files' (a staged folder is swapped in
    whole, so any of them will do; the newest is robust to one kept unchanged)."""
    if path.is_dir():
        return max((p.stat().st_mtime for p in path.rglob("*") if p.is_file()), default=path.stat().st_mtime)
    return path.stat().st_mtime


def _foreign_outputs(stage: Stage, record: dict) -> str | None:
    """Why the stage's existing outputs are not what this pipeline last made (so that running it would
    overwrite someone's files), or None. A stage this pipeline was running when it stopped owns them."""
    existing = [o for o in stage.outputs if o.exists()]
    if not existing or record.get("running"):
        return None
    if not record:
        return f"{existing[0]} exists but this pipeline did not make it"
    if "outputs" in record and record["outputs"] != _outputs_hash(stage):
        return f"its outputs ({', '.join(map(str, existing))}) changed since this pipeline made them"
    return None


#: a command's exit code when Ctrl-C or SIGTERM stopped it
INTERRUPTED = 130

#: the pipeline files running in this process (a stage that runs its own pipeline would recurse for ever)
_RUNNING: set[Path] = set()


def run_pipeline(
    spec: PipelineSpec,
    runner: Callable[[Stage], int],
    force: bool = False,
    dry_run: bool = False,
    echo: Callable[[str], Any] = print,
    check: Callable[[Stage], None] | None = None,
) -> Outcome:
    """Run ``spec``'s stages in order with ``runner`` (a stage in, its exit code out), skipping fresh ones.
    ``check`` (a stage in, a :class:`BadInputError` out for a command line its command refuses) sees every
    stage before any runs, so that a typo in the last stage costs no time and no state. A stage whose outputs
    someone else made or edited is not overwritten without ``force``. The state is locked for the run: a
    second run of the same pipeline is refused with one line. A dry run writes nothing, not even the lock."""
    running = spec.path.resolve()
    if running in _RUNNING:
        raise BadInputError(spec.path, "a stage runs this pipeline again: a pipeline cannot run itself")
    for stage in spec.stages:
        try:
            if check is not None:
                check(stage)
        except BadInputError as exc:
            raise BadInputError(spec.path, f"stage '{stage.name}': {exc.problem}") from None
    _RUNNING.add(running)
    began = time.perf_counter()
    try:
        if dry_run:
            outcome = _run_locked(spec, runner, force, dry_run, echo)
        else:
            with folder_lock(spec.state_path, f"pipeline run {spec.path}"):
                outcome = _run_locked(spec, runner, force, dry_run, echo)
    finally:
        _RUNNING.discard(running)
    if not dry_run:  # the one place a run's time is stated (the docs quote none)
        minutes = (time.perf_counter() - began) / 60
        echo(
            f"pipeline {spec.name}: {len(outcome.ran)} stages ran, {len(outcome.skipped)} skipped, "
            f"in {minutes:.1f} min" + (f"; stopped at '{outcome.failed}'" if outcome.failed else "")
        )
    return outcome


def _run_locked(
    spec: PipelineSpec, runner: Callable[[Stage], int], force: bool, dry_run: bool, echo: Callable[[str], Any]
) -> Outcome:
    state = _load_state(spec.state_path, force)
    outcome = Outcome()
    for number, stage in enumerate(spec.stages, start=1):
        label = f"[{number}/{len(spec.stages)}] {stage.name}"
        record = state.get(stage.name, {})
        if not force and _finished_unrecorded(stage, record):
            record = state[stage.name] = {"key": record["key"], "outputs": _outputs_hash(stage), "seconds": None}
            if not dry_run:
                _save_state(spec.state_path, state)
            echo(f"{label}: finished before the last run stopped; recorded")
        fresh = (
            not record.get("running")
            and record.get("key") == stage.key()
            and all(o.exists() for o in stage.outputs)
            and record.get("outputs", _outputs_hash(stage)) == _outputs_hash(stage)
        )
        if fresh and not force:
            echo(f"{label}: unchanged, skipped")
            outcome.skipped.append(stage.name)
            continue
        foreign = None if force else _foreign_outputs(stage, record)
        if foreign:
            raise BadInputError(spec.path, f"stage '{stage.name}' not run: {foreign}; rerun with --force to overwrite")
        echo(f"{label}: grasptask {' '.join([*stage.run, *stage.args])}")
        if dry_run:
            outcome.ran.append(stage.name)
            continue
        missing = next((p for p in stage.inputs if not p.exists()), None)
        if missing is not None:
            raise BadInputError(spec.path, f"stage '{stage.name}': its input {missing} does not exist")
        if _interrupted(stage, record):
            stage = replace(stage, resume=True)
            echo(f"{label}: stopped part-way in the last run; going on from there")
        code = _run_stage(spec, stage, state, runner)
        if code != 0:
            echo(f"{label}: failed with exit code {code}; later stages not run")
            outcome.failed, outcome.exit_code = stage.name, code
            return outcome
        outcome.ran.append(stage.name)
        echo(f"{label}: done in {state[stage.name]['seconds']:.1f} s")
        for output in stage.outputs:
            if not output.exists():
                echo(f"{label}: warning: its declared output {output} did not appear")
    return outcome


def _interrupted(stage: Stage, record: dict) -> bool:
    """The stage was running, with these same inputs, when the last run stopped: what it left is its own."""
    return bool(record.get("running")) and record.get("key") == stage.key()


def _run_stage(spec: PipelineSpec, stage: Stage, state: dict, runner: Callable[[Stage], int]) -> int:
    """One stage run, its record saved; its exit code. It is recorded as running while it runs: should the run
    stop between the stage's commit and the save after it, the next run knows these outputs for its own, and
    one stopped part-way (exit code 130) goes on from there. A stage that fails otherwise without touching its
    outputs (refused before it ran) leaves the record as it was."""
    before, outputs = state.get(stage.name), _outputs_hash(stage)
    start = time.perf_counter()
    state[stage.name] = {"key": stage.key(), "running": True, "started": time.time()}
    _save_state(spec.state_path, state)
    refused: BadInputError | None = None
    try:
        code = runner(stage)
    except BadInputError as exc:  # the command line itself is wrong (an unknown command or option)
        code, refused = 2, exc
    if code != 0:
        if code != INTERRUPTED and _outputs_hash(stage) == outputs:
            if before is None:
                state.pop(stage.name)
            else:
                state[stage.name] = before
            _save_state(spec.state_path, state)
        if refused is not None:
            raise BadInputError(spec.path, f"stage '{stage.name}': {refused.problem}") from None
        return code
    # the key is taken again after the run: a stage may have created inputs of its own (none do today)
    seconds = round(time.perf_counter() - start, 3)
    state[stage.name] = {"key": stage.key(), "outputs": _outputs_hash(stage), "seconds": seconds}
    _save_state(spec.state_path, state)
    return 0
