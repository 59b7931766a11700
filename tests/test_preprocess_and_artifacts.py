"""Preprocessing, atomic artifacts with provenance, and the distance computation against brute force."""

import json

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from grasptask.errors import BadInputError
from grasptask.io.artifacts import Provenance, StagedOutput
from grasptask.task import preprocess
from grasptask.task.distances import (
    compute_distances,
    embedding_2d,
    embedding_from_distances,
    loo_1nn_accuracy,
    read_distances,
)
from tests.test_spd import random_spd


def test_bias_removal_subtracts_the_static_window_and_drops_it():
    t = np.arange(1000) / 500.0
    wrenches = np.zeros((1000, 6)) + [0.3, -0.2, 1.0, 0.01, 0.0, -0.02]
    wrenches[t >= 0.5, 2] += 2.0
    kept_t, kept = preprocess.remove_bias(t, wrenches, 0.5)
    assert kept_t[0] >= 0.5
    np.testing.assert_allclose(kept, np.tile([0, 0, 2.0, 0, 0, 0], (len(kept), 1)), atol=1e-12)


def test_lowpass_keeps_slow_motion_and_removes_fast_noise():
    t = np.arange(5000) / 1000.0
    slow = np.sin(2 * np.pi * 1.0 * t)
    fast = 0.5 * np.sin(2 * np.pi * 200.0 * t)
    filtered = preprocess.lowpass(t, np.column_stack([slow + fast] * 6), cutoff_hz=20.0)
    assert np.abs(filtered[100:-100, 0] - slow[100:-100]).max() < 0.01


def test_lowpass_rejects_a_cutoff_above_nyquist():
    t = np.arange(100) / 100.0
    with pytest.raises(ValueError, match="Nyquist"):
        preprocess.lowpass(t, np.zeros((100, 6)), cutoff_hz=60.0)


def test_staged_output_writes_nothing_when_the_command_fails(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(RuntimeError):
        with StagedOutput(out, Provenance.of("test", {})) as staged:
            staged.write_csv("a.csv", pd.DataFrame({"x": [1]}))
            raise RuntimeError("boom")
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_artifacts_carry_provenance(tmp_path):
    source = tmp_path / "input.txt"
    source.write_text("hello")
    provenance = Provenance.of("test", {"a": 1}, [source], seed=7)
    with StagedOutput(tmp_path / "out", provenance) as staged:
        staged.write_parquet("t.parquet", pd.DataFrame({"x": [1.0]}))
        staged.write_json("m.json", {"value": 1})
        staged.write_csv("s.csv", pd.DataFrame({"x": [1]}))
    recorded = json.loads(pq.read_schema(tmp_path / "out" / "t.parquet").metadata[b"grasptask.provenance"])
    assert recorded["seed"] == 7 and recorded["inputs"][str(source)] == provenance.inputs[str(source)]
    assert json.loads((tmp_path / "out" / "m.json").read_text())["provenance"]["config_hash"] == provenance.config_hash
    ledger = json.loads((tmp_path / "out" / "provenance.json").read_text())
    assert set(ledger) == {"t.parquet", "m.json", "s.csv"}
    assert ledger["s.csv"]["version"]


def _ellipsoid_table(matrices):
    k = len(matrices)
    half = ["a"] * (k // 2) + ["b"] * (k - k // 2)
    return pd.DataFrame(
        {
            "id": [f"e{i}" for i in range(k)],
            "task": half,
            "grasp": "free",
            "group": half,
            "subject": "1",
            "trial": range(k),
            "S": [m.ravel() for m in matrices],
        }
    )


def test_distance_matrix_matches_pairwise_scipy_logm():
    rng = np.random.default_rng(0)
    matrices = [random_spd(rng) for _ in range(6)]
    distances = compute_distances(_ellipsoid_table(matrices))
    for i in range(6):
        for j in range(6):
            expected = np.linalg.norm(scipy.linalg.logm(matrices[i]).real - scipy.linalg.logm(matrices[j]).real)
            assert np.isclose(distances.raw[i, j], expected, rtol=1e-7, atol=1e-9)
    long = distances.long_table()
    assert len(long) == 36 and np.isclose(long["distance_normalised"].max(), 1.0)


def test_loo_1nn_accuracy_on_a_known_layout():
    # 2.0 (a) and 2.4 (b) are each other's nearest neighbours, so both are misclassified
    points = np.array([0.0, 1.0, 2.0, 10.0, 11.0, 2.4])
    distances = np.abs(points[:, None] - points[None, :])
    labels = np.array(["a", "a", "a", "b", "b", "b"])
    assert loo_1nn_accuracy(distances, labels) == pytest.approx(4 / 6)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(3, 12))
def test_embedding_from_the_distances_alone_is_the_embedding_of_the_matrices(seed, k):
    """Classical MDS of the Log-Euclidean distances gives the PCA coordinates of the matrix logs, so the report
    can draw the embedding from distances.parquet without the matrices."""
    rng = np.random.default_rng(seed)
    matrices = np.stack([random_spd(rng) for _ in range(k)])
    distances = compute_distances(_ellipsoid_table(list(matrices)))
    direct = embedding_2d(matrices[[int(i[1:]) for i in distances.table["id"]]])
    np.testing.assert_allclose(embedding_from_distances(distances.raw), direct, atol=1e-8 * np.abs(direct).max())


def test_distances_read_back_from_their_table(tmp_path):
    rng = np.random.default_rng(1)
    table = _ellipsoid_table([random_spd(rng) for _ in range(6)])
    distances = compute_distances(table)
    path = tmp_path / "distances.parquet"
    distances.long_table().to_parquet(path)
    again = read_distances(path, table)
    assert list(again.table["id"]) == list(distances.table["id"])
    np.testing.assert_array_equal(again.raw, distances.raw)
    np.testing.assert_allclose(again.embedding, distances.embedding, atol=1e-9)
    distances.long_table().iloc[:-1].to_parquet(path)
    with pytest.raises(BadInputError, match="6 x 6 distances"):
        read_distances(path, table)
