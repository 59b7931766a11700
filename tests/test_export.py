"""``grasptask export``: GLB scenes that reload with their bodies, and JSON records that follow their schema and
replay through the hand's forward kinematics, on the project's hand and on a URDF hand read by yourdfpy."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import numpy as np
import pandas as pd
import pytest
import trimesh
from grasp_fixtures import ball_grasp, ball_sweep, drawing_like_task, results_with_tasks

from grasptask.exports.grasp_files import glb_bytes, grasp_record
from grasptask.exports.scene_meshes import grasp_scene
from grasptask.grasp.grasp_pose import Grasp
from grasptask.grasp.grasp_settings import GraspSettings
from grasptask.hand import forward, load_hand
from grasptask.verifier.verify import verify

SCHEMA = json.loads(Path("docs/grasp_record.schema.json").read_text())


def grasp_from_record(record, joint_names):
    """The grasp a record holds, as a reader of the JSON replays it: joint angles in the hand's own order."""
    pose = np.asarray(record["palm_pose"], dtype=float)
    angles = record["joint_angles"]
    return Grasp(pose[:3, :3], pose[:3, 3], np.array([angles[name] for name in joint_names], dtype=float))


def _light_tasks(results: Path) -> Path:
    """A task-models file whose drawing task the ball grasp can hold (the simulated one asks too much of it)."""
    tasks = results / "light_tasks.json"
    tasks.write_text(json.dumps({"tasks": {"drawing": drawing_like_task().to_dict()}}))
    return tasks


@pytest.fixture(scope="module")
def exported(simulated, tmp_path_factory):
    """The ball sweep's one optimum exported by the CLI, with a task light enough for the ball grasp to hold."""
    from click.testing import CliRunner

    from grasptask.cli import main

    results = results_with_tasks(simulated, tmp_path_factory.mktemp("export") / "results")
    ball_sweep(results)
    tasks = _light_tasks(results)
    out = results / "export"
    solutions = results / "grasps" / "drawing" / "solutions.parquet"
    result = CliRunner().invoke(main, ["export", str(solutions), "--out", str(out), "--tasks", str(tasks)])
    assert result.exit_code == 0, result.output
    return out, result.output


def test_export_writes_a_glb_and_a_record_per_optimum(exported):
    out, output = exported
    listing = json.loads((out / "grasps.json").read_text())
    assert [g["name"] for g in listing["grasps"]] == ["optimum_00"] and listing["task"] == "drawing"
    assert "wrote 1 grasp " in output and "1 verified" in output
    scene = trimesh.load(out / "optimum_00.glb", force="scene")
    hand = load_hand().grasping_hand()
    expected = {"object", "palm"} | {f"{kind}_{f}" for f in hand.fingers for kind in ("finger", "contact")}
    assert set(scene.geometry) == expected
    record = json.loads((out / "optimum_00.json").read_text())
    # each finger's body holds one icosphere per collision sphere of that finger and one for its fingertip's
    # sphere, around the right centres
    pose = forward(hand, *_pose_arguments(grasp_from_record(record, hand.joint_names)))
    for name, finger in pose.fingers.items():
        body = scene.geometry[f"finger_{name}"]
        assert len(body.vertices) == 42 * (len(finger.radii) + 1)
        centres = np.vstack([finger.samples[0], finger.pad_centre])
        assert np.allclose(body.vertices.reshape(-1, 42, 3).mean(axis=1), centres, atol=1e-6)
    contact = scene.geometry["contact_thumb"].bounds.mean(axis=0)
    assert np.allclose(contact, record["contacts"][0]["surface_point"], atol=1e-6)
    assert np.allclose(scene.geometry["object"].bounds, [[-0.03] * 3, [0.03] * 3], atol=2e-3)


def _pose_arguments(grasp: Grasp):
    return grasp.joint_angles, grasp.palm_rotation, grasp.palm_position


def test_record_follows_its_schema_and_replays_to_the_contacts(exported):
    out, _ = exported
    record = json.loads((out / "optimum_00.json").read_text())
    jsonschema.validate(record, SCHEMA)
    hand = load_hand().grasping_hand()
    assert list(record["joint_angles"]) == hand.joint_names
    replayed = forward(hand, *_pose_arguments(grasp_from_record(record, hand.joint_names))).contacts()[0]
    pads = np.array([c["pad"] for c in record["contacts"]])
    assert np.abs(replayed - pads).max() < 1e-9
    assert record["verification"]["verified"] and record["verification"]["failures"] == []


def test_record_forces_apply_each_task_wrench(exported):
    """The contact forces of every task wrench add up to that wrench (torques about the object's origin), lie
    in their friction cones, and the activations stay within [0, 1]."""
    out, _ = exported
    record = json.loads((out / "optimum_00.json").read_text())
    points = np.array([c["surface_point"] for c in record["contacts"]])
    inward = -np.array([c["normal"] for c in record["contacts"]])
    mu = record["friction_coefficient"]
    assert len(record["wrenches"]) == 12
    for load in record["wrenches"]:
        forces = np.array([load["contact_forces"][c["finger"]] for c in record["contacts"]])
        total = np.concatenate([forces.sum(axis=0), np.cross(points, forces).sum(axis=0)])
        assert np.allclose(total, load["wrench"], atol=1e-7)
        normal = (forces * inward).sum(axis=1)
        tangential = np.linalg.norm(forces - normal[:, None] * inward, axis=1)
        assert np.all(tangential <= mu * normal + 1e-9)
        activations = np.array(list(load["activations"].values()))
        assert activations.min() >= -1e-9 and activations.max() <= 1 + 1e-6


def test_urdf_record_replays_in_yourdfpy(tmp_path):
    """A Barrett hand's record, keyed by the URDF's own joint names, put through yourdfpy's kinematics: each
    pad lands on the same point of its fingertip link in two different grasps, as a rigid pad must."""
    import yourdfpy

    path = "configs/hands/barrett_bh8_282.urdf"
    hand = load_hand(path).grasping_hand()
    robot = yourdfpy.URDF.load(path, build_scene_graph=True, load_meshes=False, load_collision_meshes=False)
    grasp_ball = ball_grasp()[1]
    rng = np.random.default_rng(3)
    in_tip: list[np.ndarray] = []
    for _ in range(2):
        q = hand.apply_coupling(rng.uniform(hand.lower, hand.upper))
        rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        grasp = Grasp(rotation * np.sign(np.linalg.det(rotation)), rng.normal(scale=0.05, size=3), q)
        check = verify(grasp, hand, grasp_ball, drawing_like_task(), GraspSettings())
        scene = grasp_scene(hand, grasp_ball.picture(500), grasp, check.contacts, check.normals, 0.5)
        record = json.loads(json.dumps(_record(hand, grasp, scene, check, path)))
        jsonschema.validate(record, SCHEMA)
        assert set(record["joint_angles"]) <= set(robot.joint_names)
        actuated = {n: record["joint_angles"][n] for n in robot.actuated_joint_names if n in record["joint_angles"]}
        robot.update_cfg(actuated)
        palm = np.array(record["palm_pose"])
        root = robot.base_link
        points = []
        for contact, finger in zip(record["contacts"], hand.fingers.values(), strict=True):
            # the link the finger's last joint moves: the pad is rigid on it (and on the links fixed to it)
            link_in_object = palm @ robot.get_transform(robot.joint_map[finger.joints[-1].name].child, root)
            points.append(np.linalg.solve(link_in_object, np.append(contact["pad"], 1.0))[:3])
        in_tip.append(np.array(points))
    assert np.abs(in_tip[0] - in_tip[1]).max() < 1e-9


def _record(hand, grasp, scene, check, path):
    row = {"start_id": 0, "Q": 1.0}
    return grasp_record(
        task="test", row=row, hand=hand, grasp=grasp, scene=scene, verification=check, sources={"hand": path}
    )


def test_export_all_writes_every_verified_start(simulated, tmp_path, cli):
    results = results_with_tasks(simulated, tmp_path / "results")
    ball_sweep(results)
    tasks = _light_tasks(results)
    solutions = results / "grasps" / "drawing" / "solutions.parquet"
    result = cli("export", solutions, "--out", tmp_path / "out", "--tasks", tasks, "--all")
    assert result.exit_code == 0, result.output
    names = sorted(p.name for p in (tmp_path / "out").iterdir() if p.name.startswith("start_"))
    assert names == ["start_000.glb", "start_000.json", "start_001.glb", "start_001.json"]
    record = json.loads((tmp_path / "out" / "start_001.json").read_text())
    assert record["start_id"] == 1 and record["optimum_id"] is None


def test_glb_bytes_are_a_binary_gltf():
    grasp, ball = ball_grasp()
    hand = load_hand().grasping_hand()
    check = verify(grasp, hand, ball, drawing_like_task(), GraspSettings())
    data = glb_bytes(grasp_scene(hand, ball.picture(500), grasp, check.contacts, check.normals, 0.5))
    assert data[:4] == b"glTF"


def test_export_bad_input(cli, simulated, tmp_path):
    results = results_with_tasks(simulated, tmp_path / "results")
    ball_sweep(results)
    solutions = results / "grasps" / "drawing" / "solutions.parquet"
    optima_path = results / "grasps" / "drawing" / "optima.parquet"
    optima = pd.read_parquet(optima_path)
    optima.assign(start_id=99).to_parquet(optima_path)  # an optimum whose start the solutions do not hold
    result = cli("export", solutions, "--out", tmp_path / "out")
    assert result.exit_code == 2 and "optima.parquet" in result.output and "start 99" in result.output
    assert "start_id" in result.output and not (tmp_path / "out").exists()
    optima_path.unlink()
    result = cli("export", solutions, "--out", tmp_path / "out")
    assert result.exit_code == 2 and "optima.parquet" in result.output and "--all" in result.output
    assert not (tmp_path / "out").exists()
    result = cli("export", solutions, "--out", tmp_path / "out", "--task", "juggling")
    assert result.exit_code == 2 and "the sweep is of task 'drawing', not 'juggling'" in result.output


def test_export_refuses_a_run_json_with_wrong_types(cli, simulated, tmp_path):
    results = results_with_tasks(simulated, tmp_path / "results")
    ball_sweep(results)
    run_file = results / "grasps" / "drawing" / "run.json"
    original = json.loads(run_file.read_text())
    for field, value in (("hand", 5), ("fingers", "thumb"), ("task", ["drawing"])):
        run_file.write_text(json.dumps({**original, field: value}))
        result = cli("export", run_file.parent / "solutions.parquet", "--out", tmp_path / "out")
        assert result.exit_code == 2 and "run.json" in result.output and f"'{field}'" in result.output, result.output
        assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "out").exists()


def test_export_of_a_sweep_with_no_verified_start_says_so(cli, simulated, tmp_path):
    """It said 'wrote 0 grasps' and exited 0."""
    results = results_with_tasks(simulated, tmp_path / "results")
    ball_sweep(results)
    folder = results / "grasps" / "drawing"
    pd.read_parquet(folder / "optima.parquet").iloc[0:0].to_parquet(folder / "optima.parquet")
    result = cli("export", folder / "solutions.parquet", "--out", tmp_path / "out")
    assert result.exit_code == 2 and "no verified start" in result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "out").exists()
