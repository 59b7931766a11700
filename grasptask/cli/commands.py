"""The stage commands: each builds its stage's options from the shared option groups, runs the stage and says what
it wrote. No command reads an artifact itself."""

from __future__ import annotations

from pathlib import Path

import click

from grasptask import stages
from grasptask.cli.group import main
from grasptask.cli.options import (
    fingers_option,
    object_options,
    out_option,
    physics_config_option,
    scale_option,
    sweep_model_options,
    sweep_task_options,
    synthesis_options,
)
from grasptask.cli.summaries import fit_summary, number, synthesis_line
from grasptask.stages import (
    DEFAULT_SIMULATE_CONFIG,
    FORCE_UNITS,
    TIME_UNITS,
    TORQUE_UNITS,
    BadInputError,
)


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
def simulate(out, config_path, seed, fmt):
    """Simulate sensorized-tool demonstrations: 7 subjects x 3 trials of drawing (tripod, cylindrical and
    power grasps), cutting and screw driving, 105 recordings plus manifest.csv."""
    summary = stages.run_simulate(config_path, out, seed, fmt)
    click.echo(f"wrote {summary['recordings']} recordings and {summary['manifest']}")


@main.command("fit-task")
@click.argument("inputs", nargs=-1, required=True, type=click.Path(path_type=Path))
@out_option
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
    click.echo(fit_summary(result.ellipsoids, stats))
    click.echo(f"wrote {out}/ellipsoids.parquet, task_models.json, stats.csv")
    if result.skipped:
        click.echo(f"skipped {len(result.skipped)} bad recording(s):", err=True)
        for exc in result.skipped:
            click.echo(f"  {exc}", err=True)


@main.command()
@click.argument("ellipsoids", type=click.Path(path_type=Path))
@out_option
def distances(ellipsoids, out):
    """Log-Euclidean distances between the ellipsoids of ELLIPSOIDS (ellipsoids.parquet): distances.parquet,
    distance_summary.json (leave-one-out 1-NN accuracy, silhouette, within/between means), a heatmap ordered
    as the paper's Figure 9 and a 2D embedding."""
    summary = stages.run_distances(ellipsoids, out)
    by_task = summary["by_task"]
    click.echo(
        f"{by_task['n_ellipsoids']} ellipsoids, {len(by_task['labels'])} tasks: "
        f"LOO 1-NN task accuracy {number(by_task['loo_1nn_accuracy'])}, "
        f"silhouette {number(by_task.get('silhouette'))}, "
        f"mean normalised distance within tasks {number(by_task.get('mean_within_normalised'))}"
        f" vs between {number(by_task.get('mean_between_normalised'))}"
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


@main.command()
@synthesis_options
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
    library,
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
        library=library,
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
    click.echo(synthesis_line(task, run))
    if run.get("why_few_verified"):
        click.echo(f"{task}: few starts verified: {run['why_few_verified']}")
    click.echo(f"wrote {out}/{task}/solutions.parquet, optima.parquet, run.json")


@main.command("verify")
@click.argument("solutions", type=click.Path(path_type=Path))
@sweep_task_options
@out_option
@sweep_model_options
@object_options
@fingers_option("those SOLUTIONS holds contacts of")
def verify_command(solutions, tasks_path, task, out, hand, object_path, grasp_config, fingers, **object_options):
    """Check every grasp in SOLUTIONS (solutions.parquet) again with the independent verifier; writes
    OUT/verification.parquet with one row per start and its verification figures."""
    options = stages.VerifyOptions(
        solutions=solutions, out=out, tasks=tasks_path, task=task, hand=hand, object=object_path,
        grasp_config=grasp_config, fingers=fingers, **object_options,
    )  # fmt: skip
    done = stages.run_verify(options)
    click.echo(f"{done.verified}/{len(done.table)} grasps verified; wrote {done.path}")


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
    options = stages.PhysicsOptions(
        solutions=solutions, out=out, workers=workers, tasks=tasks_path, task=task, hand=hand, object=object_path,
        grasp_config=grasp_config, physics_config=physics_config, fingers=fingers, controller=controller,
        strength=strength, friction_scale=friction_scale,
    )  # fmt: skip
    stages.run_physics(options, echo=click.echo)
    click.echo(f"wrote {out}/physics.parquet, physics_summary.json")


@main.command()
@click.argument("solutions", type=click.Path(path_type=Path))
@out_option
@sweep_task_options
@click.option(
    "--all", "every_start", is_flag=True, help="Every verified start, not only the distinct optima (optima.parquet)."
)
@sweep_model_options
@fingers_option("the sweep's")
def export(solutions, out, tasks_path, task, every_start, hand, object_path, grasp_config, fingers):
    """Write each distinct optimum of SOLUTIONS (solutions.parquet, with optima.parquet beside it) as
    OUT/optimum_NN.glb (hand collision bodies, object and contacts in the object frame, a colour per finger;
    Blender, MeshLab and three.js open it) and OUT/optimum_NN.json (joint angles by the hand file's joint names,
    the palm pose as a 4x4 matrix, contacts and normals, the contact forces and activations or joint torques per
    task wrench, Q and the verifier's figures; schema in docs/grasp_record.schema.json)."""
    options = stages.ExportOptions(
        solutions=solutions, out=out, tasks=tasks_path, task=task, hand=hand, object=object_path,
        grasp_config=grasp_config, fingers=fingers, every_start=every_start,
    )  # fmt: skip
    done = stages.run_export(options)
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
