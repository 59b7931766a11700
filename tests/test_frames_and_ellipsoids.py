"""Wrench frame transformation, ellipsoid axes and the paper-table statistics."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from grasptask.task.ellipsoid import Ellipsoid, block_extents, block_lengths, principal_axes, second_moment
from grasptask.task.frames import transform_wrenches, wrench_transform
from grasptask.task.stats import group_statistics

seeds = st.integers(0, 2**32 - 1)


@given(seeds)
def test_transform_matches_a_point_force_taken_about_each_origin(seed):
    """A force f applied at point c: its wrench about the sensor origin, transformed, equals the wrench about
    the object origin computed directly."""
    rng = np.random.default_rng(seed)
    rotation = Rotation.random(random_state=seed).as_matrix()
    position = rng.normal(size=3) * 0.1
    c_object, f_object = rng.normal(size=3) * 0.1, rng.normal(size=3)
    c_sensor = rotation.T @ (c_object - position)
    f_sensor = rotation.T @ f_object
    sensor_wrench = np.concatenate([f_sensor, np.cross(c_sensor, f_sensor)])
    object_wrench = transform_wrenches(sensor_wrench[None], rotation, position)[0]
    np.testing.assert_allclose(object_wrench, np.concatenate([f_object, np.cross(c_object, f_object)]), atol=1e-12)


@given(seeds)
def test_transform_composes_with_its_inverse(seed):
    rotation = Rotation.random(random_state=seed).as_matrix()
    position = np.random.default_rng(seed).normal(size=3)
    forward = wrench_transform(rotation, position)
    backward = wrench_transform(rotation.T, -rotation.T @ position)
    np.testing.assert_allclose(forward @ backward, np.eye(6), atol=1e-12)


@given(seeds)
def test_ellipsoid_axes_reconstruct_the_matrix_and_are_sorted(seed):
    rng = np.random.default_rng(seed)
    w = rng.standard_normal((500, 6)) * rng.uniform(0.01, 3, 6)
    e = Ellipsoid.from_wrenches(w)
    np.testing.assert_allclose((e.axes * e.lengths**2) @ e.axes.T, e.S, atol=1e-10)
    assert np.all(np.diff(e.lengths) <= 0)
    np.testing.assert_allclose(e.axes.T @ e.axes, np.eye(6), atol=1e-10)
    assert np.isclose(e.weights.sum(), 1.0)


def test_second_moment_counts_a_constant_pressing_force_and_centred_does_not():
    w = np.zeros((100, 6))
    w[:, 2] = 2.0
    w[::2, 0], w[1::2, 0] = 0.5, -0.5
    assert np.isclose(second_moment(w)[2, 2], 4.0)
    assert np.isclose(second_moment(w, centered=True)[2, 2], 0.0)
    lengths, axes = principal_axes(second_moment(w))
    np.testing.assert_allclose(lengths[:2], [2.0, 0.5])
    np.testing.assert_allclose(np.abs(axes[:, 0]), [0, 0, 1, 0, 0, 0], atol=1e-12)


@given(seeds)
def test_block_lengths_are_invariant_to_rotating_the_samples(seed):
    rng = np.random.default_rng(seed)
    w = rng.standard_normal((300, 6)) * rng.uniform(0.1, 2, 6)
    r = Rotation.random(random_state=seed).as_matrix()
    rotated = w @ np.kron(np.eye(2), r).T
    for block in (slice(0, 3), slice(3, 6)):
        np.testing.assert_allclose(block_lengths(second_moment(rotated), block), block_lengths(second_moment(w), block))


def test_group_statistics_on_a_known_ellipsoid():
    """Force half-widths 1, 2, 3 N along x, y, z; torques 0.01, 0.02, 0.04 N.m (1, 2, 4 N.cm)."""
    s = np.diag([1.0, 4.0, 9.0, 1e-4, 4e-4, 16e-4])
    stats = group_statistics(np.stack([s, s]))
    np.testing.assert_allclose(stats["force"]["mu"], [1, 2, 3])
    np.testing.assert_allclose(stats["force"]["mu_n"], [1 / 6, 2 / 6, 3 / 6])
    np.testing.assert_allclose(stats["force"]["sigma"], 0)
    np.testing.assert_allclose(stats["torque"]["mu"], [1, 2, 4])
    np.testing.assert_allclose(stats["torque"]["proj"], [1 / 7, 2 / 7, 4 / 7])
    np.testing.assert_allclose(block_extents(s, slice(0, 3)), [1, 2, 3])
