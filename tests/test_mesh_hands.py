"""Robot hands as people publish them: every link an STL mesh, joints named by number, no YAML."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hand_files import write_mesh_allegro
from hypothesis import given, settings
from hypothesis import strategies as st

from grasptask.errors import BadInputError
from grasptask.hand.hand_files import load_hand
from grasptask.hand.mesh_cover import BOUND_M, mesh_spheres
from grasptask.hand.pad_fit import fit_pad
from grasptask.report.browser_check import check_page, find_chromium
from grasptask.report.hand_view import hand_lines


@pytest.fixture(scope="module")
def mesh_hand(tmp_path_factory):
    return load_hand(write_mesh_allegro(tmp_path_factory.mktemp("mesh_hand")))


@pytest.fixture(scope="module")
def sphere_twin(tmp_path_factory):
    return load_hand(write_mesh_allegro(tmp_path_factory.mktemp("sphere_twin"), tips="sphere"))


def test_a_mesh_hand_loads_with_no_yaml(mesh_hand):
    assert list(mesh_hand.fingers) == ["ff_tip", "mf_tip", "rf_tip", "th_tip"]
    names = [j.name for f in mesh_hand.fingers.values() for j in f.joints]
    assert names == [str(k) for k in range(16)]
    for finger in mesh_hand.fingers.values():
        pad = finger.pad
        assert np.isfinite(pad.point).all() and np.isfinite(pad.normal).all()
        assert pad.radius == pytest.approx(0.012, abs=1e-4)  # the capsule tips' radius, fitted
        assert pad.fit_error_m < 1e-4
        assert len(finger.spheres) > 0


def test_its_pads_agree_with_a_sphere_tipped_twin(mesh_hand, sphere_twin):
    for mesh, sphere in zip(mesh_hand.fingers.values(), sphere_twin.fingers.values(), strict=True):
        tolerance = mesh.pad.fit_error_m + 1e-6
        assert np.linalg.norm(mesh.pad.point - sphere.pad.point) <= tolerance
        assert np.linalg.norm(mesh.pad.centre - sphere.pad.centre) <= tolerance
        assert mesh.pad.normal @ sphere.pad.normal > 1 - 1e-9


def _reach_outside(mesh: trimesh.Trimesh, spheres) -> float:
    """The farthest point of the spheres' union outside the mesh, exactly, on 300 directions per sphere."""
    centre = np.array([c for c, _ in spheres])
    radius = np.array([r for _, r in spheres])
    directions = trimesh.sample.sample_surface_sphere(300)
    boundary = (centre[:, None] + radius[:, None, None] * directions[None]).reshape(-1, 3)
    inner = (np.linalg.norm(boundary[:, None] - centre[None], axis=2) < radius[None] - 1e-9).any(axis=1)
    return float(max(-trimesh.proximity.signed_distance(mesh, boundary[~inner]).max(), 0.0))


@settings(max_examples=8, deadline=None)
@given(st.floats(0.004, 0.015), st.floats(0.0, 0.04), st.sampled_from(["capsule", "ellipsoid"]), st.integers(0, 10**6))
def test_a_rounded_link_is_covered_within_the_bound(radius, length, kind, seed):
    if kind == "capsule":
        mesh = trimesh.creation.capsule(height=length, radius=radius)
    else:
        mesh = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
        mesh.apply_scale([radius, radius * 1.3, radius + length / 2])
    mesh.apply_transform(trimesh.transformations.random_rotation_matrix(np.random.default_rng(seed).random(3)))
    spheres, reach = mesh_spheres(mesh.vertices, mesh.faces, np.eye(4))
    centre = np.array([c for c, _ in spheres])
    radii = np.array([r for _, r in spheres])
    held = (np.linalg.norm(mesh.vertices[:, None] - centre[None], axis=2) <= radii[None] + 1e-9).any(axis=1)
    assert held.all()  # every vertex in a sphere
    assert reach <= BOUND_M
    assert _reach_outside(mesh, spheres) <= BOUND_M + 0.25e-3  # measured on the triangles, to the sampling


def test_the_cover_holds_every_vertex_of_the_mesh_hand(mesh_hand, tmp_path_factory):
    folder = tmp_path_factory.getbasetemp()
    tip = trimesh.load(next(folder.glob("mesh_hand*/hand/meshes/ff_tip.stl")))
    spheres, reach = mesh_spheres(tip.vertices, tip.faces, np.eye(4))
    centre = np.array([c for c, _ in spheres])
    radii = np.array([r for _, r in spheres])
    assert (np.linalg.norm(tip.vertices[:, None] - centre[None], axis=2) <= radii[None] + 1e-9).any(axis=1).all()
    assert reach <= BOUND_M


def test_a_fitted_pad_of_a_sphere_cap():
    cap = trimesh.creation.icosphere(subdivisions=4, radius=0.01)
    cap.apply_translation([0.0, 0.0, 0.04])
    fit = fit_pad(cap.vertices, cap.faces, np.array([0.0, 1.0, 0.0]), 1.0)
    assert fit.radius == pytest.approx(0.01, abs=1e-6)
    assert np.allclose(fit.centre, [0.0, 0.0, 0.04], atol=1e-6)


def _edit(path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


def test_a_fingertip_with_no_surface_facing_the_closing_direction(tmp_path):
    path = write_mesh_allegro(tmp_path)
    # an open sheet on the back of the tip, facing away from the way it closes (+x): a closed mesh always has
    # some surface facing every way, a sheet need not
    back = trimesh.Trimesh(
        [[-0.01, -0.01, 0.01], [-0.01, 0.01, 0.01], [-0.01, 0.01, 0.03], [-0.01, -0.01, 0.03]], [[0, 2, 1], [0, 3, 2]]
    )
    assert back.face_normals[:, 0].max() < -0.99
    back.export(path.parents[1] / "meshes" / "ff_tip.stl")
    with pytest.raises(BadInputError, match="fingertip 'ff_tip': no surface faces the way the finger closes"):
        load_hand(path)


def test_an_unreadable_collision_mesh_names_the_file_and_the_link(tmp_path):
    path = write_mesh_allegro(tmp_path)
    (path.parents[1] / "meshes" / "ff_medial.stl").write_bytes(b"solid broken\nfacet normal\n")
    with pytest.raises(BadInputError, match="ff_medial"):
        load_hand(path)


def test_fingertips_on_one_chain_are_refused(tmp_path):
    path = write_mesh_allegro(tmp_path)
    yaml = tmp_path / "hand.yaml"
    yaml.write_text(f"model: {path}\nfingertips: [ff_medial, ff_tip]\n")
    with pytest.raises(BadInputError, match="fingertips 'ff_medial' and 'ff_tip' sit on one chain"):
        load_hand(yaml)


def test_a_nan_in_the_urdf_is_refused_with_its_joint(tmp_path):
    path = write_mesh_allegro(tmp_path)
    text = path.read_text()
    start = text.index('<joint name="5"')
    origin = text.index('<origin xyz="', start) + len('<origin xyz="')
    path.write_text(text[:origin] + "nan " + text[text.index(" ", origin) + 1 :])
    with pytest.raises(BadInputError, match="joint '5'"):
        load_hand(path)


@pytest.mark.slow
def test_the_hand_command_prints_the_summary_and_writes_a_view(tmp_path):
    from click.testing import CliRunner

    from grasptask.cli import main

    path = write_mesh_allegro(tmp_path)
    result = CliRunner().invoke(main, ["hand", str(path), "--out", str(tmp_path / "view")])
    assert result.exit_code == 0, result.output
    assert "fingertip link 'th_tip': pad at (12.0, 0.0, 43.0) mm, normal (1.00, 0.00, 0.00)" in result.output
    assert "16 joints" in result.output and "collision spheres on the fingers" in result.output
    page = tmp_path / "view" / "hand.html"
    assert page.is_file() and "view-hand" in page.read_text()
    if find_chromium() is not None:
        check = check_page(page)  # a page of one view and no images: its view must draw
        assert check.views and not check.failed_views and not check.console_errors, check.problems()


def test_the_hand_command_refuses_a_bad_hand_with_one_line(tmp_path):
    from click.testing import CliRunner

    from grasptask.cli import main

    path = write_mesh_allegro(tmp_path)
    (path.parents[1] / "meshes" / "ff_medial.stl").write_bytes(b"solid broken\nfacet normal\n")
    result = CliRunner().invoke(main, ["hand", str(path), "--out", str(tmp_path / "view")])
    assert result.exit_code == 2
    assert "ff_medial" in result.output and len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "view" / "hand.html").exists()


def test_a_contact_rolls_over_a_mesh_pad_only_as_far_as_its_sphere_follows_the_mesh(mesh_hand):
    """A capsule tip's fitted sphere is its end cap's: a contact rolled over it stays on or inside the capsule
    over the whole 45 degrees. A tip flatter than its pad sphere falls away from it, and a contact rolled far
    enough lies in the air beside the real tip: the NLP's pad bound for that finger stops short of it."""
    from grasptask.hand.pad_fit import roll_limit_deg

    assert all(f.pad.roll_max_deg == 45.0 and f.tip_mesh is not None for f in mesh_hand.fingers.values())
    assert (mesh_hand.pad_angle_limits(45.0) == 45.0).all() and (mesh_hand.pad_angle_limits(10.0) == 10.0).all()
    assert any("on the mesh for 45 deg of roll" in line for line in hand_lines(mesh_hand))
    normal, allowed = np.array([1.0, 0.0, 0.0]), 1e-3
    limits = []
    for flattening in (1.0, 0.7, 0.5):  # a round tip, then flatter than its pad sphere away from the normal
        tip = trimesh.creation.icosphere(4, 0.01)
        tip.apply_scale([1.0, 1.0, flattening])
        limits.append(roll_limit_deg(tip.vertices, tip.faces, np.zeros(3), 0.0095, normal, allowed, 45.0))
    # the flattest's surface lies 1 mm inside the 9.5 mm sphere by about 20 degrees towards its 5 mm half-axis
    assert limits[0] == 45.0 and limits[0] > limits[1] > limits[2] and 15.0 <= limits[2] <= 25.0
