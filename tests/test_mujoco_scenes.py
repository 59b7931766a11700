"""``grasptask export --mujoco``: each optimum's physics scene as a folder MuJoCo loads from anywhere, whose
contacts are the physics check's and in which the docs' replay gives the check's verdict: a held grasp and a
dropped one, a hand of meshes and one of primitives, a scan and the tool."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import mujoco
import numpy as np
import pandas as pd
import pytest
import trimesh
from docs_replay import docs_replay
from grasp_fixtures import drawing_like_task
from hand_files import GRIPPER_BALL_RADIUS_M, ball_centre, write_mesh_gripper
from scan_files import write_textured_obj

from grasptask.grasp.grasp_pose import Grasp
from grasptask.hand import load_hand
from grasptask.objects import Superquadric, load_object
from grasptask.physics.judge import Holding
from grasptask.physics.physics_settings import load_physics_settings
from grasptask.physics.scene_file import SCENE_FILE, scene_files

SETTINGS = load_physics_settings()
#: the issue's bound on a contact moved by the export (m)
CONTACT_M = 5e-4


def moved_elsewhere(files: dict[str, bytes], root: Path) -> Path:
    """The files written to one folder, then the folder copied to another place and the first removed."""
    first = root / "written"
    for name, content in files.items():
        (first / name).parent.mkdir(parents=True, exist_ok=True)
        (first / name).write_bytes(content)
    second = shutil.copytree(first, root / "elsewhere" / "scene")
    shutil.rmtree(first)
    return second


def object_contacts(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Where the hand touches the object's colliding geoms."""
    body = model.body("object").id
    points = [
        data.contact[k].pos.copy()
        for k in range(data.ncon)
        if body in (model.geom_bodyid[data.contact[k].geom1], model.geom_bodyid[data.contact[k].geom2])
    ]
    return np.array(points).reshape(-1, 3)


def assert_same_contacts(first: np.ndarray, second: np.ndarray) -> None:
    assert len(first) == len(second)
    if not len(first):
        return
    gaps = np.linalg.norm(first[:, None] - second[None], axis=2)
    assert gaps.min(axis=1).max() < CONTACT_M and gaps.min(axis=0).max() < CONTACT_M


def round_trip(holding: Holding, hand, grasp: Grasp, task, root: Path, show: trimesh.Trimesh):
    """A grasp's exported scene, loaded from a copy of its folder: its contacts at both keyframes against the
    check's own scene in those states, and the docs' replay against the check's verdict. Returns the check."""
    scene, result = holding.traced(hand, grasp, task)
    folder = moved_elsewhere(scene_files(scene, result, show, holding.settings), root)
    model = mujoco.MjModel.from_xml_path(str(folder / SCENE_FILE))
    assert model.body("object").id > 0 and model.nkey == 2
    data, ours = mujoco.MjData(model), mujoco.MjData(scene.model)
    for key, state in (("grasp", result.start_state), ("settled", result.settled_state)):
        mujoco.mj_resetDataKeyframe(model, data, model.key(key).id)
        mujoco.mj_forward(model, data)
        ours.qpos[:], ours.qvel[:] = state["qpos"], state["qvel"]
        mujoco.mj_forward(scene.model, ours)
        contacts = object_contacts(model, data)
        assert_same_contacts(contacts, object_contacts(scene.model, ours))
    assert len(contacts), "a settled grasp touches the object"
    held, worst = docs_replay()(folder)
    assert held == result.passed
    check = json.loads((folder / "check.json").read_text())
    assert check["held"] == result.passed
    limit = check["thresholds"]
    for phase in ("settle", *(name for name in result.tests if name.startswith("task"))):
        replayed, recorded = worst[phase], check["phases"][phase]
        went = (
            recorded["translation_m"] > limit["max_translation_m"]
            or recorded["rotation_deg"] > limit["max_rotation_deg"]
        )
        if not went:  # past a threshold the object flies off, and where it ends says nothing
            assert replayed[0] == pytest.approx(recorded["translation_m"], rel=0.2, abs=2e-5), phase
    return result


@pytest.fixture(scope="module")
def gripper(tmp_path_factory):
    """The published-style URDF gripper of STL links, its tips on a 2 cm ball at its zero posture."""
    root = tmp_path_factory.mktemp("gripper")
    strong = load_hand(write_mesh_gripper(root / "strong", 2.0)).grasping_hand()
    weak = load_hand(write_mesh_gripper(root / "weak", 1e-3)).grasping_hand()
    return strong, weak, Grasp(np.eye(3), -ball_centre(), np.zeros(strong.n_joints))


def test_a_mesh_hands_held_grasp_round_trips_with_its_contacts_and_verdict(gripper, tmp_path):
    strong, _, grasp = gripper
    ball = Superquadric(np.full(3, GRIPPER_BALL_RADIUS_M), 1.0, 1.0, name="ball")
    holding = Holding.of(ball, 0.5, SETTINGS)
    result = round_trip(holding, strong, grasp, drawing_like_task(0.2), tmp_path, ball.picture(2000))
    assert result.passed


def test_a_dropped_grasp_round_trips_dropped(gripper, tmp_path):
    _, weak, grasp = gripper
    ball = Superquadric(np.full(3, GRIPPER_BALL_RADIUS_M), 1.0, 1.0, name="ball")
    holding = Holding.of(ball, 0.5, SETTINGS)
    result = round_trip(holding, weak, grasp, drawing_like_task(0.2), tmp_path, ball.picture(2000))
    assert not result.passed


def test_a_scan_with_texture_seams_round_trips(gripper, tmp_path):
    """The ball as a scanner writes it (an OBJ whose texture charts cut it open at their seams, a little
    noise), its convex pieces and its own mesh for show in the folder."""
    strong, _, grasp = gripper
    mesh = trimesh.creation.icosphere(4, GRIPPER_BALL_RADIUS_M)
    mesh.vertices += np.random.default_rng(0).normal(0, 2e-5, mesh.vertices.shape)
    scan = load_object(write_textured_obj(mesh, tmp_path / "scan.obj"), say=lambda _: None)
    holding = Holding.of(scan, 0.5, SETTINGS)
    result = round_trip(holding, strong, grasp, drawing_like_task(0.2), tmp_path / "export", scan.picture(4000))
    assert result.passed
    shown = trimesh.load(tmp_path / "export" / "elsewhere" / "scene" / "meshes" / "object_show.obj", force="mesh")
    assert np.allclose(shown.bounds, scan.picture(4000).bounds, atol=1e-6)


@pytest.fixture(scope="module")
def tool_export(simulated, tmp_path_factory):
    """A short sweep of the project's hand (collision spheres) on the tool, judged in physics, its optima
    exported with --mujoco by the command line."""
    from click.testing import CliRunner

    from grasptask.cli import main

    root = tmp_path_factory.mktemp("tool-export")
    tasks = simulated[0] / "tasks" / "task_models.json"
    runner = CliRunner()
    common = ["--tasks", str(tasks), "--task", "drawing"]
    result = runner.invoke(main, ["synthesize", *common, "--out", str(root), "--starts", "3", "--executor", "serial"])
    assert result.exit_code == 0, result.output
    solutions = root / "drawing" / "solutions.parquet"
    result = runner.invoke(main, ["physics", str(solutions), *common, "--out", str(root / "physics")])
    assert result.exit_code == 0, result.output
    result = runner.invoke(main, ["export", str(solutions), "--out", str(root / "export"), "--mujoco"])
    assert result.exit_code == 0, result.output
    return root, result.output


def test_the_tools_optima_export_as_scenes_with_the_physics_commands_verdicts(tool_export, tmp_path):
    root, output = tool_export
    listing = json.loads((root / "export" / "grasps.json").read_text())["grasps"]
    assert listing and all((root / "export" / g["scene"]).is_file() for g in listing)
    assert "MuJoCo scene folder each" in output and "held in physics" in output
    judged = pd.read_parquet(root / "physics" / "physics.parquet").set_index("start_id")["physics_passed"]
    moved = shutil.copytree(root / "export", tmp_path / "moved")
    for grasp in listing:
        folder = moved / grasp["name"]
        check = json.loads((folder / "check.json").read_text())
        assert check["held"] == bool(judged[grasp["start_id"]]) == grasp["held"]
        held, _ = docs_replay()(folder)
        assert held == check["held"]
        record = json.loads((moved / f"{grasp['name']}.json").read_text())
        assert record["mujoco_scene"] == {"file": grasp["scene"], "held": grasp["held"]}
        text = (folder / SCENE_FILE).read_text()
        assert str(root) not in text and 'name="object"' in text


def test_an_export_without_mujoco_writes_no_scene(tool_export, cli, tmp_path):
    root, _ = tool_export
    result = cli("export", root / "drawing" / "solutions.parquet", "--out", tmp_path / "plain")
    assert result.exit_code == 0, result.output
    assert not [p for p in (tmp_path / "plain").iterdir() if p.is_dir()]
    assert "MuJoCo" not in result.output


def test_a_bad_physics_config_for_the_scenes_is_one_line_and_nothing_written(tool_export, cli, tmp_path):
    root, _ = tool_export
    bad = tmp_path / "physics.yaml"
    bad.write_text("timestep_s: -1\n")
    out = tmp_path / "scenes"
    result = cli("export", root / "drawing" / "solutions.parquet", "--out", out, "--mujoco", "--physics-config", bad)
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1
    assert "timestep_s" in result.output and str(bad) in result.output and not out.exists()
