"""The report's sections: the task ellipsoids, distances, sweeps and synthesized grasps of a results folder,
each beside the paper's figures. A part whose inputs are missing becomes a note saying what to run."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import trimesh

from grasptask.exports.scene_meshes import colour_legend, grasp_scene
from grasptask.grasp.grasp_pose import Grasp
from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand.hand_model import GraspingHand
from grasptask.io.artifacts import StagedOutput, file_stem
from grasptask.io.config_schema import read_json
from grasptask.io.wording import plural
from grasptask.objects.surface import ImplicitObject
from grasptask.paths import PAPER_ELLIPSOID_TABLES
from grasptask.progress import progress
from grasptask.records.reference import PaperSynthesis
from grasptask.records.solutions import contacts_from_row, grasp_from_row, normals_from_row
from grasptask.records.sweeps import Sweep, unfinished_state
from grasptask.report import paper_tables
from grasptask.report.distance_plots import plot_embedding, plot_heatmap
from grasptask.report.ellipsoid_plots import load_samples_or_note, plot_task_ellipsoids
from grasptask.report.inputs import (
    PhysicsOutcome,
    ResultsFolder,
    paper_setup,
    read_physics,
    simulated_recordings,
    verifier_q,
)
from grasptask.report.interactive import HEIGHT, ellipsoid_view, figure_json, grasp_view, moment_traces
from grasptask.report.page import Figure, Note, Section, Table, View, markdown
from grasptask.report.physics_plots import plot_physics_traces
from grasptask.report.render import display_mesh, render_grasp
from grasptask.report.style import task_colour
from grasptask.report.sweep_plots import plot_sweeps
from grasptask.task.distances import read_distances, task_comparison, weighing_line
from grasptask.task.ellipsoid import ellipsoid_matrices
from grasptask.task.fit import read_ellipsoids
from grasptask.task.stats import read_reference
from grasptask.task.task_model import TaskModel, load_task_models
from grasptask.verifier.verification import Verification
from grasptask.verifier.verify import verify


class Writer:
    """Names figures and tables inside the staged report folder."""

    def __init__(self, staged: StagedOutput):
        self.staged = staged
        self.figures: list[str] = []
        self.tables: list[str] = []
        self.views: list[str] = []

    def figure(self, name: str, suffix: str = ".png") -> Path:
        if name in self.figures:  # two labels that map to the same file stem
            name = f"{name}_{sum(f.startswith(name) for f in self.figures)}"
        self.figures.append(name)
        return self.staged.path(f"figures/{name}{suffix}")

    def view(self, name: str, figure: Any, caption: str, height: int) -> View:
        """An interactive view of the plotly ``figure``, its element id made unique and safe from ``name``."""
        key = f"view-{file_stem(name)}"
        if key in self.views:
            key = f"{key}_{len(self.views)}"
        self.views.append(key)
        data, shared = figure_json(figure)
        return View(key, data, caption, height, shared)

    def table(self, name: str, caption: str, frame: pd.DataFrame) -> Table:
        table = Table(name, caption, frame)
        self.staged.write_with(f"tables/{name}.md", lambda p: p.write_text(markdown(table)))
        self.tables.append(name)
        return table


def _run_missing(what: str, command: str) -> Note:
    return Note(f"{what} not found; run `{command}` to add this section.")


def ellipsoid_tables_section(results: ResultsFolder, writer: Writer) -> Section:
    section = Section(
        "tables",
        "Task ellipsoids beside the paper (Tables 1-10)",
        "Recomputed from the recordings; each statistic is shown with the paper's value and the difference "
        "(ours minus paper). Axes 1-3 are the axes of the 3D force or torque ellipsoid, shortest first. Groups "
        "the paper does not have are tabulated on their own.",
    )
    if not results.stats.is_file():
        section.blocks.append(_run_missing(str(results.stats), "grasptask fit-task MANIFEST --out DIR/tasks"))
        return section
    stats = read_reference(results.stats)
    reference = read_reference(PAPER_ELLIPSOID_TABLES)
    if not simulated_recordings(results.manifest):
        return _own_tables(section, stats, reference.iloc[0:0], writer)
    for table in paper_tables.PAPER_TABLES:
        frame = paper_tables.comparison(stats, reference, table)
        if frame.empty:
            continue  # none of this table's groups: nothing to compare
        section.blocks.append(writer.table(f"table_{table.number:02d}", f"Table {table.number}: {table.title}", frame))
        missing = sorted(set(table.groups) - set(frame["group"]))
        if missing:
            section.blocks.append(Note(f"Table {table.number}: no results for {', '.join(missing)}"))
    own = paper_tables.groups_not_in_paper(stats, reference)
    if not own.empty:
        section.blocks.append(
            writer.table(
                "own_groups",
                "Groups the paper does not have: ellipsoid axis lengths (N, N.cm), shortest axis first",
                own,
            )
        )
    summary = paper_tables.largest_differences(stats, reference)
    if summary["compared_values"]:
        normalised, raw = summary["max_abs_diff_normalised"], summary["max_rel_diff_raw_mu"]
        section.summary = (
            f"Tables 1-10: {summary['compared_values']} values compared with the paper; largest difference of a "
            f"normalised value {'n/a' if normalised is None else f'{normalised:.3f}'}, largest relative "
            f"difference of a raw mean axis length {'n/a' if raw is None else f'{raw:.0%}'}"
        )
    else:
        section.blocks.insert(0, Note(f"none of the groups in {results.stats} is one of the paper's: nothing compared"))
    return section


def _own_tables(section: Section, stats: pd.DataFrame, nothing: pd.DataFrame, writer: Writer) -> Section:
    """Recordings that are not the paper's protocol: their groups' axis lengths, and no comparison."""
    section.title = "Task ellipsoids: each group's axis lengths"
    section.intro = (
        "Your recordings are not the bundled simulator's, which follows the paper's protocol: the paper's Tables "
        "1-10 describe its own subjects, and are not set beside them. Axes 1-3 are the axes of the 3D force or "
        "torque ellipsoid, shortest first."
    )
    own = paper_tables.groups_not_in_paper(stats, nothing)
    if not own.empty:
        section.blocks.append(writer.table("own_groups", "Each group's ellipsoid axis lengths (N, N.cm)", own))
    return section


def ellipsoid_figures_section(results: ResultsFolder, writer: Writer) -> Section:
    section = Section("ellipsoids", "Force and torque ellipsoids (Figures 2, 7, 10)")
    if not results.ellipsoids.is_file() or not results.task_models.is_file():
        section.blocks.append(
            _run_missing(f"{results.ellipsoids} or {results.task_models}", "grasptask fit-task ... --out DIR/tasks")
        )
        return section
    ellipsoids = read_ellipsoids(results.ellipsoids)
    models = load_task_models(results.task_models)
    samples, note = load_samples_or_note(results.manifest, ellipsoids["id"])
    if note:
        section.blocks.append(Note(note))
    tasks = list(models)
    for task in progress(tasks, desc="report: ellipsoid figures", unit="tasks"):
        members = ellipsoids[ellipsoids["task"] == task]
        if members.empty:
            continue
        figure = ellipsoid_view(
            task, models[task].ellipsoid.S, list(ellipsoid_matrices(members)), task_colour(task, tasks)
        )
        section.blocks.append(
            writer.view(
                f"ellipsoids_{task}",
                figure,
                f"{task}: the force and torque ellipsoids in 3D, the task model's and (faint) each of its "
                f"{len(members)} recordings'; drag to turn, scroll to zoom, click a legend entry to hide it.",
                480,
            )
        )
        path = writer.figure(f"ellipsoids_{file_stem(task)}")
        plot_task_ellipsoids(task, members, models[task].ellipsoid.S, path, samples, tasks)
        lengths = models[task].lengths
        section.blocks.append(
            Figure(
                path,
                f"{task}: shadows of the force (top, N) and torque (bottom, N.cm) ellipsoids of its {len(members)} "
                f"recordings on the object's coordinate planes, with sampled data points; the thick outline is the "
                f"task model (Log-Euclidean mean), the arrows its three axes (black the longest). Task-model axis "
                "lengths gamma: " + ", ".join(f"{v:.3g}" for v in lengths) + " (SI).",
            )
        )
        section.blocks.append(
            writer.table(
                f"axes_{file_stem(task)}",
                f"{task}: the task model's six axes u_i (rows, longest first) in the object frame, their lengths "
                "gamma_i and their weights in eq. 12; the first three components are force, the last three torque.",
                _axes_table(models[task]),
            )
        )
    return section


def distances_section(results: ResultsFolder, writer: Writer) -> Section:
    section = Section("distances", "Distances between task ellipsoids (Figure 9)")
    needed = (results.distances, results.distance_summary, results.ellipsoids)
    if not all(p.is_file() for p in needed):
        section.blocks.append(
            _run_missing(
                " or ".join(map(str, needed)), "grasptask distances DIR/tasks/ellipsoids.parquet --out DIR/tasks"
            )
        )
        return section
    distances = read_distances(results.distances, read_ellipsoids(results.ellipsoids))
    by_task = read_json(results.distance_summary).get("by_task", {})
    tasks = task_comparison(distances.table, float(distances.raw.max()))
    section.summary = (
        f"Distances: leave-one-out nearest-neighbour task accuracy {by_task.get('loo_1nn_accuracy', 0):.2f}"
    )
    section.intro = (
        "Log-Euclidean distance ||log S_a - log S_b||_F normalised by the largest in the set, ordered by task and "
        "grasp type as in the paper. Leave-one-out nearest-neighbour task accuracy "
        f"{by_task.get('loo_1nn_accuracy', 0):.2f}; "
        f"mean normalised distance within tasks {by_task.get('mean_within_normalised', float('nan')):.2f}, between "
        f"tasks {by_task.get('mean_between_normalised', float('nan')):.2f}."
    )
    section.intro += " " + weighing_line(tasks)
    section.blocks.append(writer.table("task_distances", _TASK_TABLE, _task_table(tasks)))
    heatmap, embedding = writer.figure("distance_heatmap"), writer.figure("distance_embedding")
    plot_heatmap(distances, heatmap)
    plot_embedding(distances, embedding)
    section.blocks += [
        Figure(heatmap, "Normalised Log-Euclidean distances between all ellipsoids (cf. Figure 9)."),
        Figure(embedding, "Classical MDS of the distances: each point is one recording's ellipsoid."),
    ]
    return section


_TASK_TABLE = (
    "Which task is like which: the Log-Euclidean distance between the task models (each task's mean ellipsoid), "
    "raw and normalised by the largest distance between two recordings, and each task's nearest."
)


def _task_table(tasks: dict) -> pd.DataFrame:
    """Tasks by tasks, the distances between their models, and each task's nearest (a ``task_comparison``)."""
    frame = pd.DataFrame(tasks["distances"], index=tasks["names"], columns=tasks["names"]).round(3)
    nearest = tasks["nearest"]
    frame["nearest task"] = [nearest[n]["task"] if n in nearest else "" for n in tasks["names"]]
    frame["normalised"] = [
        round(nearest[n]["distance_normalised"], 3) if n in nearest else None for n in tasks["names"]
    ]
    return frame.rename_axis("task").reset_index()


def _axes_table(model: TaskModel) -> pd.DataFrame:
    """A task model's 6D axes: each axis's length and weight (eq. 12) and its direction u_i, force then torque."""
    frame = pd.DataFrame(model.axes.round(3), columns=["fx", "fy", "fz", "tx", "ty", "tz"])
    frame.insert(0, "weight", model.weights.round(4))
    frame.insert(0, "gamma (N, N.m)", [float(f"{g:.3g}") for g in model.lengths])
    frame.insert(0, "axis", [f"u{i + 1}" for i in range(len(model.lengths))])
    return frame


#: the one sentence that says what the report's Q is
Q_MEANING = (
    "Q (eq. 12) is the sum, over the task's wrench axes, of the squared joint torques each asks of the hand at "
    "this grasp, as the verifier computes it: lower is better."
)


def _no_sweeps(results: ResultsFolder) -> Note:
    return _run_missing(f"synthesis results under {results.grasps}", "grasptask synthesize ... --out DIR/grasps")


def sweeps_section(results: ResultsFolder, sweeps: dict[str, Sweep], paper: PaperSynthesis, writer: Writer) -> Section:
    optima = " / ".join(str(paper.optima.get(t, "?")) for t in ("drawing", "cutting", "screwdriving"))
    paper_said = (
        f" The paper reports {paper.seconds} per solution (AMPL + IPOPT on a 2.4 GHz Opteron) and {optima} local "
        "optima for drawing / cutting / screw driving."
        if any(paper_setup(sweep.files) for sweep in sweeps.values())
        else ""
    )
    section = Section(
        "sweeps",
        "Synthesis sweeps: convergence and time per start",
        "Every start is an IPOPT solve of the grasp NLP from one of the 126 starting palm poses; a start counts "
        f"as a grasp only when the independent verifier accepts it.{paper_said}",
    )
    for folder in results.unfinished_sweeps():
        section.blocks.append(Note(unfinished_state(folder)))
    if not sweeps:
        section.blocks.append(_no_sweeps(results))
        return section
    section.blocks.append(
        writer.table("synthesis_sweeps", "Sweep statistics beside the paper", paper_tables.sweep_table(sweeps, paper))
    )
    path = writer.figure("synthesis_sweeps")
    paperly = [t for t, sweep in sweeps.items() if paper_setup(sweep.files)]
    optima_shown = {t: n for t, n in paper.optima.items() if t in paperly}
    plot_sweeps(sweeps, paper.mean_s if paperly else None, paper.sd_s, optima_shown, path)
    shaded = " (the paper's mean +- sd shaded)" if paperly else ""
    section.blocks.append(Figure(path, f"Statuses, time per start{shaded} and verified fraction per task."))
    size = next(iter(sweeps.values())).run.get("model_size", {})
    if size:
        beside = f" (paper: {paper.variables} x {paper.constraints})" if paperly else ""
        section.intro += f" Our NLP: {size.get('variables')} variables x {size.get('constraints')} constraints{beside}."
    return section


def grasps_section(
    results: ResultsFolder,
    sweeps: dict[str, Sweep],
    paper: PaperSynthesis,
    writer: Writer,
) -> Section:
    """Per task a line of its figures, then each distinct optimum as a view and two fixed viewpoints, and the
    table of Q."""
    section = Section(
        "grasps",
        "Your grasps: per task, its best grasp first, then every other distinct optimum",
        "Per task, a line of its figures, then each distinct verified optimum, best first, as an interactive view "
        "and from two viewpoints, a colour per finger (each task's line names them); red crosses "
        "and lines are the contact points and their friction cones; the arrows from the task frame's origin (where "
        "the task's torques act) show its main wrench axis (force magenta, torque black). " + Q_MEANING,
    )
    if not sweeps:
        section.blocks.append(_no_sweeps(results))
        return section
    shown_q: dict[tuple[str, int], float] = {}  # the Q each view shows, so that the table shows the same
    task_models = load_task_models(results.task_models) if results.task_models.is_file() else {}
    objects: dict[Path, tuple] = {}
    for task, sweep in sweeps.items():
        if sweep.optima.empty:
            section.blocks.append(Note(f"{task}: no verified grasp among {plural(len(sweep.table), 'start')}"))
            continue
        physics = read_physics(results, sweep)
        section.blocks.append(Note(_task_card(task, sweep, physics)))
        object_path = sweep.files.object
        if object_path not in objects:
            obj = sweep.load_object()  # synthesize said what it repaired
            objects[object_path] = obj, display_mesh(obj), display_mesh(obj, VIEW_FACES)
        obj, mesh, view_mesh = objects[object_path]
        hand = sweep.hand
        shown = _Shown(
            hand, list(hand.fingers), obj, mesh, view_mesh, sweep.settings, task_models.get(task), physics
        )  # fmt: skip
        rows = list(sweep.optima.iterrows())
        for _, optimum in progress(rows, desc=f"report: {task} grasps", unit="grasps"):
            blocks, shown_q[task, int(optimum["optimum_id"])] = _optimum_blocks(task, optimum, shown, writer)
            section.blocks.extend(blocks)
    if not task_models:
        section.blocks.append(Note(f"no task models at {results.task_models}: the grasps have no interactive views"))
    table = writer.table(
        "grasp_quality",
        "Q of every distinct optimum (beside the values the paper's Tables 11-12 show, for its own setup)",
        paper_tables.quality_table(sweeps, paper, shown_q),
    )
    section.blocks.append(table)
    return section


@dataclass(frozen=True)
class _Shown:
    """What a task's optima are drawn with: the sweep's hand, its object (as loaded, and as the two meshes the
    figures and the views draw), its grasp settings and task model (None: no task model found)."""

    hand: GraspingHand
    fingers: list[str]
    obj: ImplicitObject
    mesh: Any  # trimesh meshes
    view_mesh: Any
    settings: GraspSettings
    task_model: TaskModel | None
    physics: PhysicsOutcome | None = None

    @property
    def task_axis(self) -> np.ndarray | None:
        return self.task_model.axes[0] if self.task_model is not None else None


def _optimum_blocks(task: str, optimum: pd.Series, shown: _Shown, writer: Writer) -> tuple[list[View | Figure], float]:
    """One optimum as an interactive view (where the task model is known) and two fixed viewpoints, and the Q
    they show: the verifier's, recomputed here, as the tables show it."""
    hand, settings = shown.hand, shown.settings
    grasp = grasp_from_row(optimum, hand.joint_names)
    number = int(optimum["optimum_id"])
    path = writer.figure(f"grasp_{file_stem(task)}_{number:02d}")
    check = verify(grasp, hand, shown.obj, shown.task_model, settings) if shown.task_model is not None else None
    quality = check.Q if check is not None else verifier_q(optimum)
    title = f"{task}, optimum {number}: Q = {quality:.3g} ({plural(int(optimum['members']), 'start')})"  # as the tables
    blocks: list[View | Figure] = []
    if check is not None:
        scene = grasp_scene(hand, shown.view_mesh, grasp, check.contacts, check.normals, settings.friction_coefficient)
        view = grasp_view(scene, check, title, np.zeros(3), shown.task_axis)  # objects live in their task frame
        moment = shown.physics.moment(int(optimum["start_id"])) if shown.physics is not None else None
        if moment is not None:
            view.add_traces(_moment_traces(shown, grasp, check, moment))
        caption = (
            f"{title}: drag to turn, scroll to zoom, click a legend entry to hide it; hover over a contact "
            "for its forces under the task wrenches (the verifier's LP) and the verifier's figures."
        )
        blocks.append(writer.view(f"grasp_{task}_{number:02d}", view, caption, HEIGHT))
    render_grasp(
        path,
        title,
        hand=hand,
        obj=shown.obj,
        palm_rotation=grasp.palm_rotation,
        palm_position=grasp.palm_position,
        joint_angles=grasp.joint_angles,
        contacts=contacts_from_row(optimum, shown.fingers),
        normals=normals_from_row(optimum, shown.fingers),
        mu=settings.friction_coefficient,
        task_axis=shown.task_axis,
        mesh=shown.mesh,
    )
    blocks.append(Figure(path, f"{title}: two fixed viewpoints (for print)"))
    return blocks, quality


def _moment_traces(shown: _Shown, grasp: Grasp, check: Verification, moment: dict) -> list:
    """The physics check's worst moment of a grasp, for its view: the object moved as MuJoCo had it, the fingers
    at the joints the controller held them at."""
    then = Grasp(grasp.palm_rotation, grasp.palm_position, np.asarray(moment["joint_angles"], dtype=float))
    fingers = grasp_scene(shown.hand, shown.view_mesh, then, check.contacts, check.normals, 0.0)
    pose = np.asarray(moment["object_pose"], dtype=float)
    moved = shown.view_mesh.copy()
    moved.apply_transform(trimesh.transformations.quaternion_matrix(pose[3:]))
    moved.apply_translation(pose[:3])
    label = (
        f"physics, worst moment: {moment['phase']} at {moment['time_s']:.2f} s, "
        f"{moment['translation_m'] * 1e3:.2f} mm, {moment['rotation_deg']:.2f} deg"
    )
    return moment_traces(fingers, moved, label)


def _optima_paths(task: str, physics: PhysicsOutcome, sweep: Sweep, writer: Writer) -> list[Figure]:
    """A task's traced optima in the physics check, best first: each one's translation and rotation over every
    phase against the thresholds, and the films of those filmed."""
    numbers = dict(zip(sweep.optima["start_id"].astype(int), sweep.optima["optimum_id"].astype(int), strict=True))

    def optimum(start: int) -> str:
        return f"optimum {numbers.get(start, '?')}"

    traces = {f"{task}, {optimum(int(start))}": trace for start, trace in physics.trace.groupby("start_id", sort=False)}
    path = writer.figure(f"physics_{file_stem(task)}")
    plot_physics_traces(traces, dict.fromkeys(traces, physics.summary["thresholds"]), path)
    said = "; ".join(f"{optimum(m['start_id'])} {_verdict(m)}" for m in physics.summary["traced"])
    blocks = [
        Figure(
            path,
            f"{task}: the object's translation and rotation under each distinct optimum, best first ({said}), over "
            "settling and each test wrench, each from the settled state (DexGraspBench's forces shaded); dashed "
            "our threshold, dotted DexGraspBench's; log scale above 0.1. Each one's worst moment is in its 3D view "
            "(legend: 'physics, worst moment').",
        )
    ]
    for moment in physics.summary["traced"]:
        film = physics.film(moment["start_id"])
        if film is not None:
            copied = writer.figure(f"film_{file_stem(task)}_{moment['start_id']:03d}", ".gif")
            copied.write_bytes(film.read_bytes())
            said = f"{task}, {optimum(moment['start_id'])}, {_verdict(moment)}: in MuJoCo, the object orange"
            blocks.append(Figure(copied, said))
    return blocks


def _verdict(moment: dict) -> str:
    phase = moment["phase"]
    return f"held (worst: {phase})" if moment["held"] else f"dropped under {phase}"


def _task_card(task: str, sweep: Sweep, physics: PhysicsOutcome | None) -> str:
    """One line of a task's results, at the head of its grasps: what a colleague asks first."""
    solutions = sweep.table
    verified = int(solutions["verified"].sum())
    held = "not checked in physics"
    if physics is not None:
        both, checked = physics.summary["agreement"]["verified_and_held"], int(physics.summary["verified"])
        held = f"{both} of {checked} verified held in physics"
    best = min(verifier_q(row) for _, row in sweep.optima.iterrows())
    seconds = solutions["seconds"].astype(float).median()
    fingers = colour_legend(list(sweep.hand.fingers))
    return (
        f"{task.upper()} ({sweep.hand.name}: {fingers}): {verified} of {plural(len(solutions), 'start')} verified, "
        f"{plural(len(sweep.optima), 'distinct optimum')}, "
        f"{held}; best Q {best:.3g}; {seconds:.2f} s per start (median)"
    )


#: the object's picture in an interactive view, in triangles: smooth enough to turn, small enough that 40 views
#: keep the page within its 15 MB
VIEW_FACES = 2500


def _share(count: int, total: int) -> str:
    return f"{count} ({count / total:.0%})" if total else "0"


def physics_table(outcomes: dict[str, PhysicsOutcome], sweeps: dict[str, Sweep]) -> pd.DataFrame:
    """Per task: the analytic verifier's verdicts beside the physics check's pass rates and their 2x2
    agreement."""
    rows = []
    for task, outcome in outcomes.items():
        summary, pair = outcome.summary, outcome.summary["agreement"]
        verified = int(summary["verified"])
        held = pair["verified_and_held"]
        bench = summary.get("dexgraspbench_pass_rate_of_verified")
        failing: dict[str, int] = summary.get("failed_wrenches_of_verified") or {}
        seconds = summary.get("seconds_per_grasp_median")
        rows.append(
            {
                "task": task,
                "starts": len(sweeps[task].table),
                "verifier accepts": verified,
                "physics holds (of those)": _share(held, verified),
                "DexGraspBench test holds": "-" if bench is None else f"{bench:.0%}",
                "both accept": held,
                "only the verifier": pair["verified_and_dropped"],
                "only physics": pair["rejected_and_held"],
                "neither": pair["rejected_and_dropped"],
                "wrench that fails most": max(failing, key=lambda name: failing[name]) if failing else "-",
                "median s/grasp": "-" if seconds is None else round(float(seconds), 2),
            }
        )
    return pd.DataFrame(rows)


def physics_section(results: ResultsFolder, sweeps: dict[str, Sweep], writer: Writer) -> Section:
    section = Section(
        "physics",
        "Physics check: the grasps held in MuJoCo against each task's own wrenches",
        "A second judge, separate from the analytic verifier: each grasp is closed on the object as a free body, "
        "settled, then loaded with each of the task's 12 wrenches +-gamma_i u_i and DexGraspBench's six "
        "+-10 m/s^2 x mass forces, each ramped in from the settled state and held. It holds when no task wrench "
        "moves the object more than the thresholds. Disagreements between the judges are findings, not errors; "
        "the README's physics section explains the main causes.",
    )
    outcomes = {task: o for task, sweep in sweeps.items() if (o := read_physics(results, sweep)) is not None}
    if not outcomes:
        section.blocks.append(
            _run_missing(
                "physics results",
                "grasptask physics DIR/grasps/TASK/solutions.parquet --tasks ... --out DIR/physics/TASK",
            )
        )
        return section
    limits = next(iter(outcomes.values())).summary["thresholds"]
    section.intro += (
        f" Our thresholds: {limits['max_translation_m'] * 1e3:g} mm and {limits['max_rotation_deg']:g} deg "
        f"(DexGraspBench's: {limits['benchmark_translation_m'] * 1e3:g} mm and {limits['benchmark_rotation_deg']:g}"
        " deg). The table counts the solved starts physics checked: synthesize --physics checks only those the "
        "verifier accepts."
    )
    section.blocks.append(
        writer.table(
            "physics",
            "Physics pass rates beside the analytic verifier, with their 2x2 agreement",
            physics_table(outcomes, sweeps),
        )  # fmt: skip
    )
    section.summary = "Physics check: " + "; ".join(
        f"{task} {_share(o.summary['agreement']['verified_and_held'], int(o.summary['verified']))} of verified held"
        for task, o in outcomes.items()
    )
    unfilmed = next(
        (o.summary["films_unavailable"] for o in outcomes.values() if o.summary.get("films_unavailable")), None
    )
    if unfilmed:
        section.blocks.append(Note(f"No films of the check: {unfilmed}. Each optimum's path is drawn as a plot."))
    for task, outcome in outcomes.items():
        if len(outcome.trace):
            section.blocks.extend(_optima_paths(task, outcome, sweeps[task], writer))
        else:
            section.blocks.append(Note(f"{task}: no verified grasp to show the motion of"))
    return section
