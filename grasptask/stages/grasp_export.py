"""``grasptask export``: the distinct optima of a sweep (or every verified start) as GLB scenes and JSON records
that other tools load (:mod:`grasptask.exports.grasp_files`)."""

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
from grasptask.paths import as_paths
from grasptask.progress import progress
from grasptask.records.sweeps import SolvedGrasps, SweepInputs
from grasptask.verifier.verify import verify

#: the object's picture in the GLB, in triangles: smooth to the eye, a few hundred kB
GLB_OBJECT_FACES = 20000


@dataclass(frozen=True)
class ExportSummary:
    out: Path
    grasps: int
    verified_now: int
    files: list[str]


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

    def __post_init__(self) -> None:
        as_paths(self, "solutions", "out")


def run_export(options: ExportOptions) -> ExportSummary:
    """Write ``out/<name>.glb`` and ``out/<name>.json`` for each distinct optimum (``optimum_07``) or, with
    ``every_start``, each verified start (``start_017``), and ``out/grasps.json`` listing them. Each grasp is
    verified again, for the contact forces and activations per task wrench that the verifier's LP finds; the
    record says whether it still passes."""
    solutions, out, every_start = options.solutions, options.out, options.every_start
    sweep = options.open_sweep()
    files, tasks_file, task_name, settings = sweep.files, sweep.tasks, sweep.task, sweep.settings
    chosen, kind = _chosen(sweep.solved, solutions, every_start)
    if not chosen:  # "wrote 0 grasps", exit 0, told the user nothing
        raise BadInputError(solutions, f"no verified start among its {len(sweep.rows)}: nothing to export")
    obj = sweep.load_object()
    mesh = obj.picture(GLB_OBJECT_FACES)
    sources = {"hand": str(files.hand), "object": str(files.object), "tasks": str(tasks_file)}
    config = {"task": task_name, "all": every_start, **sources, "grasp_config": str(files.grasp_config)}
    inputs = [solutions, tasks_file, files.hand, files.grasp_config, *object_files(files.object)]
    listing: list[dict[str, Any]] = []
    verified = 0
    with StagedOutput(out, Provenance.of("export", config, inputs)) as staged:
        for row, grasp in progress(chosen, desc=f"export: {task_name}", unit="grasps"):
            check = verify(grasp, sweep.hand, obj, sweep.task_model, settings)
            scene = grasp_scene(sweep.hand, mesh, grasp, check.contacts, check.normals, settings.friction_coefficient)
            record = grasp_record(
                task=task_name,
                row=row,
                hand=sweep.hand,
                grasp=grasp,
                scene=scene,
                verification=check,
                sources=sources,
            )
            number = int(row["optimum_id"] if kind == "optimum" else row["start_id"])
            name = f"{kind}_{number:02d}" if kind == "optimum" else f"{kind}_{number:03d}"
            staged.path(f"{name}.glb").write_bytes(glb_bytes(scene))
            staged.write_json(f"{name}.json", record)
            verified += check.ok
            listing.append({"name": name, "start_id": int(row["start_id"]), "Q": float(row["Q"]), "verified": check.ok})
        staged.write_json("grasps.json", {"task": task_name, "kind": kind, "grasps": listing})
    return ExportSummary(Path(out), len(listing), verified, [str(g["name"]) for g in listing])
