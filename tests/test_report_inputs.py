"""What a newcomer's results folder holds, found as it is: recordings wherever ``simulate --out`` put them (the task
models' provenance names the manifest fit-task read), and an interrupted sweep said as what it is."""

from __future__ import annotations

import json
import shutil

from grasptask.records.sweeps import unfinished_state
from grasptask.report.ellipsoid_plots import load_samples_or_note
from grasptask.report.inputs import find_results


def test_the_report_finds_the_recordings_through_the_task_models_provenance(simulated, tmp_path):
    """The README's tour: simulate --out rec, fit-task rec/manifest.csv --out tasks, report --results . -- no
    recordings/ folder beside tasks/, yet the ellipsoid figures get their data points."""
    root, fitted, _ = simulated
    tour = tmp_path / "tour"
    shutil.copytree(root / "tasks", tour / "tasks")
    results = find_results(tour)
    assert results.manifest == (root / "recordings" / "manifest.csv").resolve()
    samples, note = load_samples_or_note(results.manifest, fitted.ellipsoids["id"][:3])
    assert note is None and samples is not None and len(samples) == 3
    models = json.loads((tour / "tasks" / "task_models.json").read_text())
    inputs = models["provenance"]["inputs"]
    models["provenance"]["inputs"] = {name.replace("manifest.csv", "moved.csv"): h for name, h in inputs.items()}
    (tour / "tasks" / "task_models.json").write_text(json.dumps(models))  # a manifest moved away since
    samples, note = load_samples_or_note(find_results(tour).manifest, fitted.ellipsoids["id"][:3])
    assert samples is None and "no recordings manifest at" in note


def test_an_empty_or_interrupted_sweep_is_said_as_what_it_is(tmp_path):
    empty = tmp_path / "grasps" / "drawing"
    empty.mkdir(parents=True)
    (empty / "solutions.jsonl").write_bytes(b"")
    said = unfinished_state(empty)
    assert "a sweep that ended before any start finished (solutions.jsonl is empty)" in said
    assert "no run.json summarises" not in said
    (empty / "solutions.jsonl").write_text('{"start_id": 0, "status": "optimal"}\n{"start_id": 1, "status": "x"}\n')
    said = unfinished_state(empty)
    assert "solutions.jsonl holds 2 starts, and no run.json summarises them (interrupted, or still running)" in said
