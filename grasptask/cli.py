"""``grasptask``: the command-line interface, a thin layer over :mod:`grasptask.stages`."""

from __future__ import annotations

import math
import os
import signal
import threading
from pathlib import Path
from typing import Any

import click

from grasptask import __version__, stages
from grasptask.stages import (
    DEFAULT_GRASP_CONFIG,
    DEFAULT_HAND,
    DEFAULT_OBJECT,
    DEFAULT_SIMULATE_CONFIG,
    DEFAULT_SOLVER_CONFIG,
    FORCE_UNITS,
    TIME_UNITS,
    TORQUE_UNITS,
    BadInputError,
)


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


class _Group(click.Group):
    """Turns :class:`BadInputError`, and an output folder that cannot be written (read-only, a full disk), into
    one line on stderr and exit code 2; SIGTERM into the same orderly stop as Ctrl-C (exit code 130), so that
    no half-written artifact, staging folder or lock is left behind."""

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
            return super().invoke(ctx)
        except BadInputError as exc:
            click.echo(f"error: {exc}", err=True)
            raise click.exceptions.Exit(2) from None
        except OSError as exc:
            where = exc.filename or ctx.invoked_subcommand or "grasptask"
            click.echo(f"error: {where}: {exc.strerror or exc}", err=True)
            raise click.exceptions.Exit(2) from None
        except KeyboardInterrupt:
            click.echo("interrupted: nothing half-written was kept", err=True)
            raise click.exceptions.Exit(130) from None
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


def _out_option(f):
    return click.option(
        "--out", required=True, type=click.Path(file_okay=False, path_type=Path), help="Output folder."
    )(f)


@main.command()
@_out_option
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
def simulate(out, config_path, seed, fmt):
    """Simulate sensorized-tool demonstrations: 7 subjects x 3 trials of drawing (tripod, cylindrical and
    power grasps), cutting and screw driving, 105 recordings plus manifest.csv."""
    summary = stages.run_simulate(config_path, out, seed, fmt)
    click.echo(f"wrote {summary['recordings']} recordings and {summary['manifest']}")


@main.command("fit-task")
@click.argument("inputs", nargs=-1, required=True, type=click.Path(path_type=Path))
@_out_option
@click.option(
    "--bias-window",
    type=click.FloatRange(min=0),
    default=None,
    help="Seconds of initial static data to subtract as bias, then drop (default: the manifest's "
    "bias_window_s column, else none).",
)
@click.option(
    "--trim-start", type=click.FloatRange(min=0), default=0.0, show_default=True, help="Seconds to drop at the start."
)
@click.option(
    "--trim-end", type=click.FloatRange(min=0), default=0.0, show_default=True, help="Seconds to drop at the end."
)
@click.option(
    "--lowpass",
    type=click.FloatRange(min=0, min_open=True),
    default=None,
    help="Zero-phase Butterworth low-pass cutoff in Hz (default: no filtering).",
)
@click.option("--centered", is_flag=True, help="Use the covariance instead of the second moment about the origin.")
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
def fit_task(
    inputs,
    out,
    bias_window,
    trim_start,
    trim_end,
    lowpass,
    centered,
    skip_bad,
    task,
    grasp,
    frame,
    tool,
    torque_unit,
    force_unit,
    time_unit,
):
    """Fit a 6D task ellipsoid to each recording and a Log-Euclidean mean model to each task.

    INPUTS is a manifest CSV (columns path, task, subject, trial, grasp and optionally id, frame, force_unit,
    torque_unit, time_unit, tool, bias_window_s), or recording files that share the --task/--grasp labels.
    Writes ellipsoids.parquet, task_models.json and stats.csv (the long format of the paper's Tables 1-10).
    """
    options = stages.FitOptions(stages.Preprocess(bias_window, trim_start, trim_end, lowpass), centered)
    units = {"torque_unit": torque_unit, "force_unit": force_unit, "time_unit": time_unit}
    result, stats = stages.run_fit_task(
        inputs, out, options, skip_bad, task=task, grasp=grasp, frame=frame, tool=tool, units=units
    )
    click.echo(_fit_summary(result.ellipsoids, stats))
    click.echo(f"wrote {out}/ellipsoids.parquet, task_models.json, stats.csv")
    if result.skipped:
        click.echo(f"skipped {len(result.skipped)} bad recording(s):", err=True)
        for exc in result.skipped:
            click.echo(f"  {exc}", err=True)


def _fit_summary(ellipsoids, stats) -> str:
    """Per group (paper order): recordings and the mean main-axis lengths of the force and torque ellipsoids."""
    main_axis = stats[(stats["stat"] == "mu") & (stats["axis"] == "3")]
    counts = ellipsoids.groupby("group").size()
    lines = [f"{'group':<24}{'n':>4}{'force main axis (N)':>22}{'torque main axis (N.cm)':>26}"]
    for group, rows in main_axis.groupby("group", sort=False):
        force, torque = (rows.loc[rows["domain"] == d, "value"].iloc[0] for d in ("force", "torque"))
        lines.append(f"{group:<24}{counts[group]:>4}{force:>22.2f}{torque:>26.2f}")
    return "\n".join(lines)


def _number(value) -> str:
    """Three significant digits: a Q of 0.00074 is not 0.001."""
    return "n/a" if value is None else f"{value:.3g}"


@main.command()
@click.argument("ellipsoids", type=click.Path(path_type=Path))
@_out_option
def distances(ellipsoids, out):
    """Log-Euclidean distances between the ellipsoids of ELLIPSOIDS (ellipsoids.parquet): distances.parquet,
    distance_summary.json (leave-one-out 1-NN accuracy, silhouette, within/between means), a heatmap ordered
    as the paper's Figure 9 and a 2D embedding."""
    summary = stages.run_distances(ellipsoids, out)
    by_task = summary["by_task"]
    click.echo(
        f"{by_task['n_ellipsoids']} ellipsoids, {len(by_task['labels'])} tasks: "
        f"LOO 1-NN task accuracy {_number(by_task['loo_1nn_accuracy'])}, "
        f"silhouette {_number(by_task.get('silhouette'))}, "
        f"mean normalised distance within tasks {_number(by_task.get('mean_within_normalised'))}"
        f" vs between {_number(by_task.get('mean_between_normalised'))}"
    )
    click.echo(f"wrote {out}/distances.parquet, distance_summary.json, distance_heatmap.png, distance_embedding.png")


@main.command("hand")
@click.argument("hand_file", type=click.Path(path_type=Path))
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=None,
    help="Write OUT/hand.html, the hand at mid-range joints [default: no page].",
)
def hand_command(hand_file, out):
    """What grasptask understood of HAND_FILE (a URDF, an MJCF file or a hand YAML), before any sweep: its
    chains, joints with limits and couplings, fingertips, pads with their normals and fit errors, and the
    collision spheres; with --out, one self-contained HTML view of the hand with its pads and spheres over its
    true collision surfaces. Start here with a hand of your own."""
    described = stages.describe_hand(hand_file, out)
    for line in described.lines:
        click.echo(line)
    if described.page is not None:
        click.echo(f"wrote {described.page}")


def _finger_list(ctx, param, value):
    if value is None:
        return None
    names = tuple(n.strip() for n in value.split(",") if n.strip())
    if not names:
        raise click.BadParameter("name the fingers, e.g. thumb,index,middle,ring")
    return names


def _fingers_option(default: str):
    def decorate(f):
        return click.option(
            "--fingers",
            default=None,
            callback=_finger_list,
            help=f"Grasping fingers, comma-separated (e.g. thumb,index,middle,ring) [default: {default}].",
        )(f)

    return decorate


def _physics_config_option(help_text: str):
    return click.option(
        "--physics-config",
        type=click.Path(path_type=Path),
        default=stages.DEFAULT_PHYSICS_CONFIG,
        show_default=True,
        help=help_text,
    )


def _scale_option(name: str, help_text: str):
    """A positive multiple of a model's value, 1 by default."""
    return click.option(
        name, type=click.FloatRange(min=0, min_open=True), default=1.0, show_default=True, help=help_text
    )


def _model_option_set(sweep: bool):
    """--hand, --object and --grasp-config: the package's defaults (synthesize, verify), or with ``sweep`` what
    the sweep of SOLUTIONS used, from its run.json (physics, export)."""
    options = (
        ("--grasp-config", "grasp_config", DEFAULT_GRASP_CONFIG, "Friction and pad-angle settings (YAML)."),
        ("--object", "object_path", DEFAULT_OBJECT, "Object config (YAML) or mesh."),
        ("--hand", "hand", DEFAULT_HAND,
         "Hand: the project's YAML, a URDF, an MJCF file, or a YAML pointing at one (model: FILE)."),
    )  # fmt: skip

    def decorate(f):
        for flag, name, default, text in options:
            if sweep:
                f = click.option(flag, name, type=click.Path(path_type=Path), default=None,
                                 help=f"{text} [default: the sweep's, from run.json].")(f)  # fmt: skip
            else:
                f = click.option(flag, name, type=click.Path(path_type=Path), default=default, show_default=True,
                                 help=text)(f)  # fmt: skip
        return f

    return decorate


_model_options = _model_option_set(sweep=False)
_sweep_model_options = _model_option_set(sweep=True)


def _object_options(f):
    """--unit, --mass, --task-frame and --task-frame-outside: what a bare mesh or point cloud cannot say (a mesh
    YAML's fields), passed on as the keywords ``unit``, ``mass_kg``, ``task_frame`` and ``task_frame_outside``."""
    f = click.option(
        "--task-frame-outside",
        is_flag=True,
        default=None,
        help="Take a task frame (origin) that lies outside the object or within 5 mm of its surface "
        "(task_frame_outside in a mesh YAML); the centre is always taken.",
    )(f)
    f = click.option(
        "--task-frame",
        type=click.Choice(["centre", "origin"]),
        default=None,
        help="The object's task frame: centre (its centre of volume, z along its longest axis: a bare file's "
        "default) or origin (the file's own frame).",
    )(f)
    f = click.option(
        "--mass", "mass_kg", type=click.FloatRange(min=0, min_open=True), default=None,
        help="The object's mass (kg), for the physics check [default: the object YAML's mass_kg; none is stated].",
    )(f)  # fmt: skip
    return click.option(
        "--unit",
        type=click.Choice(["m", "cm", "mm"]),
        default=None,
        help="The length unit of a mesh or point-cloud object's file [default: the YAML's unit, or m].",
    )(f)


@main.command()
@click.option(
    "--tasks", "tasks_path", required=True, type=click.Path(path_type=Path), help="task_models.json from fit-task."
)
@click.option("--task", required=True, help="Task to grasp for, e.g. drawing, cutting, screwdriving.")
@_out_option
@_model_options
@_object_options
@click.option(
    "--solver-config",
    type=click.Path(path_type=Path),
    default=DEFAULT_SOLVER_CONFIG,
    show_default=True,
    help="IPOPT options and time limits (YAML).",
)
@click.option(
    "--starts", type=click.IntRange(min=1), default=None, help="Run a deterministic subset of the 126 starts."
)
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the starts' jitter.")
@click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True, help="Solver processes.")
@click.option(
    "--executor",
    type=click.Choice(["pool", "serial", "dask"]),
    default="pool",
    show_default=True,
    help="pool: local processes (a crashed or hung start is recorded and the sweep goes on); serial: in "
    "this process; dask: a Dask cluster at --scheduler.",
)
@click.option("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://10.0.0.5:8786.")
@click.option(
    "--solver",
    "backend",
    type=click.Choice(["casadi", "cyipopt"]),
    default="casadi",
    show_default=True,
    help="IPOPT through CasADi's nlpsol, or the same CasADi functions through cyipopt.",
)
@click.option(
    "--resume",
    is_flag=True,
    help="Keep the starts already in solutions.jsonl and solve only the rest; refused if the folder holds another run.",
)
@_fingers_option("the hand file's choice; for a URDF or MJCF hand, all its fingers")
@click.option(
    "--physics",
    "physics_flag",
    is_flag=True,
    help="Also hold each verified grasp in MuJoCo against the task's wrenches (see `grasptask physics`).",
)
@_physics_config_option("With --physics: scene, controller, protocol and thresholds (YAML).")
def synthesize(
    tasks_path,
    task,
    out,
    hand,
    object_path,
    grasp_config,
    solver_config,
    starts,
    seed,
    workers,
    executor,
    scheduler,
    backend,
    resume,
    fingers,
    physics_flag,
    physics_config,
    **object_options,
):
    """Synthesize task-oriented grasps: the NLP of the paper's Sections 5-6 solved from many starts, every
    solution checked by the independent verifier. Writes OUT/TASK/solutions.parquet (one row per start),
    optima.parquet (distinct verified optima) and run.json."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    options = stages.SynthesisOptions(
        tasks=tasks_path,
        task=task,
        out=out,
        hand=hand,
        object=object_path,
        solver_config=solver_config,
        grasp_config=grasp_config,
        starts=starts,
        seed=seed,
        workers=workers,
        executor=executor,
        scheduler=scheduler,
        backend=backend,
        resume=resume,
        fingers=fingers,
        physics=physics_config if physics_flag else None,
        **object_options,  # --unit, --mass, --task-frame, --task-frame-outside
    )
    try:
        run = stages.run_synthesize(options, echo=click.echo)
    except stages.SweepInterrupted as stop:
        click.echo(f"interrupted: {stop}", err=True)
        raise click.exceptions.Exit(130) from None
    seconds = run["seconds_per_start"]
    click.echo(
        f"{task}: {run['verified']}/{run['starts']} starts verified ({run['verified_on_retry']} on a retry), "
        f"{run['distinct_optima']} distinct optima, "
        f"best Q {_number(run['best_Q'])}{_verifier_said(run)}; {seconds['median']:.2f} s per start (median), "
        f"statuses {', '.join(f'{k} {v}' for k, v in run['status_counts'].items() if v)}"
        f"{_throughput_said(run)}{_object_said(run)}"
    )
    if run.get("why_few_verified"):
        click.echo(f"{task}: few starts verified: {run['why_few_verified']}")
    click.echo(f"wrote {out}/{task}/solutions.parquet, optima.parquet, run.json")


def _throughput_said(run: dict) -> str:
    """The summary's word on what the user waited for: starts and distinct optima a second, and when the best
    grasp came in."""
    rates = run.get("throughput") or {}
    if not rates or not math.isfinite(rates["starts_per_s"]):
        return ""
    best = rates.get("best_Q_after_s")
    found = f", the best Q after {best:.0f} s" if best is not None else ""
    return f"; {rates['starts_per_s']:.2f} starts/s, {rates['optima_per_s']:.2f} optima/s{found}"


def _object_said(run: dict) -> str:
    """The summary's word on a mesh or cloud object: where its task frame is, and a mass not given."""
    frame = run.get("task_frame") or {}
    if frame.get("rule") in (None, "object"):
        return ""
    origin = ", ".join(str(int(round(row[3] * 1e3))) for row in frame["in_file_frame"][:3])  # no "-0"
    said = f"; task frame: {frame['rule']}, at ({origin}) mm in the file's frame"
    if run.get("object_mass_kg") is None:
        said += "; the object's mass is not given (physics takes its config's object_mass_kg; --mass KG)"
    return said


@main.command("verify")
@click.argument("solutions", type=click.Path(path_type=Path))
@click.option(
    "--tasks", "tasks_path", type=click.Path(path_type=Path), default=None,
    help="task_models.json [default: the sweep's, from its run.json].",
)  # fmt: skip
@click.option("--task", default=None, help="The task the solutions were made for [default: the sweep's].")
@_out_option
@_sweep_model_options
@_object_options
@_fingers_option("those SOLUTIONS holds contacts of")
def verify_command(solutions, tasks_path, task, out, hand, object_path, grasp_config, fingers, **object_options):
    """Check every grasp in SOLUTIONS (solutions.parquet) again with the independent verifier; writes
    OUT/verification.parquet with one row per start and its verification figures."""
    table = stages.run_verify(
        solutions, tasks_path, task, out, hand, object_path, grasp_config, fingers, object_options
    )
    click.echo(f"{int(table['verified'].sum())}/{len(table)} grasps verified; wrote {out}/verification.parquet")


@main.command()
@click.argument("solutions", type=click.Path(path_type=Path))
@click.option(
    "--tasks", "tasks_path", type=click.Path(path_type=Path), default=None,
    help="task_models.json [default: the sweep's, from its run.json].",
)  # fmt: skip
@click.option("--task", default=None, help="The task the solutions were made for [default: the sweep's].")
@_out_option
@_sweep_model_options
@_physics_config_option("Scene, controller, protocol and pass thresholds (YAML).")
@click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True, help="Simulation processes.")
@_fingers_option("the sweep's")
@click.option(
    "--controller",
    type=click.Choice(["grip", "spring"]),
    default=None,
    help="grip: contact forces from a QP over MuJoCo's own contacts; spring: a spring on each synthesized pad "
    "(default: the physics config's, grip).",
)
@_scale_option("--strength", "The hand's actuators this many times as strong as its model (10: the strong-hand check).")
@_scale_option("--friction-scale", "The friction coefficient this many times the grasp config's.")
def physics(
    solutions,
    tasks_path,
    task,
    out,
    hand,
    object_path,
    grasp_config,
    physics_config,
    workers,
    fingers,
    controller,
    strength,
    friction_scale,
):
    """Hold every solved grasp of SOLUTIONS (solutions.parquet) in MuJoCo against its task's own wrenches, and
    against DexGraspBench's six forces. A URDF or MJCF hand is simulated from its own file. Writes
    OUT/physics.parquet (one row per start: pass flags, the object's worst translation and rotation, the wrench
    that failed, the peak activation, the friction used and the hand's penetration) and
    OUT/physics_summary.json (pass rates and the 2x2 agreement with the analytic verifier)."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    inputs = stages.PhysicsInputs(
        solutions, tasks_path, task, hand, object_path, grasp_config, physics_config, fingers, controller, strength,
        friction_scale,
    )  # fmt: skip
    stages.run_physics(inputs, out, workers, echo=click.echo)
    click.echo(f"wrote {out}/physics.parquet, physics_summary.json")


@main.command()
@click.argument("solutions", type=click.Path(path_type=Path))
@_out_option
@click.option(
    "--tasks",
    "tasks_path",
    type=click.Path(path_type=Path),
    default=None,
    help="task_models.json, for the forces per task wrench [default: the sweep's].",
)
@click.option("--task", default=None, help="The task the solutions were made for [default: the sweep's].")
@click.option(
    "--all", "every_start", is_flag=True, help="Every verified start, not only the distinct optima (optima.parquet)."
)
@_sweep_model_options
@_fingers_option("the sweep's")
def export(solutions, out, tasks_path, task, every_start, hand, object_path, grasp_config, fingers):
    """Write each distinct optimum of SOLUTIONS (solutions.parquet, with optima.parquet beside it) as
    OUT/optimum_NN.glb (hand collision bodies, object and contacts in the object frame, a colour per finger;
    Blender, MeshLab and three.js open it) and OUT/optimum_NN.json (joint angles by the hand file's joint names,
    the palm pose as a 4x4 matrix, contacts and normals, the contact forces and activations or joint torques per
    task wrench, Q and the verifier's figures; schema in docs/grasp_record.schema.json)."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    done = stages.run_export(solutions, out, tasks_path, task, hand, object_path, grasp_config, fingers, every_start)
    click.echo(f"wrote {done.grasps} grasps to {out} (.glb and .json each, grasps.json), {done.verified_now} verified")


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
def report(results_dir, out, check_browser, screenshot, view_screenshot):
    """Write a self-contained HTML report (OUT/index.html: images, interactive 3D views and plotly.js inlined;
    it works offline and can be mailed), OUT/figures/*.png and OUT/tables/*.md: Tables 1-10 beside the paper,
    ellipsoid figures, distances, synthesis statistics, every distinct optimum (interactive and as two fixed
    views) and the physics check. Parts whose inputs are missing become notes."""
    out = out or results_dir / "report"
    # what the browser check needs is checked before the report is built, not after
    for option, path in (("--screenshot", screenshot), ("--view-screenshot", view_screenshot)):
        if path is not None:
            if not check_browser:
                raise BadInputError(option, "needs --check-browser (the screenshot is the browser's)")
            stages.check_screenshot_path(path)
    if check_browser and stages.find_chromium() is None:
        raise BadInputError("chromium", "not installed (apt-get install chromium chromium-driver)")
    summary = stages.build_report(results_dir, out)
    for line in summary.found:
        click.echo(f"found {line}")
    for note in summary.notes:
        click.echo(f"note: {note}")
    size = summary.index.stat().st_size / 1e6
    click.echo(
        f"{summary.figures} figures, {summary.views} interactive views, {summary.tables} tables in "
        f"{summary.seconds:.1f} s; index.html {size:.1f} MB"
    )
    if check_browser:
        check = stages.check_page(summary.index, screenshot, view_screenshot=view_screenshot)
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


def _verifier_said(run: dict) -> str:
    """The verifier's Q of the best optimum beside the NLP's, where they differ by over 1%: which is which."""
    nlp, verifier = run.get("best_Q"), run.get("best_Q_verifier")
    if nlp is None or verifier is None or abs(verifier - nlp) <= 0.01 * abs(nlp):
        return ""
    return f" (the NLP's; the verifier's {_number(verifier)})"


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


if __name__ == "__main__":
    main()
