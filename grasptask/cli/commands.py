"""The stage commands. Each is three parts, registered in :data:`STAGE_COMMANDS` under its name: its stage's
options made from Click's parameters, the stage (a function of :mod:`grasptask.stages`, by name, loaded on first
use) and what is said of its summary. ``pipeline run`` runs a stage's command line through the same three. No
command reads an artifact itself."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import click

from grasptask import stages
from grasptask.cli.group import main
from grasptask.cli.options import (
    fingers_option,
    mujoco_options,
    object_options,
    out_option,
    physics_config_option,
    preprocess_options,
    scale_option,
    sweep_model_options,
    sweep_task_options,
    synthesis_options,
)
from grasptask.cli.summaries import finding_lines, fit_summary, nearest_lines, number, physics_line, synthesis_line
from grasptask.stages import DEFAULT_SIMULATE_CONFIG, FORCE_UNITS, TIME_UNITS, TORQUE_UNITS, plural


@dataclass(frozen=True)
class StageCommand:
    """A command as the stage it runs: ``options`` makes the stage's options from Click's parameters (by name),
    ``stage`` runs it, and ``say`` tells its summary (and may end the command with an exit code, as
    ``click.exceptions.Exit``). Stage functions and options classes are named, not imported, so that
    ``grasptask --help`` loads none of them."""

    options: Callable[..., Any]
    stage: Callable[[Any], Any]
    say: Callable[[Any, Any], None]

    def __call__(self, params: dict[str, Any]) -> None:
        options = self.options(**params)
        self.say(options, self.stage(options))


def _stage(name: str) -> Callable[[Any], Any]:
    """The stage function ``name`` of :mod:`grasptask.stages`, loaded when the command runs."""
    return lambda options: getattr(stages, name)(options)


def _options(name: str, **renamed: str) -> Callable[..., Any]:
    """The options class ``name`` of :mod:`grasptask.stages`, made from Click's parameters by their own names
    but those ``renamed`` (a parameter's name to the field's)."""

    def make(**params: Any) -> Any:
        return getattr(stages, name)(**{renamed.get(k, k): v for k, v in params.items()})

    return make


def run_command(name: str, params: dict[str, Any]) -> None:
    """The body of every stage command: the one registered under its name."""
    STAGE_COMMANDS[name](params)


@main.command()
@out_option
@click.option(
    "--config",
    "config_path",
    type=click.Path(path_type=Path),
    default=DEFAULT_SIMULATE_CONFIG,
    show_default=True,
    help="Simulator parameters (YAML).",
)
@click.option("--seed", type=int, default=0, show_default=True, help="Seed; the output is identical for a seed.")
@click.option(
    "--format",
    "fmt",
    type=click.Choice(["csv", "parquet"]),
    default="csv",
    show_default=True,
    help="File format of the recordings.",
)
def simulate(**params):
    """Simulate sensorized-tool demonstrations: 7 subjects x 3 trials of drawing (tripod, cylindrical and
    power grasps), cutting and screw driving, 105 recordings plus manifest.csv."""
    run_command("simulate", params)


def _simulate_said(options, done) -> None:
    click.echo(f"wrote {done.recordings} recordings and {done.manifest}")


@main.command("fit-task")
@click.argument("inputs", nargs=-1, required=True, type=click.Path(path_type=Path))
@out_option
@preprocess_options
@click.option("--skip-bad", is_flag=True, help="Set aside bad recordings, list them at the end, and go on.")
@click.option("--task", default="unlabelled", show_default=True, help="Task label for plain recording files.")
@click.option("--grasp", default="free", show_default=True, help="Grasp label for plain recording files.")
@click.option(
    "--frame",
    type=click.Choice(["object", "sensor"]),
    default="object",
    show_default=True,
    help="Frame of plain recording files.",
)
@click.option("--tool", type=click.Path(path_type=Path), default=None, help="Tool config for plain recording files.")
@click.option("--torque-unit", type=click.Choice(list(TORQUE_UNITS)), default=None, help="Torque unit of plain files.")
@click.option("--force-unit", type=click.Choice(list(FORCE_UNITS)), default=None, help="Force unit of plain files.")
@click.option("--time-unit", type=click.Choice(list(TIME_UNITS)), default=None, help="Time unit of plain files.")
def fit_task(**params):
    """Fit a 6D task ellipsoid to each recording and a Log-Euclidean mean model to each task.

    INPUTS is a manifest CSV (columns path, task, subject, trial, grasp and optionally id, frame, force_unit,
    torque_unit, time_unit, tool, bias_window_s, start_s, end_s, variable, rate_hz, topic), or recording files
    (CSV, Parquet, MATLAB .mat) that share the --task/--grasp labels. Writes ellipsoids.parquet, task_models.json
    and stats.csv (the long format of the paper's Tables 1-10).

    Each recording is checked, and what is found is said once, with its figures, and kept in task_models.json:
    uneven sampling, a recording shorter than the tool config's minimum, values beyond its plausible range (a
    probable unit error), spikes, and a mean that dominates the spread (an untared sensor or the tool's weight).
    """
    run_command("fit-task", params)


def _fit_options(
    inputs, out, bias_window, trim_start, trim_end, lowpass, resample, drop_spikes, centered, skip_bad, **labels
):
    steps = stages.Preprocess(bias_window, trim_start, trim_end, lowpass, resample_hz=resample, drop_spikes=drop_spikes)
    return stages.FitTaskOptions(
        inputs=inputs, out=out, fit=stages.FitOptions(steps, centered), skip_bad=skip_bad, **labels
    )


def _fit_said(options, done) -> None:
    click.echo(fit_summary(done.ellipsoids, done.stats))
    for line in finding_lines(done.findings):
        click.echo(line)
    click.echo(f"wrote {done.out}/ellipsoids.parquet, task_models.json, stats.csv")
    if done.skipped:
        click.echo(f"skipped {len(done.skipped)} bad recording(s):", err=True)
        for exc in done.skipped:
            click.echo(f"  {exc}", err=True)


@main.command()
@click.argument("ellipsoids", type=click.Path(path_type=Path))
@out_option
def distances(**params):
    """Log-Euclidean distances between the ellipsoids of ELLIPSOIDS (ellipsoids.parquet): distances.parquet,
    distance_summary.json (leave-one-out 1-NN accuracy, silhouette, within/between means), a heatmap ordered
    as the paper's Figure 9 and a 2D embedding."""
    run_command("distances", params)


def _distances_said(options, done) -> None:
    by_task = done.by_task
    click.echo(
        f"{plural(by_task['n_ellipsoids'], 'ellipsoid')}, {plural(len(by_task['labels']), 'task')}: "
        f"LOO 1-NN task accuracy {number(by_task['loo_1nn_accuracy'])}, "
        f"silhouette {number(by_task.get('silhouette'))}, "
        f"mean normalised distance within tasks {number(by_task.get('mean_within_normalised'))}"
        f" vs between {number(by_task.get('mean_between_normalised'))}"
    )
    for line in nearest_lines(done.summary["tasks"]):
        click.echo(line)
    click.echo(done.weighing)
    click.echo(
        f"wrote {done.out}/distances.parquet, distance_summary.json, distance_heatmap.png, distance_embedding.png"
    )


@main.command("hand")
@click.argument("hand_file", type=click.Path(path_type=Path))
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Write OUT/hand.html, the hand at mid-range joints [default: no page].",
)
def hand_command(**params):
    """What grasptask understood of HAND_FILE (a URDF, an MJCF file or a hand YAML), before any sweep: its
    chains, joints with limits and couplings, fingertips, pads with their normals and fit errors, and the
    collision spheres; with --out, one self-contained HTML view of the hand with its pads and spheres over its
    true collision surfaces. Start here with a hand of your own."""
    run_command("hand", params)


def _hand_said(options, described) -> None:
    for line in described.lines:
        click.echo(line)
    if described.page is not None:
        click.echo(f"wrote {described.page}")


@main.command()
@synthesis_options
def synthesize(**params):
    """Synthesize task-oriented grasps: the NLP of the paper's Sections 5-6 solved from many starts, every
    solution checked by the independent verifier. Writes OUT/TASK/solutions.parquet (one row per start),
    optima.parquet (distinct verified optima) and run.json.

    \b
    Exit codes: 0 some grasp verified; 2 a bad input, or grasping contacts that cannot resist the task
    wherever they are placed (said before solving; see --anyway); 3 the sweep verified nothing (its last line
    says why), so that a pipeline stops there; 130 stopped (what was solved is kept)."""
    run_command("synthesize", params)


def _synthesis_options(tasks_path, object_path, physics_flag, physics_config, **given):
    return stages.SynthesisOptions(
        tasks=tasks_path,
        object=object_path,
        physics=physics_config if physics_flag else None,
        **given,  # the rest by their own names, --unit, --mass, --task-frame and --task-frame-outside included
    )


def _synthesize(options):
    """The sweep, a stop told as what of it was kept (exit code 130)."""
    try:
        return stages.run_synthesize(options, echo=click.echo)
    except stages.SweepInterrupted as stop:
        click.echo(f"interrupted: {stop}", err=True)
        raise click.exceptions.Exit(130) from None


def _synthesis_said(options, done) -> None:
    click.echo(synthesis_line(done.task, done.run))
    nothing = done.run["distinct_optima"] == 0
    if done.run.get("why_few_verified") and not nothing:
        click.echo(f"{done.task}: few starts verified: {done.run['why_few_verified']}")
    click.echo(f"wrote {done.folder}/solutions.parquet, optima.parquet, run.json")
    if nothing:
        why = done.run.get("why_few_verified") or "every start failed to solve"
        click.echo(f"{done.task}: no grasp verified (exit code 3): {why}", err=True)
        raise click.exceptions.Exit(3)


@main.command("verify")
@click.argument("solutions", type=click.Path(path_type=Path))
@sweep_task_options
@out_option
@sweep_model_options
@object_options
@fingers_option("those SOLUTIONS holds contacts of")
def verify_command(**params):
    """Check every grasp in SOLUTIONS (solutions.parquet) again with the independent verifier; writes
    OUT/verification.parquet with one row per start and its verification figures."""
    run_command("verify", params)


def _verify_said(options, done) -> None:
    click.echo(f"{done.verified}/{plural(len(done.table), 'grasp')} verified; wrote {done.path}")


@main.command()
@click.argument("solutions", type=click.Path(path_type=Path))
@sweep_task_options
@out_option
@sweep_model_options
@physics_config_option("Scene, controller, protocol and pass thresholds (YAML).")
@click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True, help="Simulation processes.")
@fingers_option("the sweep's")
@click.option(
    "--controller",
    type=click.Choice(["grip", "spring"]),
    default=None,
    help="grip: contact forces from a QP over MuJoCo's own contacts; spring: a spring on each synthesized pad "
    "(default: the physics config's, grip).",
)
@scale_option("--strength", "The hand's actuators this many times as strong as its model (10: the strong-hand check).")
@scale_option("--friction-scale", "The friction coefficient this many times the grasp config's.")
def physics(**params):
    """Hold every solved grasp of SOLUTIONS (solutions.parquet) in MuJoCo against its task's own wrenches, and
    against DexGraspBench's six forces. A URDF or MJCF hand is simulated from its own file. Writes
    OUT/physics.parquet (one row per start: pass flags, the object's worst translation and rotation, the wrench
    that failed and why (physics_why: the pad that slipped, MuJoCo's normal there against the object's, the
    friction and strength), the peak activation, the friction used and the hand's penetration) and
    OUT/physics_summary.json (pass rates and the 2x2 agreement with the analytic verifier)."""
    run_command("physics", params)


def _physics_said(options, done) -> None:
    click.echo(physics_line(done.summary))
    click.echo(f"wrote {done.out}/physics.parquet, physics_summary.json")


@main.command()
@click.argument("solutions", type=click.Path(path_type=Path))
@out_option
@sweep_task_options
@click.option(
    "--all", "every_start", is_flag=True, help="Every verified start, not only the distinct optima (optima.parquet)."
)
@mujoco_options
@sweep_model_options
@fingers_option("the sweep's")
def export(**params):
    """Write each distinct optimum of SOLUTIONS (solutions.parquet, with optima.parquet beside it) as
    OUT/optimum_NN.glb (hand collision bodies, object and contacts in the object frame, a colour per finger;
    Blender, MeshLab and three.js open it) and OUT/optimum_NN.json (joint angles by the hand file's joint names,
    the palm pose as a 4x4 matrix, contacts and normals, the contact forces and activations or joint torques per
    task wrench, Q and the verifier's figures; schema in docs/grasp_record.schema.json).

    With --mujoco, each also as a folder MuJoCo loads as it is, anywhere: look at it with
    `python -m mujoco.viewer --mjcf OUT/optimum_01/scene.xml` (load key 'grasp'); docs/guide/mujoco.md replays
    the physics check in it."""
    run_command("export", params)


def _export_said(options, done) -> None:
    what = "(.glb and .json each, grasps.json)"
    if done.held is not None:
        what = f"(.glb, .json and a MuJoCo scene folder each, grasps.json), {done.held} held in physics,"
    click.echo(f"wrote {plural(done.grasps, 'grasp')} to {done.out} {what} {done.verified_now} verified")


@main.command()
@click.option(
    "--results",
    "results_dir",
    required=True,
    type=click.Path(path_type=Path),
    help="Results folder: recordings/, tasks/ and grasps/<task>/ as the pipelines write them.",
)
@click.option("--out", type=click.Path(path_type=Path), default=None, help="Report folder [default: RESULTS/report].")
@click.option(
    "--check-browser",
    is_flag=True,
    help="Open the page in headless Chromium: every image loads, the console stays free of errors, and every "
    "interactive view draws a non-empty WebGL scene; the times are said, not judged.",
)
@click.option(
    "--screenshot", type=click.Path(path_type=Path), default=None, help="With --check-browser: save the page top."
)
@click.option(
    "--view-screenshot",
    type=click.Path(path_type=Path),
    default=None,
    help="With --check-browser: save the first grasp's interactive view as drawn.",
)
def report(**params):
    """Write a self-contained HTML report (OUT/index.html: images, interactive 3D views and plotly.js inlined;
    it works offline and can be mailed), OUT/figures/*.png and OUT/tables/*.md: Tables 1-10 beside the paper,
    ellipsoid figures, distances, synthesis statistics, every distinct optimum (interactive and as two fixed
    views) and the physics check. Parts whose inputs are missing become notes."""
    run_command("report", params)


def _report_said(options, summary) -> None:
    for line in summary.found:
        click.echo(f"found {line}")
    for note in summary.notes:
        click.echo(f"note: {note}")
    size = summary.index.stat().st_size / 1e6
    click.echo(
        f"{summary.figures} figures, {summary.views} interactive views, {summary.tables} tables in "
        f"{summary.seconds:.1f} s; index.html {size:.1f} MB"
    )
    check = summary.browser
    if check is not None:
        slowest = max((v.draw_s for v in check.views), default=0.0)
        click.echo(
            f"chromium: {check.images - len(check.broken_images)}/{check.images} images loaded, "
            f"{len(check.console_errors)} console errors, ready in {check.ready_s:.1f} s, "
            f"{len(check.views) - len(check.failed_views)}/{len(check.views)} views drawn and non-empty "
            f"(slowest {slowest:.1f} s)"
        )
        for problem in check.problems():
            click.echo(f"  {problem}", err=True)
        if not check.ok:
            raise click.exceptions.Exit(1)
    click.echo(f"report: {summary.index}")


#: the options of a stage that reads a finished sweep: --tasks and --object as those options name them
SWEEP = {"tasks_path": "tasks", "object_path": "object"}

#: every stage command by its name: what ``pipeline run`` runs a stage's command line through
STAGE_COMMANDS: dict[str, StageCommand] = {
    "simulate": StageCommand(
        _options("SimulateOptions", config_path="config", fmt="format"), _stage("run_simulate"), _simulate_said
    ),
    "fit-task": StageCommand(_fit_options, _stage("run_fit_task"), _fit_said),
    "distances": StageCommand(_options("DistanceOptions"), _stage("run_distances"), _distances_said),
    "hand": StageCommand(_options("HandOptions", hand_file="hand"), _stage("describe_hand"), _hand_said),
    "synthesize": StageCommand(_synthesis_options, _synthesize, _synthesis_said),
    "verify": StageCommand(_options("VerifyOptions", **SWEEP), _stage("run_verify"), _verify_said),
    "physics": StageCommand(_options("PhysicsOptions", **SWEEP), _stage("run_physics"), _physics_said),
    "export": StageCommand(_options("ExportOptions", **SWEEP), _stage("run_export"), _export_said),
    "report": StageCommand(_options("ReportOptions", results_dir="results"), _stage("run_report"), _report_said),
}
