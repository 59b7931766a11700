"""``grasptask export``: the distinct optima of a sweep (or every verified start) as GLB scenes and JSON records
that other tools load (:mod:`grasptask.exports.grasp_files`), and with ``--mujoco`` each as the MuJoCo scene the
physics check holds it in (:mod:`grasptask.physics.scene_file`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from grasptask.errors import BadInputError
from grasptask.exports.grasp_files import glb_bytes, grasp_record
from grasptask.exports.scene_meshes import grasp_scene
from grasptask.grasp.grasp_pose import Grasp
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.io.tables import read_table
from grasptask.objects.object_files import object_files
from grasptask.objects.surface import ImplicitObject
from grasptask.paths import DEFAULT_PHYSICS_CONFIG, as_paths
from grasptask.physics.judge import Holding
from grasptask.physics.physics_settings import load_physics_settings
from grasptask.progress import Progress, timed_stage
from grasptask.records.sweeps import SolvedGrasps, Sweep, SweepInputs
from grasptask.verifier.verify import verify

#: the object's picture in the GLB, in triangles: smooth to the eye, a few hundred kB
GLB_OBJECT_FACES = 20000


@dataclass(frozen=True)
class ExportSummary:
    out: Path
    grasps: int
    verified_now: int
    files: list[str]
    #: with --mujoco: how many of the exported grasps the physics check held (None: no scenes)
    held: int | None = None


def _chosen(solved: SolvedGrasps, solutions_path: Path, every_start: bool) -> tuple[list[tuple[dict, Grasp]], str]:
    """The rows and grasps to export and how their files are named: the sweep's distinct optima
    (``optima.parquet`` beside the solutions, each its best start's solution with the optimum's columns), or
    with ``every_start`` each verified start of the solutions table."""
    solved_starts = {int(row["start_id"]): (row, grasp) for row, grasp in solved.rows if grasp is not None}
    if every_start:
        return [(row, grasp) for row, grasp in solved_starts.values() if row.get("verified")], "start"
    optima_path = solutions_path.parent / "optima.parquet"
    if not optima_path.is_file():
        raise BadInputError(optima_path, "not found: export needs the sweep's distinct optima, or --all")
    chosen = []
    for number, optimum in enumerate(read_table(optima_path, ("optimum_id", "start_id", "Q")).to_dict("records"), 1):
        start = int(optimum["start_id"])
        if start not in solved_starts:
            message = f"start {start} has no solution in {solutions_path.name}"
            raise BadInputError(optima_path, message, row=number, column="start_id")
        row, grasp = solved_starts[start]
        chosen.append(({**row, **optimum}, grasp))
    return chosen, "optimum"


@dataclass(frozen=True, kw_only=True)
class ExportOptions(SweepInputs):
    """What to export: the distinct optima of a sweep (:class:`SweepInputs`) or, with ``every_start``, each
    verified start; and where to."""

    out: Path
    every_start: bool = False
    #: each grasp also as a MuJoCo scene folder, held as ``physics_config`` says
    mujoco: bool = False
    physics_config: Path = DEFAULT_PHYSICS_CONFIG

    def __post_init__(self) -> None:
        as_paths(self, "solutions", "out", "physics_config")


@timed_stage
def run_export(options: ExportOptions) -> ExportSummary:
    """Write ``out/<name>.glb`` and ``out/<name>.json`` for each distinct optimum (``optimum_07``) or, with
    ``every_start``, each verified start (``start_017``), and ``out/grasps.json`` listing them; with ``mujoco``,
    ``out/<name>/scene.xml`` and the check's timelines beside it. Each grasp is verified again, for the contact
    forces and activations per task wrench that the verifier's LP finds; the record says whether it still
    passes."""
    solutions, out, every_start = options.solutions, options.out, options.every_start
    sweep = options.open_sweep()
    files, tasks_file, task_name = sweep.files, sweep.tasks, sweep.task
    chosen, kind = _chosen(sweep.solved, solutions, every_start)
    if not chosen:  # "wrote 0 grasps", exit 0, told the user nothing
        raise BadInputError(solutions, f"no verified start among its {len(sweep.rows)}: nothing to export")
    sources = {"hand": str(files.hand), "object": str(files.object), "tasks": str(tasks_file)}
    config = {"task": task_name, "all": every_start, **sources, "grasp_config": str(files.grasp_config)}
    inputs = [solutions, tasks_file, files.hand, files.grasp_config, *object_files(files.object)]
    if options.mujoco:
        config["mujoco"], config["physics_config"] = True, str(options.physics_config)
        inputs.append(options.physics_config)
    exporter = _Exporter(sweep, sweep.load_object(), sources, kind)
    if options.mujoco:
        exporter.prepare_scenes(options.physics_config)
    listing: list[dict[str, Any]] = []
    with StagedOutput(out, Provenance.of("export", config, inputs)) as staged:
        with Progress(len(chosen), f"export {task_name}", "grasps") as shown:
            for row, grasp in chosen:
                listing.append(exporter.write(staged, row, grasp))
                counts = {key: sum(bool(g[key]) for g in listing) for key in ("verified", "held") if key in listing[0]}
                shown.update(1, **counts)
        staged.write_json("grasps.json", {"task": task_name, "kind": kind, "grasps": listing})
    held = sum(bool(g["held"]) for g in listing) if options.mujoco else None
    verified = sum(bool(g["verified"]) for g in listing)
    return ExportSummary(Path(out), len(listing), verified, [str(g["name"]) for g in listing], held)


class _Exporter:
    """What every grasp of one export shares: the sweep, its object and the picture of it, the sources the
    records name, how files are named, and for MuJoCo scenes the holding of grasps on the object."""

    def __init__(self, sweep: Sweep, obj: ImplicitObject, sources: dict[str, str], kind: str):
        self.sweep, self.obj, self.sources, self.kind = sweep, obj, sources, kind
        self.mesh = obj.picture(GLB_OBJECT_FACES)
        self.holding: Holding | None = None

    def prepare_scenes(self, physics_config: Path) -> None:
        """The object's convex parts for MuJoCo, made once and kept (CoACD can take a minute on a scan: said)."""
        settings = load_physics_settings(physics_config)
        grasp_settings = self.sweep.settings
        friction, torsion = grasp_settings.friction_coefficient, grasp_settings.torsional_friction_m
        self.holding = Holding.of(self.obj, friction, settings, 1.0, torsion)

    def write(self, staged: StagedOutput, row: dict, grasp: Grasp) -> dict[str, Any]:
        """One grasp's files, and its entry in ``grasps.json``."""
        sweep, settings = self.sweep, self.sweep.settings
        check = verify(grasp, sweep.hand, self.obj, sweep.task_model, settings)
        scene = grasp_scene(sweep.hand, self.mesh, grasp, check.contacts, check.normals, settings.friction_coefficient)
        record = grasp_record(
            task=sweep.task, row=row, hand=sweep.hand, grasp=grasp, scene=scene, verification=check,
            sources=self.sources,
        )  # fmt: skip
        number = int(row["optimum_id"] if self.kind == "optimum" else row["start_id"])
        name = f"{self.kind}_{number:02d}" if self.kind == "optimum" else f"{self.kind}_{number:03d}"
        entry: dict[str, Any] = {"name": name, "start_id": int(row["start_id"]), "Q": float(row["Q"])}
        entry["verified"] = check.ok
        if self.holding is not None:
            from grasptask.physics.scene_file import SCENE_FILE, scene_files  # deferred: MuJoCo

            scene_at, result = self.holding.traced(sweep.hand, grasp, sweep.task_model)
            for file, content in scene_files(scene_at, result, self.mesh, self.holding.settings).items():
                staged.path(f"{name}/{file}").write_bytes(content)
            record["mujoco_scene"] = {"file": f"{name}/{SCENE_FILE}", "held": result.passed}
            entry["held"], entry["scene"] = result.passed, f"{name}/{SCENE_FILE}"
        staged.path(f"{name}.glb").write_bytes(glb_bytes(scene))
        staged.write_json(f"{name}.json", record)
        return entry
