"""A user's own object, as it comes: scans laid out as they are published load as they are, repaired
and said so in one line; a bare file gets a task frame at its centre of volume; what a bare file cannot say is
given on the command line; and each file no repair can save is one line with exit code 2."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
import trimesh
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from grasptask.errors import BadInputError
from grasptask.objects import load_object
from grasptask.objects.mesh_file import holes, non_manifold_edges, open_edges
from grasptask.objects.mesh_object import MeshObject
from grasptask.objects.object_files import FRAME_DEPTH_M, file_object_name
from tests.grasp_fixtures import first_verified
from tests.scan_files import bottle, bowl, box, can, cup, rod, with_fin, with_hole, write_scene_glb, write_textured_obj
from tests.test_bad_input import assert_rejected


def loaded(path: Path, **overrides):
    said: list[str] = []
    return load_object(path, say=said.append, **overrides), said


@pytest.mark.parametrize("shape", ["bottle", "box"])
def test_a_textured_obj_split_at_its_seams_loads_closed(tmp_path, shape):
    mesh = bottle() if shape == "bottle" else box()
    path = write_textured_obj(mesh, tmp_path / f"{shape}.obj")
    raw = trimesh.load(path, force="mesh")
    assert open_edges(raw) > 50  # read as trimesh reads it, every seam is open: refused before this issue
    obj, said = loaded(path)
    assert obj.mesh.is_watertight and obj.mesh.volume == pytest.approx(mesh.volume, rel=1e-6)
    assert len(said) == 1 and "seam" in said[0] and path.name in said[0]


def test_a_glb_scene_of_several_nodes_is_joined_with_its_transforms(tmp_path):
    """A body and a turned cap, each stored about its own origin: joined where their nodes place them."""
    obj, _ = loaded(write_scene_glb(tmp_path / "scene.glb"))
    cap_and_body = np.pi * 0.03**2 * 0.12 + 0.02 * 0.04 * 0.02
    assert obj.mesh.volume == pytest.approx(cap_and_body, rel=0.02)
    in_file = obj.mesh.copy().apply_transform(obj.task_frame)
    np.testing.assert_allclose(in_file.bounds[:, 2], [0.0, 0.14], atol=1e-6)  # the cap on top, 2 cm tall
    np.testing.assert_allclose(in_file.extents[:2], [0.06, 0.06], atol=1e-3)  # the cap turned within the body


def test_a_small_hole_is_filled_and_said_with_its_size(tmp_path):
    ball = trimesh.creation.icosphere(5, 0.025)
    holed = with_hole(ball, ball.vertices[np.argmin(np.abs(ball.vertices[:, 0] - 0.025))], 0.0008)
    assert 0.0015 < holes(holed)[0] < 0.0025  # a 2 mm hole
    holed.export(tmp_path / "holed.stl")
    obj, said = loaded(tmp_path / "holed.stl")
    assert obj.mesh.is_watertight and "filled 1 holes (the widest 2.0 mm)" in said[0]


def test_a_non_manifold_fin_is_removed(tmp_path):
    finned = with_fin(box())
    assert non_manifold_edges(finned) == 1
    finned.export(tmp_path / "fin.ply")
    obj, said = loaded(tmp_path / "fin.ply")
    assert obj.mesh.is_watertight and obj.mesh.volume == pytest.approx(box().volume, rel=1e-6)
    assert "removed 1 non-manifold edges" in said[0]


def test_a_real_scan_with_holes_and_non_manifold_edges_loads():
    """The Stanford bunny as its range scans were merged (it ships with pymeshfix): 4 holes under its base and
    132 non-manifold edges."""
    import pymeshfix

    scan = Path(pymeshfix.__file__).parent / "examples" / "StanfordBunny.ply"
    obj, said = loaded(scan, unit="mm")
    assert obj.mesh.is_watertight and obj.mesh.is_winding_consistent
    assert "filled 4 holes (the widest 14 mm)" in said[0] and "132 non-manifold edges" in said[0]


def asymmetric_mesh() -> trimesh.Trimesh:
    """An elongated convex body with no symmetry, so that its principal frame is fixed, signs included."""
    points = np.random.default_rng(4).normal(size=(40, 3)) * [0.02, 0.03, 0.06]
    return trimesh.convex.convex_hull(points)


@settings(max_examples=8, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_default_task_frame_is_inside_and_turns_with_the_mesh(tmp_path_factory, seed):
    """Moved and turned, a bare mesh is the same object in its default task frame; grasps, which live in the
    task frame, follow the mesh."""
    folder = tmp_path_factory.mktemp("centre")
    rng = np.random.default_rng(seed)
    move = np.eye(4)
    move[:3, :3] = Rotation.from_euler("xyz", rng.uniform(-180, 180, 3), degrees=True).as_matrix()
    move[:3, 3] = rng.uniform(-0.2, 0.2, 3)
    mesh = asymmetric_mesh()
    mesh.export(folder / "still.stl")
    mesh.copy().apply_transform(move).export(folder / "moved.stl")
    still, moved = (
        load_object(folder / "still.stl", say=lambda _: None),
        load_object(folder / "moved.stl", say=lambda _: None),
    )
    np.testing.assert_allclose(moved.task_frame, move @ still.task_frame, atol=1e-5)  # STL: float32
    assert still.task_frame_rule == "centre"
    assert -still.signed_distance(np.zeros((1, 3)))[0] >= FRAME_DEPTH_M  # the frame lies inside
    probes = np.random.default_rng(1).uniform(-0.06, 0.06, (60, 3))
    np.testing.assert_allclose(moved.signed_distance(probes), still.signed_distance(probes), atol=1e-5)
    longest = np.ptp(still.mesh.vertices, axis=0)
    assert np.argmax(longest) == 2  # z along the longest axis


@pytest.mark.parametrize("shape", ["bowl", "can", "ball"])
def test_a_scanned_symmetric_object_gets_z_along_its_symmetry_axis(tmp_path, shape):
    """Turned in its file, with a scan's noise and texture seams: a bowl's and a can's z is their axis of
    symmetry, whatever the noise makes of their two equal axes; a ball keeps the file's own axes."""
    mesh = {"bowl": bowl, "can": can, "ball": lambda: trimesh.creation.icosphere(4, radius=0.035)}[shape]()
    mesh.vertices += np.random.default_rng(7).normal(scale=2e-4, size=mesh.vertices.shape)
    turn = Rotation.from_euler("xyz", [35, -20, 50], degrees=True).as_matrix()
    mesh.vertices = mesh.vertices @ turn.T + [0.1, -0.05, 0.2]
    obj, _ = loaded(write_textured_obj(mesh, tmp_path / f"{shape}.obj"))
    frame = obj.task_frame[:3, :3]
    if shape == "ball":
        assert obj.task_frame_axes.startswith("the file's own axes")
        np.testing.assert_allclose(frame, np.eye(3))
        return
    assert obj.task_frame_axes == "z along its symmetry axis"
    assert abs(frame[:, 2] @ turn[:, 2]) > 0.9999
    if shape == "bowl":  # its wide rim reaches farther from its centre than its base: z points out of it
        assert frame[:, 2] @ turn[:, 2] > 0


def test_unit_mass_and_task_frame_reach_run_json(cli, simulated, tmp_path):
    """A bare OBJ in millimetres, with --unit, --mass and --task-frame: the sweep records them, writes the object
    config the later stages read, and its summary says where the task frame is."""
    path = write_textured_obj(box(), tmp_path / "box.obj", unit_scale=1000.0)
    tasks = simulated[0] / "tasks" / "task_models.json"
    out = tmp_path / "out"
    args = ["synthesize", "--tasks", tasks, "--task", "drawing", "--out", out, "--object", path, "--starts", "1",
            "--solver-config", "tests/data/solver_tiny.yaml", "--executor", "serial"]  # fmt: skip
    result = cli(*args, "--unit", "mm", "--mass", "0.45", "--task-frame", "centre")
    assert result.exit_code in (0, 3), result.output  # 3: its one start verified nothing
    run = json.loads((out / "drawing" / "run.json").read_text())
    assert run["object_options"] == {"unit": "mm", "mass_kg": 0.45, "task_frame": "centre"}
    assert run["object_mass_kg"] == 0.45 and run["task_frame"]["rule"] == "centre"
    np.testing.assert_allclose(np.array(run["task_frame"]["in_file_frame"])[:3, 3], [0, 0, 0.0875], atol=1e-6)
    config = yaml.safe_load((out / "drawing" / "object.yaml").read_text())
    assert run["object"] == str(out / "drawing" / "object.yaml") and config["unit"] == "mm"
    assert (
        "task frame: centre (z along its longest axis), at (0, 0, 88) mm" in result.output
        and "mass is not given" not in result.output
    )
    again = cli(*args, "--unit", "mm")  # no mass: said
    assert "the object's mass is not given" in again.output
    base = cli(*args, "--unit", "mm", "--task-frame", "origin", "--task-frame-outside")  # on its base: taken
    assert base.exit_code in (0, 3), base.output
    assert "is 0.0 mm inside it; taken: the task's torques act about it" in base.output
    run = json.loads((out / "drawing" / "run.json").read_text())
    assert run["object_options"] == {"unit": "mm", "task_frame": "origin", "task_frame_outside": True}


def test_a_hollow_objects_centre_is_taken_and_said(tmp_path):
    """A mug's centre of volume lies in its cavity, a thin rod's less than 5 mm inside it: each is the frame a
    user would choose, so it is taken, and where it lies is said."""
    write_textured_obj(cup(), tmp_path / "mug.obj")
    mug, said = loaded(tmp_path / "mug.obj")
    assert mug.task_frame_rule == "centre" and mug.signed_distance(np.zeros((1, 3)))[0] > 0  # in the cavity
    assert len(said) == 2 and "repaired" in said[0]  # the seams, then the frame
    assert said[1].startswith(f"{tmp_path / 'mug.obj'}: the task frame (centre, at (")
    assert "mm outside the solid; taken: the task's torques act about it" in said[1]
    rod().export(tmp_path / "rod.stl")
    thin, said = loaded(tmp_path / "rod.stl")
    assert said == [f"{tmp_path / 'rod.stl'}: the task frame (centre, at (0, 0, 60) mm in the file's frame) is 3.0 mm "
                    "inside it; taken: the task's torques act about it"]  # fmt: skip
    solid, said = loaded(write_textured_obj(bottle(), tmp_path / "bottle.obj"))
    assert not any("task frame" in line for line in said)  # deep inside: nothing to say


@pytest.mark.parametrize(
    ("path", "name"),
    [("ycb/025_mug/google_16k/textured.obj", "025_mug"), ("036_wood_block/textured.obj", "036_wood_block"),
     ("scans/banana/poisson/mesh.ply", "banana"), ("objects/knife.stl", "knife")],
)  # fmt: skip
def test_a_generic_file_name_gives_the_folders(tmp_path, path, name):
    assert file_object_name(tmp_path / path) == name


def test_a_scans_name_reaches_the_object_and_a_yamls_name_wins(tmp_path):
    folder = tmp_path / "025_mug" / "google_16k"
    folder.mkdir(parents=True)
    write_textured_obj(bottle(), folder / "textured.obj")
    assert loaded(folder / "textured.obj")[0].name == "025_mug"
    assert loaded(folder / "textured.obj", mass_kg=0.3)[0].name == "025_mug"  # with --mass: still
    (folder / "mug.yaml").write_text("type: mesh\nmesh: textured.obj\nname: my mug\ntask_frame: centre\n")
    assert loaded(folder / "mug.yaml")[0].name == "my mug"


def _bad_scan(tmp_path: Path, case: str) -> tuple[Path, list[str]]:
    """A file no repair can save, or a frame outside the object, and the options it is given with."""
    if case == "large hole":
        path = tmp_path / "cut.stl"
        with_hole(bottle(), np.array([0.0, 0.0, 0.2]), 0.1).export(path)  # all above the body's middle gone
        return path, []
    if case == "frame outside":
        path = tmp_path / "bottle.obj"
        write_textured_obj(bottle(), path)
        return path, ["--task-frame", "origin"]  # YCB's origin: on the base
    if case == "millimetres":
        path = tmp_path / "box_mm.obj"
        write_textured_obj(box(), path, unit_scale=1000.0)
        return path, []
    if case == "no triangles":
        path = tmp_path / "points.glb"
        cloud = trimesh.PointCloud(np.random.default_rng(0).uniform(-0.03, 0.03, (100, 3)))
        path.write_bytes(trimesh.Scene(cloud).export(file_type="glb"))
        return path, []
    if case == "no normals":
        path = tmp_path / "cloud.csv"
        points = trimesh.sample.sample_surface_even(box(), 2000, seed=0)[0]
        np.savetxt(path, points, delimiter=",", header="x,y,z", comments="")
        return path, []
    assert case == "non-manifold"
    path = tmp_path / "sheets.ply"
    corners = np.array([[0, 0, 0], [0, 0, 0.05], [0.03, 0, 0.02], [-0.03, 0, 0.02], [0, 0.03, 0.02]], dtype=float)
    trimesh.Trimesh(corners, [[0, 1, 2], [1, 0, 3], [0, 1, 4]], process=False).export(path)  # three sheets, one edge
    return path, []


BAD_SCANS = {
    "large hole": "has a hole 70 mm across",
    "frame outside": "task frame (origin, at (0, 0, 0) mm in the file's frame) is 0.0 mm inside it; the task's "
    "torques act about it, so place it at least 5 mm inside (--task-frame centre, or task_frame in the object's "
    "YAML), or accept it (--task-frame-outside",
    "millimetres": "give --unit mm",
    "no triangles": "holds no triangles",
    "no normals": "normals",
    "non-manifold": "1 non-manifold edges",
}


@pytest.mark.parametrize("case", list(BAD_SCANS))
def test_a_scan_no_repair_can_save_is_one_line_and_exit_2(cli, simulated, tmp_path, case):
    path, options = _bad_scan(tmp_path, case)
    tasks = simulated[0] / "tasks" / "task_models.json"
    out = tmp_path / "out"
    result = cli("synthesize", "--tasks", tasks, "--task", "drawing", "--out", out, "--object", path, *options)
    assert_rejected(result, out, path.name, BAD_SCANS[case])


def test_a_frame_outside_is_taken_when_the_yaml_says_so(tmp_path):
    write_textured_obj(bottle(), tmp_path / "bottle.obj")
    (tmp_path / "bottle.yaml").write_text("type: mesh\nmesh: bottle.obj\ntask_frame: origin\n")
    with pytest.raises(BadInputError, match="task_frame_outside: true"):
        load_object(tmp_path / "bottle.yaml", say=lambda _: None)
    (tmp_path / "bottle.yaml").write_text(
        "type: mesh\nmesh: bottle.obj\ntask_frame: origin\ntask_frame_outside: true\n"
    )
    obj = load_object(tmp_path / "bottle.yaml", say=lambda _: None)
    assert obj.bounds()[0, 2] == pytest.approx(0.0) and os.path.basename(obj.name) == "bottle"


@settings(max_examples=25, deadline=None)
@given(st.floats(0.2e-3, 20e-3), st.floats(1e-3, 8e-3))
def test_a_box_face_keeps_its_own_normal_up_to_its_edge(from_edge, height):
    """Normals are not averaged across a crease: a point over a box's face, however near its edge, has the
    face's normal (averaged across the edge, 1 mm from it was 27 degrees off)."""
    obj = MeshObject(box())  # 9 x 4 x 17.5 cm, the +x face at x = 0.045, its edge with +y at y = 0.02
    _, normal = obj.closest_point(np.array([[0.045 + height, 0.02 - from_edge, 0.09]]))
    np.testing.assert_allclose(normal[0], [1.0, 0.0, 0.0], atol=1e-9)


@pytest.mark.parametrize(
    ("point", "expected"),
    [
        ([0.051, 0.026, 0.09], [1, 1, 0]),  # a ball beside the edge, on its bisector
        ([0.051, 0.022, 0.09], [3, 1, 0]),  # beside it, nearer the +x face's side
        ([0.05, 0.025, 0.18], [1, 1, 1]),  # beside a corner
    ],
)
def test_a_ball_touching_an_edge_or_corner_gets_the_direction_to_its_centre(point, expected):
    _, normal = MeshObject(box()).closest_point(np.array([point]))
    np.testing.assert_allclose(normal[0], np.array(expected) / np.linalg.norm(expected), atol=1e-9)


def test_a_smooth_scan_keeps_smoothly_turning_normals():
    """The bottle's side (7.5 degrees between neighbouring faces) is no crease: the normals of points 0.6 mm
    apart round it turn by under 2 degrees, where the faces' own normals jump 7.5 degrees."""
    obj = MeshObject(bottle())
    angles = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    ring = np.column_stack([0.04 * np.cos(angles), 0.04 * np.sin(angles), np.full(400, 0.07)])
    _, normals = obj.closest_point(ring)
    turn = np.degrees(np.arccos(np.clip((normals * np.roll(normals, -1, axis=0)).sum(axis=1), -1, 1)))
    assert turn.max() < 2.0  # 0.9 degrees of angle between neighbours, 7.5 between faces


@pytest.mark.slow
@pytest.mark.parametrize(
    ("shape", "task"),
    [
        ("marker", "screwdriving"),
        # a 6 mm rod: no start of 12 verified while the contacts were held on the grid's zero set
        ("rod", "drawing"),
        ("cup", "screwdriving"),
        ("box", "cutting"),
    ],
)
def test_a_scan_as_published_gives_a_verified_grasp_in_its_default_frame(simulated, tmp_path, shape, task):
    """A marker (a rod 18 mm across, as YCB's large marker), a thin rod (6 mm), a mug with a handle (its centre
    in the cavity) and a box with sharp edges, each a bare textured OBJ split at its seams: each loads in its
    default frame and gives a verified grasp."""
    (tmp_path / shape).mkdir()
    shapes = {"marker": lambda: rod(radius=0.009), "rod": rod, "cup": cup, "box": box}
    path = write_textured_obj(shapes[shape](), tmp_path / shape / "textured.obj")
    tasks = str(simulated[0] / "tasks" / "task_models.json")
    _, context = first_verified("configs/hands/human.yaml", str(path), tasks, task, starts=12)
    assert context.obj.name == shape and context.obj.task_frame_rule == "centre"


def test_a_noisy_seamed_scan_is_grasped_with_its_contacts_on_its_own_triangles(simulated, tmp_path):
    """A soup can as a scanner gives it: 0.2 mm of noise on every vertex, split at its texture seams. The NLP
    sees the smooth surrogate of its distance grid, but the verified grasp's pads meet the scan's own triangles:
    each contact lies on them, and each pad sinks into them by the compliance within 0.5 mm."""
    mesh = can()
    mesh.vertices += np.random.default_rng(3).normal(scale=2e-4, size=mesh.vertices.shape)
    (tmp_path / "can").mkdir()
    path = write_textured_obj(mesh, tmp_path / "can" / "textured.obj")
    tasks = str(simulated[0] / "tasks" / "task_models.json")
    row, context = first_verified("configs/hands/human.yaml", str(path), tasks, "drawing")
    fingers = list(context.job.hand.grasping)
    sinking = np.array([row[f"verify_contact_distance_m_{f}"] for f in fingers])
    assert np.abs(sinking).max() <= 0.5e-3
    contacts = np.array([[row[f"contact_{f}_{a}"] for a in "xyz"] for f in fingers])
    _, off, _ = trimesh.proximity.closest_point(context.obj.mesh, contacts)  # the scan's triangles, as loaded
    assert off.max() <= 0.5e-3
