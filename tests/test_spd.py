"""Log-Euclidean maths: hypothesis properties of the SPD log, mean and distance."""

import numpy as np
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from grasptask.task.spd import log_euclidean_distance, log_euclidean_mean, log_vectors, spd_exp, spd_log

seeds = st.integers(0, 2**32 - 1)


def random_spd(rng, d=6, spread=3.0):
    q, _ = np.linalg.qr(rng.standard_normal((d, d)))
    return (q * np.exp(rng.uniform(-spread, spread, d))) @ q.T


@given(seeds)
def test_log_is_the_inverse_of_exp_and_matches_scipy(seed):
    s = random_spd(np.random.default_rng(seed))
    log = spd_log(s)
    np.testing.assert_allclose(log, log.T, atol=1e-12)
    np.testing.assert_allclose(spd_exp(log), s, rtol=1e-8, atol=1e-10 * np.abs(s).max())
    np.testing.assert_allclose(log, scipy.linalg.logm(s).real, atol=1e-7)


@given(seeds)
def test_log_vector_distance_is_the_frobenius_distance_of_logs(seed):
    rng = np.random.default_rng(seed)
    x, y = random_spd(rng), random_spd(rng)
    vx, vy = log_vectors(np.stack([x, y]))
    assert np.isclose(np.linalg.norm(vx - vy), np.linalg.norm(spd_log(x) - spd_log(y)))


@given(seeds)
def test_distance_is_invariant_to_a_rotation_of_the_wrench_frame(seed):
    """Rotating forces and torques together (a change of object frame orientation) keeps every distance."""
    rng = np.random.default_rng(seed)
    x, y = random_spd(rng), random_spd(rng)
    r = Rotation.random(random_state=seed).as_matrix()
    big = np.kron(np.eye(2), r)
    rotated = log_euclidean_distance(big @ x @ big.T, big @ y @ big.T)
    assert np.isclose(rotated, log_euclidean_distance(x, y), rtol=1e-7)


@given(seeds)
def test_distance_is_a_metric(seed):
    rng = np.random.default_rng(seed)
    x, y, z = (random_spd(rng) for _ in range(3))
    assert log_euclidean_distance(x, x) < 1e-9
    assert np.isclose(log_euclidean_distance(x, y), log_euclidean_distance(y, x))
    assert log_euclidean_distance(x, z) <= log_euclidean_distance(x, y) + log_euclidean_distance(y, z) + 1e-9


@settings(max_examples=30)
@given(seeds, st.integers(1, 6))
def test_mean_is_spd_and_of_identical_matrices_is_the_matrix(seed, k):
    rng = np.random.default_rng(seed)
    s = random_spd(rng)
    np.testing.assert_allclose(log_euclidean_mean(np.stack([s] * k)), s, rtol=1e-7, atol=1e-12)
    mixed = log_euclidean_mean(np.stack([random_spd(rng) for _ in range(k)]))
    np.testing.assert_allclose(mixed, mixed.T, atol=1e-10 * np.abs(mixed).max())
    assert np.linalg.eigvalsh(mixed).min() > 0


def test_mean_of_scalings_is_their_geometric_mean():
    s = random_spd(np.random.default_rng(1))
    np.testing.assert_allclose(log_euclidean_mean(np.stack([s * 2.0, s * 8.0])), s * 4.0, rtol=1e-9)


def test_log_rejects_a_singular_matrix():
    import pytest

    with pytest.raises(ValueError):
        spd_log(np.diag([1.0, 1, 1, 1, 1, 0]))
