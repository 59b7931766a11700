"""The option groups several commands share, each declared once: the output folder, the hand, object and grasp
settings (the package's defaults, or a sweep's own), what a bare mesh cannot say, the grasping fingers and the
physics config."""

from __future__ import annotations

from pathlib import Path

import click

from grasptask import stages
from grasptask.stages import DEFAULT_GRASP_CONFIG, DEFAULT_HAND, DEFAULT_OBJECT, DEFAULT_SOLVER_CONFIG


def out_option(f):
    return click.option(
        "--out", required=True, type=click.Path(file_okay=False, path_type=Path), help="Output folder."
    )(f)


def finger_list(ctx, param, value):
    if value is None:
        return None
    names = tuple(n.strip() for n in value.split(",") if n.strip())
    if not names:
        raise click.BadParameter("name the fingers, e.g. thumb,index,middle,ring")
    return names


def fingers_option(default: str):
    def decorate(f):
        return click.option(
            "--fingers",
            default=None,
            callback=finger_list,
            help=f"Grasping fingers, comma-separated (e.g. thumb,index,middle,ring) [default: {default}].",
        )(f)

    return decorate


def physics_config_option(help_text: str):
    return click.option(
        "--physics-config",
        type=click.Path(path_type=Path),
        default=stages.DEFAULT_PHYSICS_CONFIG,
        show_default=True,
        help=help_text,
    )


def scale_option(name: str, help_text: str):
    """A positive multiple of a model's value, 1 by default."""
    return click.option(
        name, type=click.FloatRange(min=0, min_open=True), default=1.0, show_default=True, help=help_text
    )


def model_option_set(sweep: bool):
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


model_options = model_option_set(sweep=False)
sweep_model_options = model_option_set(sweep=True)


def object_options(f):
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
        help="The object's task frame: centre (its centre of volume, z along its longest axis, or a bowl's or a "
        "can's symmetry axis: a bare file's default) or origin (the file's own frame).",
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


def sweep_task_options(f):
    """--tasks and --task of a command that reads a finished sweep: by default the sweep's own."""
    f = click.option("--task", default=None, help="The task the solutions were made for [default: the sweep's].")(f)
    return click.option(
        "--tasks", "tasks_path", type=click.Path(path_type=Path), default=None,
        help="task_models.json [default: the sweep's, from its run.json].",
    )(f)  # fmt: skip


def _with(options: list, f):
    """``f`` with each of ``options`` (Click decorators), the first listed the first in ``--help``."""
    for option in reversed(options):
        f = option(f)
    return f


def synthesis_options(f):
    """Everything ``synthesize`` takes: the task, the models, the solver, the starts and where they run."""
    return _with(_SYNTHESIS, f)


_SYNTHESIS = [
    click.option(
        "--tasks", "tasks_path", required=True, type=click.Path(path_type=Path), help="task_models.json from fit-task."
    ),
    click.option("--task", required=True, help="Task to grasp for, e.g. drawing, cutting, screwdriving."),
    out_option,
    model_options,
    object_options,
    click.option(
        "--solver-config",
        type=click.Path(path_type=Path),
        default=DEFAULT_SOLVER_CONFIG,
        show_default=True,
        help="IPOPT options (iteration caps, tolerances; a clock limit is refused), retries and the search's "
        "settings (YAML).",
    ),
    click.option(
        "--starts", type=click.IntRange(min=1), default=None, help="Run a deterministic subset of the 126 starts."
    ),
    click.option(
        "--surface-starts",
        type=click.IntRange(min=0),
        default=0,
        show_default=True,
        help="Starts seeded over the object's surface too, besides the paper's: seeds spread evenly over it, each "
        "approached along its normal with the palm turned 4 ways, the pads placed at the seed (a handle, a rim "
        "or a flat face tried wherever it lies).",
    ),
    click.option("--seed", type=int, default=0, show_default=True, help="Seed of the starts' jitter."),
    click.option(
        "--library",
        type=click.Path(file_okay=False, path_type=Path),
        default=None,
        help="A grasp library folder: the sweep starts first from the optima of the nearest task (Log-Euclidean "
        "distance) that it holds for this hand, object and fingers, and adds its own optima to it "
        "[default: none; the sweep is then reproducible].",
    ),
    click.option("--workers", type=click.IntRange(min=1), default=1, show_default=True, help="Solver processes."),
    click.option(
        "--executor",
        type=click.Choice(["pool", "serial", "dask"]),
        default="pool",
        show_default=True,
        help="pool: local processes (a crashed or hung start is recorded and the sweep goes on); serial: in "
        "this process; dask: a Dask cluster at --scheduler.",
    ),
    click.option("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://10.0.0.5:8786."),
    click.option(
        "--route",
        type=click.Choice(["paper", "search"]),
        default="paper",
        show_default=True,
        help="paper: every start solved to its end by the Section 6 NLP (the paper's route); search: every start's "
        "palm pose and joints searched at once in batches (JAX), end points grouped into basins, one per basin "
        "polished by the same NLP (docs/guide/search.md).",
    ),
    click.option(
        "--solver",
        "backend",
        type=click.Choice(["casadi", "cyipopt"]),
        default="casadi",
        show_default=True,
        help="IPOPT through CasADi's nlpsol, or the same CasADi functions through cyipopt.",
    ),
    click.option(
        "--resume",
        is_flag=True,
        help="Keep the starts already in solutions.jsonl and solve only the rest; refused if the folder holds "
        "another run.",
    ),
    fingers_option("the hand file's choice; for a URDF or MJCF hand, all its fingers"),
    click.option(
        "--anyway",
        is_flag=True,
        help="Solve even when the grasping contacts cannot resist the task wherever they are placed (two point "
        "contacts and a task with torque about every axis), which synthesize otherwise refuses before solving.",
    ),
    click.option(
        "--physics",
        "physics_flag",
        is_flag=True,
        help="Also hold each verified grasp in MuJoCo against the task's wrenches (see `grasptask physics`).",
    ),
    physics_config_option("With --physics: scene, controller, protocol and thresholds (YAML)."),
]


def preprocess_options(f):
    """fit-task's preprocessing: bias removal, trimming, low-pass filtering, resampling, spikes, centring."""
    return _with(_PREPROCESS, f)


_PREPROCESS = [
    click.option(
        "--bias-window",
        type=click.FloatRange(min=0),
        default=None,
        help="Seconds of initial static data to subtract as bias, then drop (default: the manifest's "
        "bias_window_s column, else none).",
    ),
    click.option(
        "--trim-start",
        type=click.FloatRange(min=0),
        default=0.0,
        show_default=True,
        help="Seconds to drop at the start.",
    ),
    click.option(
        "--trim-end", type=click.FloatRange(min=0), default=0.0, show_default=True, help="Seconds to drop at the end."
    ),
    click.option(
        "--lowpass",
        type=click.FloatRange(min=0, min_open=True),
        default=None,
        help="Zero-phase Butterworth low-pass cutoff in Hz (default: no filtering).",
    ),
    click.option(
        "--resample",
        type=click.FloatRange(min=0, min_open=True, max=100_000),
        default=None,
        help="Put every recording on an even grid at this rate (Hz), by linear interpolation, before any other "
        "step (default: as sampled; fit-task says where sampling is uneven).",
    ),
    click.option(
        "--drop-spikes",
        is_flag=True,
        help="Leave out the samples fit-task finds to be spikes (default: kept, and said with their rows).",
    ),
    click.option("--centered", is_flag=True, help="Use the covariance instead of the second moment about the origin."),
]


def mujoco_options(command):
    """``export``'s MuJoCo scene folders, and the physics config they are held with."""
    command = physics_config_option("With --mujoco: scene, controller, protocol and thresholds (YAML).")(command)
    return click.option(
        "--mujoco",
        is_flag=True,
        help="Also write OUT/optimum_NN/scene.xml, the MuJoCo scene the physics check holds the grasp in "
        "(keyframes 'grasp' and 'settled'; meshes beside it), with the check's wrenches.csv, controls.csv and "
        "check.json.",
    )(command)
