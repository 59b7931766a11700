"""Objects: superquadric maths against finite differences and exact cases; GP implicit surfaces on the
project's example shapes."""

import re

import numpy as np
import pandas as pd
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from grasptask.errors import BadInputError
from grasptask.objects import GPImplicitSurface, Superquadric, load_object

seeds = st.integers(0, 2**32 - 1)


def random_superquadric(seed):
    rng = np.random.default_rng(seed)
    exponents = [(0.1, 1.0), (1.0, 1.0), (0.2, 0.2), (0.5, 1.0)][seed % 4]
    return Superquadric(
        rng.uniform(0.01, 0.06, 3),
        *exponents,
        Rotation.random(random_state=seed).as_matrix(),
        rng.normal(size=3) * 0.05,
    )


@settings(max_examples=40, deadline=None)
@given(seeds)
def test_superquadric_gradient_matches_finite_differences(seed):
    sq = random_superquadric(seed)
    rng = np.random.default_rng(seed + 1)
    points = sq.position + (rng.normal(size=(5, 3)) * sq.a.max() * 0.8) @ sq.rotation.T
    step = 1e-7
    numeric = np.stack([(sq.g(points + step * e) - sq.g(points - step * e)) / (2 * step) for e in np.eye(3)], axis=1)
    np.testing.assert_allclose(sq.gradient(points), numeric, rtol=1e-4, atol=1e-6 * np.abs(numeric).max())


def test_sphere_radial_and_signed_distances_are_exact():
    sphere = Superquadric(np.full(3, 0.03), 1.0, 1.0, position=np.array([0.01, -0.02, 0.0]))
    rng = np.random.default_rng(0)
    directions = rng.normal(size=(200, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    radii = rng.uniform(0.005, 0.08, 200)
    points = sphere.position + directions * radii[:, None]
    np.testing.assert_allclose(sphere.radial_distance(points), radii - 0.03, atol=1e-12)
    np.testing.assert_allclose(sphere.signed_distance(points), radii - 0.03, atol=5e-5)
    np.testing.assert_allclose(sphere.normal(points), directions, atol=1e-12)


def test_tool_cylinder_signs_normals_and_euclidean_distance():
    tool = load_object("configs/objects/tool.yaml")
    inside, surface, outside = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.03], [0.015, 0.0, 0.09]])
    assert tool.g(inside[None])[0] < 0 and abs(tool.g(surface[None])[0]) < 1e-9 and tool.g(outside[None])[0] > 0
    np.testing.assert_allclose(tool.normal(surface[None])[0], [1, 0, 0], atol=1e-9)
    # radial distance runs along the ray from the centre; the verifier's signed distance is Euclidean
    assert tool.radial_distance(outside[None])[0] > 0.02
    assert tool.signed_distance(outside[None])[0] == pytest.approx(0.005, abs=1e-4)
    assert tool.signed_distance(np.array([[0.0, 0.0, 0.103]]))[0] == pytest.approx(0.003, abs=1e-4)


@pytest.mark.parametrize("offset", [0.0, 2e-4])
def test_closest_point_is_exact_on_the_tool_rims(offset):
    """On the rims of the tool's end caps the surface turns through 90 degrees within about a millimetre,
    less than two sample spacings: the closest point of a point just off the rim must still be its foot."""
    tool = load_object("configs/objects/tool.yaml")
    rng = np.random.default_rng(1)
    azimuth, z = rng.uniform(0, 2 * np.pi, 300), rng.uniform(0.095, 0.1, 300) * rng.choice([-1, 1], 300)
    rim = tool.project(np.stack([0.0105 * np.cos(azimuth), 0.0105 * np.sin(azimuth), z], axis=1), iterations=50)
    assert np.abs(tool.g(rim)).max() < 1e-9
    normal = tool.normal(rim)
    points = rim + offset * normal
    closest, closest_normal = tool.closest_point(points)
    np.testing.assert_allclose(closest, rim, atol=1e-8)
    np.testing.assert_allclose(tool.signed_distance(points), offset, atol=1e-8)
    assert np.degrees(np.arccos(np.clip((closest_normal * normal).sum(axis=1), -1, 1))).max() < 1e-3


@pytest.mark.parametrize("name", ["tool", "sphere", "box", "ellipsoid"])
def test_superquadric_presets_load_and_contain_their_centre(name):
    obj = load_object(f"configs/objects/{name}.yaml")
    assert obj.g(obj.centre[None])[0] < 0
    assert np.abs(obj.g(obj.surface.points)).max() < 1e-6


@pytest.fixture(scope="module", params=["mug", "spray_bottle"])
def gp_object(request):
    return request.param, load_object(f"configs/objects/{request.param}_gp.yaml")


def test_gp_surface_is_within_a_millimetre_on_held_out_points(gp_object):
    name, obj = gp_object
    mesh = trimesh.load(f"data/objects/{name}_coarse.stl")
    held_out, _ = trimesh.sample.sample_surface(mesh, 2000, seed=12345)
    assert np.abs(obj.margin(held_out)).max() <= 1e-3


def test_gp_is_negative_inside_and_positive_outside(gp_object):
    name, obj = gp_object
    mesh = trimesh.load(f"data/objects/{name}_coarse.stl")
    rng = np.random.default_rng(7)
    points = rng.uniform(mesh.bounds[0] - 0.03, mesh.bounds[1] + 0.03, (5000, 3))
    depth = trimesh.proximity.signed_distance(mesh, points)  # trimesh: positive inside
    clear = np.abs(depth) > 2e-3
    inside = mesh.contains(points)
    assert clear.sum() > 4000 and inside[clear].sum() > 300
    np.testing.assert_array_equal(obj.g(points[clear]) < 0, inside[clear])
    far = mesh.centroid + rng.normal(size=(500, 3)) * 0.3
    assert (obj.g(far) > 0).all()


def test_gp_gradient_matches_finite_differences(gp_object):
    name, obj = gp_object
    points = trimesh.sample.sample_surface(trimesh.load(f"data/objects/{name}_coarse.stl"), 20, seed=3)[0] + 0.003
    step = 1e-6
    numeric = np.stack([(obj.g(points + step * e) - obj.g(points - step * e)) / (2 * step) for e in np.eye(3)], axis=1)
    np.testing.assert_allclose(obj.gradient(points), numeric, atol=2e-6)


def test_gp_from_a_point_csv(tmp_path):
    rng = np.random.default_rng(0)
    normals = rng.normal(size=(1500, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    points = normals * [0.04, 0.03, 0.02]  # an ellipsoid: its outward normals are not the radial directions
    outward = points / np.array([0.04, 0.03, 0.02]) ** 2
    outward /= np.linalg.norm(outward, axis=1, keepdims=True)
    pd.DataFrame(np.hstack([points, outward]), columns=["x", "y", "z", "nx", "ny", "nz"]).to_csv(tmp_path / "e.csv")
    (tmp_path / "e.yaml").write_text("type: gp\nname: egg\npoints_csv: e.csv\nn_support: 150\nmax_support: 300\n")
    obj = load_object(tmp_path / "e.yaml")
    assert isinstance(obj, GPImplicitSurface)
    truth = Superquadric(np.array([0.04, 0.03, 0.02]), 1.0, 1.0)
    check = truth.surface.points[::97]
    assert np.abs(obj.margin(check)).max() < 1e-3
    assert obj.g(np.zeros((1, 3)))[0] < 0 and obj.g(np.array([[0.0, 0.0, 0.05]]))[0] > 0


def test_bad_object_configs(tmp_path):
    (tmp_path / "a.yaml").write_text("type: cone\n")
    with pytest.raises(BadInputError, match="unknown object type"):
        load_object(tmp_path / "a.yaml")
    (tmp_path / "b.yaml").write_text("type: gp\nmesh: missing.stl\n")
    with pytest.raises(BadInputError, match="mesh file not found"):
        load_object(tmp_path / "b.yaml")
    (tmp_path / "c.yaml").write_text("type: superquadric\nsize_m: [0.01, -1, 0.1]\nexponents: [1, 1]\n")
    with pytest.raises(BadInputError, match=re.escape("field 'size_m[2]': must be greater than or equal to 0.001")):
        load_object(tmp_path / "c.yaml")


def test_a_loaded_object_carries_its_symmetry(tmp_path):
    assert load_object("configs/objects/tool.yaml").symmetry == {"rotation_axis": "z", "flip_axis": "z"}
    assert load_object("configs/objects/box.yaml").symmetry is None
    (tmp_path / "s.yaml").write_text(
        "type: superquadric\nsize_m: [0.01, 0.01, 0.1]\nexponents: [1, 1]\nsymmetry: {rotation_axis: y}\n"
    )
    with pytest.raises(BadInputError, match="symmetry.rotation_axis"):
        load_object(tmp_path / "s.yaml")
