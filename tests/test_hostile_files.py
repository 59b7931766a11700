"""Files as a careless or hostile hand writes them: YAML that would hang the parser or hide a typo, URDFs with
impossible numbers, meshes with holes of NaN, CSVs as spreadsheets save them, pipelines with a typo in the last
stage, and counts that would hang a sweep. Each is one line naming the file and the element, exit code 2 and
nothing written, or is read as the user meant it."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh
import yaml

from grasptask.errors import BadInputError
from grasptask.hand import load_hand
from grasptask.io.config_schema import load_yaml
from grasptask.objects import load_object
from tests.test_robot_hands import TWO_FINGERS

FAST = Path("tests/data/solver_fast.yaml")


def one_line(result) -> str:
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    return lines[0]


def synthesize(cli, tasks, out, *extra):
    return cli("synthesize", "--tasks", tasks, "--task", "drawing", "--out", out, "--starts", "1", *extra)


DEEP = "a: " + "[" * 3000 + "]" * 3000 + "\n"


@pytest.mark.parametrize(
    "option, name, text",
    [
        ("--grasp-config", "grasp.yaml", DEEP),
        ("--solver-config", "solver.yaml", DEEP),
        ("--object", "object.yaml", DEEP),
        ("--hand", "hand.yaml", DEEP),
        ("--physics-config", "physics.yaml", DEEP),
    ],
)
def test_yaml_nested_thousands_deep_is_one_line_in_every_reader(tasks, tmp_path, cli, option, name, text):
    path = tmp_path / name
    path.write_text(text)
    extra = ("--physics",) if option == "--physics-config" else ()
    line = one_line(synthesize(cli, tasks, tmp_path / "o", option, path, *extra))
    assert name in line and "line 1" in line and "nested deeper than 32 levels" in line
    assert not (tmp_path / "o").exists()


def test_a_pipeline_nested_thousands_deep_is_one_line(tmp_path, cli):
    path = tmp_path / "pipeline.yaml"
    path.write_text("name: deep\nstages:\n" + "  - " + DEEP)
    line = one_line(cli("pipeline", "run", path))
    assert "pipeline.yaml" in line and "nested deeper" in line


@pytest.mark.parametrize(
    "option, name, text, expected",
    [
        # a key given twice: YAML keeps the last without a word
        ("--grasp-config", "grasp.yaml", "friction_coefficient: 0.5\ncone_edges: 8\nfriction_coefficient: 0.9\n",
         "line 3: invalid YAML: key 'friction_coefficient' given twice (first on line 1)"),
        ("--solver-config", "solver.yaml", "ipopt:\n  tol: 1.0e-4\n  tol: 1.0e-6\n", "line 3: invalid YAML: key 'tol'"),
        ("--physics-config", "physics.yaml", "hold_s: 1.0\nhold_s: 2.0\n", "'hold_s' given twice"),
        # a count that would hang a sweep: refused with its bound
        ("--grasp-config", "grasp.yaml", "cone_edges: 100000\n", "'cone_edges': must be less than or equal to 32"),
        ("--solver-config", "solver.yaml", "ipopt: {max_iter: 10000000}\n", "max_iter must be from 1 to 10000"),
        ("--solver-config", "solver.yaml", "feedback_rounds: 100000\n", "less than or equal to 10"),
        ("--solver-config", "solver.yaml", "geometric_iterations: 100000000\n", "less than or equal to 10000"),
        # a hold that would run for ever on a grasp that holds (52 s a grasp that drops)
        ("--physics-config", "physics.yaml", "hold_s: 1.0e6\n", "'hold_s': must be less than or equal to 10"),
        ("--physics-config", "physics.yaml", "timestep_s: 1.0e-9\n", "'timestep_s': must be greater than or equal"),
    ],
)  # fmt: skip
def test_a_config_that_would_lie_or_hang_is_one_line(tasks, tmp_path, cli, option, name, text, expected):
    path = tmp_path / name
    path.write_text(text)
    extra = ("--physics",) if option == "--physics-config" else ()
    line = one_line(synthesize(cli, tasks, tmp_path / "o", option, path, *extra))
    assert name in line and expected in line and not (tmp_path / "o").exists()


def test_stages_given_twice_in_a_pipeline_is_refused(tmp_path, cli):
    stage = {"run": "simulate", "args": ["--out", str(tmp_path / "r")], "outputs": [str(tmp_path / "r")]}
    text = yaml.safe_dump({"name": "twice", "stages": [stage]})
    path = tmp_path / "pipeline.yaml"
    path.write_text(text + text.split("\n", 1)[1])  # name: once, stages: twice
    line = one_line(cli("pipeline", "run", path))
    assert "pipeline.yaml" in line and "'stages' given twice" in line and not (tmp_path / "r").exists()


def test_numbers_yaml_1_1_reads_as_text_are_numbers(tmp_path):
    path = tmp_path / "physics.yaml"
    path.write_text("hold_s: 1.0e6\nx: 1e-3\ny: -2E+2\nz: 12\nw: e5\n")
    assert load_yaml(path) == {"hold_s": 1.0e6, "x": 1e-3, "y": -200.0, "z": 12, "w": "e5"}


def test_command_line_counts_have_bounds(tasks, tmp_path, cli):
    for option, value, said in (("--starts", "1000000", "there are 126 starts"), ("--workers", "100000", "1 to 64")):
        result = cli("synthesize", "--tasks", tasks, "--task", "drawing", "--out", tmp_path / "o", option, value)
        assert said in one_line(result) and not (tmp_path / "o").exists()


def with_inertial(mass: object, ixx: float) -> str:
    """The two-finger hand with an inertial element on link l1."""
    inertia = f'<inertia ixx="{ixx}" ixy="0" ixz="0" iyy="1e-5" iyz="0" izz="1e-5"/>'
    return TWO_FINGERS.replace(
        '<link name="l1"/>', f'<link name="l1"><inertial><mass value="{mass}"/>{inertia}</inertial></link>'
    )


def hand_case(case: str) -> str:
    return {
        "two links named alike": TWO_FINGERS.replace('<link name="l2"/>', '<link name="l2"/><link name="l2"/>'),
        "two joints named alike": TWO_FINGERS.replace('name="t2"', 'name="t1"'),
        "an origin at 1e30 m": TWO_FINGERS.replace('xyz="0.03 0 0.01"', 'xyz="1e30 0 0.01"'),
        "an origin at 1e300 m": TWO_FINGERS.replace('xyz="0.03 0 0.01"', 'xyz="1e300 0 0.01"'),
        "an origin in millimetres": TWO_FINGERS.replace('xyz="0.03 0 0.01"', 'xyz="30 0 10"'),
        "a negative inertia": with_inertial(0.1, -1e-5),
        "a mass of NaN": with_inertial("nan", 1e-5),
        "a negative mass": with_inertial(-1, 1e-5),
        "a zero-length link": TWO_FINGERS.replace('<origin xyz="0 0 0.05"/>', '<origin xyz="0 0 0"/>', 1),
        "a box of NaN": TWO_FINGERS.replace('<box size="0.08 0.08 0.02"/>', '<box size="0.08 nan 0.02"/>'),
        "a sphere of no radius": TWO_FINGERS.replace('<sphere radius="0.01"/>', '<sphere radius="0"/>', 1),
    }[case]


HAND_CASES = {
    "two links named alike": "link 'l2' is defined twice",
    "two joints named alike": "joint 't1' is defined twice",
    "an origin at 1e30 m": "joint 'j1': its origin lies 1e+30 m along an axis from link 'palm'",
    "an origin at 1e300 m": "joint 'j1': its origin lies 1e+300 m along an axis from link 'palm'",
    "an origin in millimetres": "is the file in millimetres?",
    "a negative inertia": "link 'l1': inertia has a negative principal moment",
    "a mass of NaN": "link 'l1': inertial mass nan is not a mass",
    "a negative mass": "link 'l1': inertial mass -1.0 is not a mass",
    "a zero-length link": "fingertip 'f1' lies on its last joint 'j1' (a link of zero length)",
    "a box of NaN": "link 'palm': box size '0.08 nan 0.02' is not a positive number of metres",
    "a sphere of no radius": "link 'f1': sphere radius '0' is not a positive number of metres",
}


@pytest.mark.parametrize("case", list(HAND_CASES))
def test_urdfs_with_impossible_elements_are_one_line_naming_them(case, tasks, tmp_path, cli):
    path = tmp_path / "hand.urdf"
    path.write_text(hand_case(case))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy RuntimeWarning before the line
        line = one_line(synthesize(cli, tasks, tmp_path / "o", "--hand", path))
    assert "hand.urdf" in line and HAND_CASES[case] in line, line
    assert not (tmp_path / "o").exists()


def test_an_error_in_a_hand_yaml_names_the_yaml_and_its_key(tmp_path):
    urdf = tmp_path / "two.urdf"
    urdf.write_text(TWO_FINGERS)
    for text, key in (
        ("palm_link: nowhere\n", "field 'palm_link': palm link 'nowhere' is not defined in two.urdf"),
        ("fingertips: [f1, f9]\n", "field 'fingertips': unknown fingertip 'f9'"),
        ("finger_names: [a, b, c]\n", "field 'finger_names': 3 finger names for 2 fingertips"),
        ("grasping_fingers: [f1, f7]\n", "field 'grasping_fingers': grasping finger 'f7'"),
    ):
        yaml_path = tmp_path / "hand.yaml"
        yaml_path.write_text(f"model: two.urdf\n{text}")
        with pytest.raises(BadInputError) as caught:
            load_hand(yaml_path)
        assert str(caught.value).startswith(f"{yaml_path}: ") and key in str(caught.value), caught.value


def nan_mesh(path: Path) -> Path:
    """A ball as a scanner leaves it: a few vertices lost as NaN or inf."""
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.03)
    vertices = ball.vertices.copy()
    vertices[5] = np.nan
    vertices[7, 1] = np.inf
    with np.errstate(invalid="ignore"):  # the export's own face normals
        trimesh.Trimesh(vertices, ball.faces, process=False).export(path)
    return path


@pytest.mark.parametrize("suffix", [".obj", ".stl", ".ply", ".off"])
def test_a_mesh_with_non_finite_vertices_is_repaired_and_said_once(tmp_path, suffix):
    path = nan_mesh(tmp_path / f"ball{suffix}")
    said: list[str] = []
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        obj = load_object(path, say=said.append)
    assert len(said) == 1 and "vertices that are not finite numbers" in said[0] and str(path) in said[0]
    assert np.isfinite(obj.bounds()).all()


def test_a_hand_mesh_with_non_finite_vertices_is_refused_with_the_count(tmp_path):
    nan_mesh(tmp_path / "palm.stl")
    path = tmp_path / "hand.urdf"
    path.write_text(TWO_FINGERS.replace('<box size="0.08 0.08 0.02"/>', '<mesh filename="palm.stl"/>'))
    with pytest.raises(BadInputError, match=r"palm.stl: link 'palm': \d+ of the collision mesh's \d+ vertices"):
        load_hand(path)


def test_an_object_file_of_unknown_type_is_not_read_as_yaml(tasks, tmp_path, cli):
    cloud = tmp_path / "cloud.xyz"
    cloud.write_text("0 0 0\n1 0 0\n")
    line = one_line(synthesize(cli, tasks, tmp_path / "o", "--object", cloud))
    assert "cloud.xyz: unknown object file type '.xyz'" in line and ".csv" in line


def spreadsheet(path: Path, data: np.ndarray, sep: str, decimal: str, columns: str = "t,fx,fy,fz,tx,ty,tz") -> Path:
    """A CSV as Excel saves it: a byte-order mark, CRLF lines, and the locale's separator and decimal mark."""
    lines = [columns.replace(",", sep)]
    lines += [sep.join(f"{v:.6f}".replace(".", decimal) for v in row) for row in data]
    path.write_bytes(b"\xef\xbb\xbf" + "\r\n".join(lines).encode() + b"\r\n")
    return path


@pytest.mark.parametrize("sep, decimal", [(",", "."), (";", ","), (";", "."), ("\t", ".")])
def test_csv_as_spreadsheets_save_it(tmp_path, cli, sep, decimal):
    from tests.conftest import wrench_samples

    data = wrench_samples()
    recording = spreadsheet(tmp_path / "rec.csv", data, sep, decimal)
    manifest = tmp_path / "manifest.csv"
    header, row = ["id", "task", "subject", "trial", "grasp", "path"], ["r1", "drawing", "1", "1", "pinch", "rec.csv"]
    manifest.write_bytes(b"\xef\xbb\xbf" + "\r\n".join(sep.join(r) for r in (header, row)).encode() + b"\r\n")
    result = cli("fit-task", manifest, "--out", tmp_path / "tasks")
    assert result.exit_code == 0, result.output
    from grasptask.task.recordings import read_recording

    np.testing.assert_allclose(read_recording(recording), data, atol=1e-6)


def test_fit_task_skipping_every_recording_names_the_first(tmp_path, cli, recording_factory):
    for name in ("a.csv", "b.csv"):
        (tmp_path / name).write_text("t,fx\n0,1\n")
    manifest = tmp_path / "manifest.csv"
    manifest.write_text("id,task,subject,trial,grasp,path\na,drawing,1,1,pinch,a.csv\nb,drawing,1,2,pinch,b.csv\n")
    result = cli("fit-task", manifest, "--skip-bad", "--out", tmp_path / "tasks")
    errors = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert result.exit_code == 2 and len(errors) == 1, result.output
    line = errors[0]
    assert "a.csv" in line and "none of the 2 recordings is usable" in line
    assert not (tmp_path / "tasks").exists()


def _pipeline(tmp_path: Path, stages: list[dict]) -> Path:
    path = tmp_path / "pipeline.yaml"
    path.write_text(yaml.safe_dump({"name": "p", "stages": stages}))
    return path


def test_a_dry_run_checks_every_stage_and_writes_nothing(tmp_path, cli, monkeypatch):
    monkeypatch.chdir(tmp_path)
    good = {"name": "sim", "run": "simulate", "args": ["--out", "results/r"], "outputs": ["results/r"]}
    typo = {"name": "dist", "run": "distancez", "args": [], "outputs": ["results/d"]}
    bad_option = {"name": "fit", "run": "fit-task", "args": ["x.csv", "--nope"], "outputs": ["results/t"]}
    for last, problem in ((typo, "No such command 'distancez'"), (bad_option, "No such option '--nope'")):
        path = _pipeline(tmp_path, [good, last])
        for extra in (["--dry-run"], []):
            line = one_line(cli("pipeline", "run", path, *extra))
            assert "pipeline.yaml" in line and f"stage '{last['name']}'" in line and problem in line
            assert sorted(p.name for p in tmp_path.iterdir()) == ["pipeline.yaml"]  # no results/, no state
    path = _pipeline(tmp_path, [good])
    result = cli("pipeline", "run", path, "--dry-run")
    assert result.exit_code == 0 and "simulate" in result.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipeline.yaml"]


def test_a_stage_refused_before_it_ran_leaves_no_state_and_a_missing_output_is_warned(tmp_path, cli, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "taken").write_text("a file where a folder goes")
    refused = {"name": "sim", "run": "simulate", "args": ["--out", "taken"], "outputs": ["taken/manifest.csv"]}
    assert cli("pipeline", "run", _pipeline(tmp_path, [refused]), "--force").exit_code == 2
    assert not (tmp_path / "results" / ".pipeline" / "p.json").exists()
    wrong = {"name": "sim", "run": "simulate", "args": ["--out", "r"], "outputs": ["r/never.csv"]}
    result = cli("pipeline", "run", _pipeline(tmp_path, [wrong]))
    assert result.exit_code == 0 and "warning: its declared output r/never.csv did not appear" in result.output
