"""MATLAB recordings as F/T studies publish them: a cell array of structs, one trial a cell, each trial 6 x n at a
rate the file holds as a variable; struct arrays; and the layouts refused in one line, naming the element."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from grasptask.errors import BadInputError
from grasptask.task.matlab import describe, read_variables
from grasptask.task.recordings import Layout, read_recording
from tests.conftest import wrench_samples
from tests.mat_files import cell, struct_array, write_mat

VERSIONS = ["v5", "v7.3"]


def trials(n: int = 4) -> list[np.ndarray]:
    """``n`` trials of different lengths at 100 Hz, as ``(k, 7)`` samples (time, then the wrench)."""
    return [wrench_samples(n=150 + 17 * k, seed=k) for k in range(n)]


def rawdata_ft(recorded: list[np.ndarray]) -> dict:
    """The first study's layout: ``rawdata_FT``, a 1 x n cell, each a struct of Hand_FT and Tool_FT, 6 x n at
    100 Hz without a time vector, and ``dt`` beside it."""
    structs = [{"Hand_FT": 2.0 * data[:, 1:].T, "Tool_FT": data[:, 1:].T} for data in recorded]
    return {"rawdata_FT": cell(*structs), "dt": 0.01}


def manifest(folder, rows: list[dict]):
    base = {"task": "screwing", "subject": "1", "grasp": "free"}
    pd.DataFrame([{**base, "trial": 1, **row} for row in rows]).to_csv(folder / "manifest.csv", index=False)
    return folder / "manifest.csv"


def fitted(folder) -> pd.DataFrame:
    return pd.read_parquet(folder / "ellipsoids.parquet")


def second_moment(data: np.ndarray) -> np.ndarray:
    return data[:, 1:].T @ data[:, 1:] / len(data)


@pytest.mark.parametrize("version", VERSIONS)
def test_a_cell_of_structs_is_one_manifest_row_of_every_trial(tmp_path, cli, version):
    recorded = trials(4)
    write_mat(tmp_path / "study.mat", rawdata_ft(recorded), version)
    (tmp_path / "ft.yaml").write_text("name: study\nmatlab: {samples: columns, period_s: dt}\n")
    rows = [{"path": "study.mat", "tool": "ft.yaml", "variable": "rawdata_FT{*}.Tool_FT", "trial": 3}]
    result = cli("fit-task", manifest(tmp_path, rows), "--out", tmp_path / "out")
    assert result.exit_code == 0, result.output
    table = fitted(tmp_path / "out")
    assert list(table["trial"]) == [3, 4, 5, 6]  # numbered as trials from the row's own
    assert list(table["id"]) == [f"screwing_free_s1_t{k}" for k in (3, 4, 5, 6)]
    for s, data in zip(table["S"], recorded, strict=True):
        np.testing.assert_allclose(np.reshape(s, (6, 6)), second_moment(data), rtol=1e-12)
    # the rate came from dt: each trial lasts (n - 1) / 100 s
    np.testing.assert_allclose(table["duration_s"], [(len(d) - 1) * 0.01 for d in recorded], atol=1e-12)


@pytest.mark.parametrize("version", VERSIONS)
def test_one_element_named_as_matlab_does(tmp_path, version):
    recorded = trials(3)
    write_mat(tmp_path / "study.mat", rawdata_ft(recorded), version)
    for text in ("rawdata_FT{2}.Hand_FT", "rawdata_FT(2).Hand_FT", "rawdata_FT{1,2}.Hand_FT"):
        data = read_recording(tmp_path / "study.mat", Layout(variable=text, period_from="dt"))
        np.testing.assert_allclose(data[:, 1:], 2.0 * recorded[1][:, 1:], rtol=1e-12)
        np.testing.assert_allclose(data[:, 0], recorded[1][:, 0], atol=1e-12)


@pytest.mark.parametrize("version", VERSIONS)
def test_the_listing_descends_into_cells_and_structs(tmp_path, version):
    write_mat(tmp_path / "study.mat", rawdata_ft(trials(3)), version)
    line = describe(read_variables(tmp_path / "study.mat"))
    assert "rawdata_FT 1x3 cell of struct {Hand_FT 6x(150-184) double, Tool_FT 6x(150-184) double}" in line
    assert "dt 1x1 double" in line
    with pytest.raises(BadInputError) as caught:
        read_recording(tmp_path / "study.mat")
    assert "rawdata_FT 1x3 cell of struct" in str(caught.value) and "\n" not in str(caught.value)


@pytest.mark.parametrize("version", VERSIONS)
def test_a_cell_of_structs_with_their_own_period_and_a_struct_array(tmp_path, cli, version):
    """The second study's layout: proc_data, a cell of structs {name, dt, X, ...}, each trial its own dt; and a
    struct array, data(k).ft."""
    recorded = trials(3)
    procs = [
        {"name": f"trial {k}", "dt": 0.01 * (k + 1), "X": d[:, 1:].T, "J": np.eye(3)} for k, d in enumerate(recorded)
    ]
    variables = {"proc_data": cell(*procs), "dt": 0.01, "data": struct_array([{"ft": d} for d in recorded])}
    write_mat(tmp_path / "proc.mat", variables, version)
    (tmp_path / "proc.yaml").write_text(
        "name: proc\nmatlab: {variable: 'proc_data{*}.X', period_s: 'proc_data{*}.dt'}\n"
    )
    (tmp_path / "arr.yaml").write_text("name: arr\nmatlab: {wrench: [2, 3, 4, 5, 6, 7], time: 1}\n")
    rows = [
        {"path": "proc.mat", "tool": "proc.yaml"},
        {"path": "proc.mat", "tool": "arr.yaml", "variable": "data(*).ft", "subject": "2"},
    ]
    result = cli("fit-task", manifest(tmp_path, rows), "--out", tmp_path / "out")
    assert result.exit_code == 0, result.output
    table = fitted(tmp_path / "out")
    assert len(table) == 6
    for s, data in zip(table["S"], recorded + recorded, strict=True):
        np.testing.assert_allclose(np.reshape(s, (6, 6)), second_moment(data), rtol=1e-12)
    durations = [(len(d) - 1) * 0.01 * (k + 1) for k, d in enumerate(recorded)]
    np.testing.assert_allclose(table["duration_s"][:3], durations, atol=1e-9)


def _refused(cli, folder, rows, *expected):
    result = cli("fit-task", manifest(folder, rows), "--out", folder / "out")
    assert result.exit_code == 2, result.output
    line = result.output.strip()
    assert "\n" not in line and line.startswith("error:"), line
    for text in expected:
        assert text in line, line
    assert not (folder / "out").exists() or not any((folder / "out").iterdir())


@pytest.mark.parametrize("version", VERSIONS)
def test_bad_layouts_are_one_line_naming_the_element(tmp_path, cli, version):
    recorded = trials(3)
    structs = [{"Hand_FT": d[:, 1:].T, "Tool_FT": d[:, 1:].T} for d in recorded]
    structs[2] = {"Hand_FT": recorded[2][:, 1:4].T, "Tool_FT": recorded[2][:, 1:4].T}  # 3 channels, not 6
    variables = {
        "mixed": cell(*structs),
        "holey": cell(structs[0], np.zeros((0, 0)), structs[1]),
        "good": cell(*structs[:2]),
        "cpx": recorded[0][:, 1:].T * (1 + 1j),
        "empty": np.zeros((7, 0)),
        "single": recorded[0][:1].T,  # one sample, 7 x 1
        "dt": 0.01,
    }
    write_mat(tmp_path / "bad.mat", variables, version)
    (tmp_path / "t.yaml").write_text("name: t\nmatlab: {period_s: dt}\n")
    (tmp_path / "t7.yaml").write_text("name: t7\nmatlab: {wrench: [2, 3, 4, 5, 6, 7], time: 1}\n")
    row = {"path": "bad.mat", "tool": "t.yaml"}
    _refused(cli, tmp_path, [{**row, "variable": "good{3}.Tool_FT"}], "good is 1x2, so it has no element 3 (1 to 2)")
    _refused(
        cli,
        tmp_path,
        [{**row, "variable": "mixed{*}.Tool_FT"}],
        "'mixed{3}.Tool_FT' is 3x",
        "unlike 'mixed{1}.Tool_FT'",
    )
    _refused(cli, tmp_path, [{**row, "variable": "holey{*}.Tool_FT"}], "holey{2} is empty (0x0 double)")
    _refused(cli, tmp_path, [{**row, "variable": "good{*}.Force"}], "has no field 'Force' (it has: Hand_FT, Tool_FT)")
    _refused(
        cli, tmp_path, [{**row, "variable": "cpx"}], "'cpx' is 6x150 complex double: a force/torque recording is real"
    )
    _refused(cli, tmp_path, [{**row, "variable": "good{*}{*}"}], "2 wildcards")
    _refused(
        cli, tmp_path, [{**row, "tool": "t7.yaml", "variable": "empty"}], "'empty' is 7x0 double: it holds 0 samples"
    )
    _refused(cli, tmp_path, [{**row, "tool": "t7.yaml", "variable": "single"}], "only 1 sample (at least 10")
    (tmp_path / "rate.yaml").write_text("name: r\nmatlab: {rate_hz: good}\n")
    _refused(cli, tmp_path, [{**row, "tool": "rate.yaml", "variable": "good{1}.Tool_FT"}], "'good' is 1x2 cell")
