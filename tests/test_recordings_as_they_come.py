"""Recordings as labs publish them: MATLAB files (v5 and v7.3, the wrench in rows or in columns, inside structs),
logs with many more columns than the wrench, files without time stamps, trials cut from one log; and what
fit-task says of recordings it fits all the same."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import scipy.io

from grasptask.errors import BadInputError
from grasptask.task.recordings import Layout, read_recording
from tests.conftest import wrench_samples
from tests.mat_files import write_mat73


def write_tool(path, text: str) -> None:
    path.write_text("name: lab_tool\n" + text)


def manifest(folder, rows: list[dict], name: str = "manifest.csv"):
    base = {"task": "wiping", "subject": "1", "grasp": "free"}
    frame = pd.DataFrame([{**base, "trial": k + 1, **row} for k, row in enumerate(rows)])
    frame.to_csv(folder / name, index=False)
    return folder / name


def ellipsoids(folder) -> list[np.ndarray]:
    table = pd.read_parquet(folder / "ellipsoids.parquet")
    return [np.reshape(s, (6, 6)) for s in table["S"]]


# --- MATLAB files ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("version", ["v5", "v7.3"])
@pytest.mark.parametrize("samples", ["rows", "columns"])
def test_a_mat_file_loads_as_the_csv_it_was_made_from(tmp_path, cli, version, samples):
    data = wrench_samples(n=300, seed=3)
    pd.DataFrame(data, columns=["t", "fx", "fy", "fz", "tx", "ty", "tz"]).to_csv(tmp_path / "trial.csv", index=False)
    # the lab's layout: a struct with the time in channel 1 of a 7-channel matrix, samples along rows or columns
    matrix = data if samples == "rows" else data.T
    variables = {"session": {"ft": matrix, "operator": "A. N. Other"}, "fs": 100.0}
    if version == "v5":
        scipy.io.savemat(tmp_path / "trial.mat", variables)
    else:
        write_mat73(tmp_path / "trial.mat", variables)
    layout = f"matlab: {{variable: session.ft, samples: {samples}, wrench: [2, 3, 4, 5, 6, 7], time: 1}}\n"
    write_tool(tmp_path / "lab.yaml", layout)
    manifest(tmp_path, [{"path": "trial.mat", "tool": "lab.yaml"}], "mat.csv")
    manifest(tmp_path, [{"path": "trial.csv"}], "csv.csv")
    for name in ("mat", "csv"):
        result = cli("fit-task", tmp_path / f"{name}.csv", "--out", tmp_path / name)
        assert result.exit_code == 0, result.output
    np.testing.assert_allclose(ellipsoids(tmp_path / "mat")[0], ellipsoids(tmp_path / "csv")[0], rtol=1e-12)


def test_a_mat_file_of_one_vector_per_channel_and_a_sample_rate(tmp_path):
    """Another common layout: a vector per channel (here as rows, 1 x n) and no time, only the rate."""
    data = wrench_samples(n=250, seed=4, rate=250.0)
    names = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
    scipy.io.savemat(tmp_path / "log.mat", {n: data[:, k + 1][None, :] for k, n in enumerate(names)})
    layout = Layout(columns=dict(zip(("fx", "fy", "fz", "tx", "ty", "tz"), names, strict=True)), rate_hz=250.0)
    np.testing.assert_allclose(read_recording(tmp_path / "log.mat", layout), data, atol=1e-12)


@pytest.mark.parametrize("version", ["v5", "v7.3"])
def test_a_mat_layout_not_said_lists_the_variables_with_their_shapes(tmp_path, version):
    variables = {"ft": wrench_samples(n=120), "info": {"rate": 100.0}}
    if version == "v5":
        scipy.io.savemat(tmp_path / "log.mat", variables)
    else:
        write_mat73(tmp_path / "log.mat", variables)
    with pytest.raises(BadInputError) as caught:
        read_recording(tmp_path / "log.mat")
    line = str(caught.value)
    assert "log.mat" in line and "ft 120x7 double" in line and "info struct {rate 1x1 double}" in line
    assert "matlab: {variable:" in line and "\n" not in line
    with pytest.raises(BadInputError, match="say whether its samples are rows or columns"):
        scipy.io.savemat(tmp_path / "square.mat", {"ft": np.eye(7)})
        read_recording(tmp_path / "square.mat", Layout(variable="ft", time=7))


def test_the_manifest_names_each_trials_variable_of_one_mat_file(tmp_path, cli):
    trials = {f"trial{k}": wrench_samples(n=200, seed=k) for k in range(1, 4)}
    scipy.io.savemat(tmp_path / "all.mat", trials)
    write_tool(tmp_path / "lab.yaml", "matlab: {wrench: [2, 3, 4, 5, 6, 7], time: 1}\n")
    rows = [{"path": "all.mat", "tool": "lab.yaml", "variable": name} for name in trials]
    assert cli("fit-task", manifest(tmp_path, rows), "--out", tmp_path / "out").exit_code == 0
    for fitted, data in zip(ellipsoids(tmp_path / "out"), trials.values(), strict=True):
        np.testing.assert_allclose(fitted, data[:, 1:].T @ data[:, 1:] / len(data), rtol=1e-12)


# --- columns as they come ----------------------------------------------------------------------------------------


def robot_log(data: np.ndarray, extra: int = 24) -> pd.DataFrame:
    """A robot's log: joint states and the like around the wrench, 31 columns in all."""
    rng = np.random.default_rng(0)
    frame = {f"q{k}": rng.standard_normal(len(data)) for k in range(extra)}
    frame.update({"stamp": data[:, 0], "Fx": data[:, 1], "Fy": data[:, 2], "Fz": data[:, 3]})
    frame.update({"Tx": data[:, 4], "Ty": data[:, 5], "Tz": data[:, 6]})
    return pd.DataFrame(frame)


MAPPED = "columns: {t: stamp, fx: Fx, fy: Fy, fz: Fz, tx: Tx, ty: Ty, tz: Tz}\n"


def test_ignore_columns_rest_takes_the_wrench_and_leaves_the_rest(tmp_path):
    data = wrench_samples(n=150)
    robot_log(data).to_csv(tmp_path / "kuka.csv", index=False)
    assert robot_log(data).shape[1] == 31
    write_tool(tmp_path / "kuka.yaml", MAPPED + "ignore_columns: rest\n")
    from grasptask.task.tool import load_tool

    np.testing.assert_allclose(read_recording(tmp_path / "kuka.csv", load_tool(tmp_path / "kuka.yaml").layout), data)
    with pytest.raises(BadInputError, match="ignore_columns .*'rest'"):
        write_tool(tmp_path / "kuka.yaml", MAPPED)
        read_recording(tmp_path / "kuka.csv", load_tool(tmp_path / "kuka.yaml").layout)


def test_a_missing_time_column_lists_the_files_columns_and_the_settings(tmp_path):
    data = wrench_samples(n=150)
    log = robot_log(data, extra=2).drop(columns="stamp")
    log.to_csv(tmp_path / "log.csv", index=False)
    layout = Layout(columns={"fx": "Fx", "fy": "Fy", "fz": "Fz", "tx": "Tx", "ty": "Ty", "tz": "Tz"}, ignore="rest")
    with pytest.raises(BadInputError) as caught:
        read_recording(tmp_path / "log.csv", layout)
    line = str(caught.value)
    assert "column 't': missing column (the file has: q0, q1, Fx, Fy, Fz, Tx, Ty, Tz)" in line
    assert "columns: {t: COLUMN}" in line and "rate_hz" in line
    # a sample rate stands in for the time column
    rated = read_recording(tmp_path / "log.csv", Layout(**{**layout.__dict__, "rate_hz": 100.0}))
    np.testing.assert_allclose(rated, data, atol=1e-12)


# --- trials from one log -----------------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_one_log_cut_into_three_trials_fits_as_three_files_cut_by_hand(tmp_path, cli, suffix):
    data = wrench_samples(n=1200, seed=7)  # 12 s at 100 Hz
    table = pd.DataFrame(data, columns=["t", "fx", "fy", "fz", "tx", "ty", "tz"]).assign(t=data[:, 0] + 100.0)
    getattr(table, "to_csv" if suffix == ".csv" else "to_parquet")(tmp_path / f"log{suffix}", index=False)
    windows = [(0.5, 3.5), (4.0, 7.25), (8.0, None)]
    rows = [{"path": f"log{suffix}", "start_s": a, "end_s": b} for a, b in windows]
    assert cli("fit-task", manifest(tmp_path, rows, "cut.csv"), "--out", tmp_path / "cut").exit_code == 0
    by_hand = []
    for k, (a, b) in enumerate(windows):
        since = table["t"] - table["t"].iloc[0]
        keep = (since >= a) & (since <= (b if b is not None else np.inf))
        table[keep].to_csv(tmp_path / f"part{k}.csv", index=False)
        by_hand.append({"path": f"part{k}.csv"})
    assert cli("fit-task", manifest(tmp_path, by_hand, "hand.csv"), "--out", tmp_path / "hand").exit_code == 0
    cut, hand = ellipsoids(tmp_path / "cut"), ellipsoids(tmp_path / "hand")
    assert len(cut) == 3
    for a, b in zip(cut, hand, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12)
    durations = pd.read_parquet(tmp_path / "cut" / "ellipsoids.parquet")["duration_s"]
    np.testing.assert_allclose(durations, [3.0, 3.25, 3.99], atol=1e-9)


def test_a_window_beyond_the_recording_is_one_line(tmp_path, cli):
    pd.DataFrame(wrench_samples(n=200), columns=["t", "fx", "fy", "fz", "tx", "ty", "tz"]).to_csv(
        tmp_path / "log.csv", index=False
    )
    result = cli("fit-task", manifest(tmp_path, [{"path": "log.csv", "start_s": 5}]), "--out", tmp_path / "o")
    assert result.exit_code == 2
    assert "no samples in the window 5.0 .. None s (the recording spans 0 .. 1.99 s)" in result.output
    assert not (tmp_path / "o" / "ellipsoids.parquet").exists()
    narrow = cli(
        "fit-task", manifest(tmp_path, [{"path": "log.csv", "start_s": 1.0, "end_s": 1.005}]), "--out", tmp_path / "o"
    )
    assert narrow.exit_code == 2 and "row 1: only 1 samples in its time window (at least 10)" in narrow.output


# --- said, not silent --------------------------------------------------------------------------------------------


def wiping(t: np.ndarray, seed: int = 1) -> np.ndarray:
    """A wiping stroke as a hand-held sensorized sponge records it: N and N.m, noise included."""
    rng = np.random.default_rng(seed)
    phase = 2 * np.pi * 0.8 * t
    force = np.column_stack([4 * np.sin(phase), 2 * np.cos(phase), -8 + 2 * np.sin(2 * np.pi * 0.3 * t)])
    torque = np.column_stack([0.1 * np.sin(phase), 0.15 * np.cos(phase), 0.02 * np.sin(t)])
    noise = rng.normal(0, 1, (len(t), 6)) * [0.3, 0.3, 0.3, 0.005, 0.005, 0.005]
    return np.column_stack([t, np.column_stack([force, torque]) + noise])


def hostile_recordings() -> dict[str, np.ndarray]:
    """The issue's implausible inputs, each a wiping recording with one thing wrong."""
    t = np.arange(800) / 100.0
    clean = wiping(t)
    torques = clean.copy()
    torques[:, 4:] *= 1000  # N.mm logged, N.m declared
    spike = clean.copy()
    spike[400:411, 3] = -5000.0  # an 11-sample glitch
    short = wiping(np.arange(40) / 100.0)
    uneven = wiping(np.cumsum(np.random.default_rng(2).uniform(0.018, 0.153, 400)))
    offset = clean.copy()
    offset[:, 1:4] *= 0.05
    offset[:, 3] += -24.7  # an untared sensor under the tool's weight
    return {"clean": clean, "torques": torques, "spike": spike, "short": short, "uneven": uneven, "offset": offset}


EXPECTED = {
    "torques": ("implausible", "torque up to", "in N.mm it would be"),
    "spike": ("spikes", "11 samples far off the rest (rows 401-411), up to fz = -5000 N", "--drop-spikes"),
    "short": ("short", "0.39 s, under the 1 s", "plausible.min_duration_s"),
    "uneven": ("uneven sampling", "intervals 18", "--resample"),
    "offset": ("offset", "fz has a mean of -25.1 N", "--bias-window"),
}


def test_each_implausible_input_is_said_once_and_a_clean_one_not_at_all(tmp_path, cli):
    recordings = hostile_recordings()
    for name, data in recordings.items():
        table = pd.DataFrame(data, columns=["t", "fx", "fy", "fz", "tx", "ty", "tz"]).assign(status=0)
        table.to_csv(tmp_path / f"{name}.csv", index=False)
    write_tool(tmp_path / "sponge.yaml", "ignore_columns: rest\n")
    rows = [{"path": f"{name}.csv", "id": name, "tool": "sponge.yaml"} for name in recordings]
    result = cli("fit-task", manifest(tmp_path, rows), "--out", tmp_path / "out")
    assert result.exit_code == 0, result.output
    said = [line for line in result.output.splitlines() if line.startswith("check: ")]
    findings = json.loads((tmp_path / "out" / "task_models.json").read_text())["findings"]
    assert not [f for f in findings if f["id"] == "clean"]
    for name, (check, *words) in EXPECTED.items():
        mine = [f for f in findings if f["id"] == name and f["check"] == check]
        assert len(mine) == 1, (name, findings)
        assert all(w in mine[0]["message"] for w in words), mine[0]["message"]
        assert sum(f"({name}): {check}" in line for line in said) == 1
        assert f"{name}.csv" in mine[0]["file"]
    assert len({(f["id"], f["check"]) for f in findings}) == len(findings)  # once each


def test_the_simulators_recordings_raise_no_finding(simulated):
    _, fitted, _ = simulated
    assert fitted.findings == []
    models = json.loads((simulated[0] / "tasks" / "task_models.json").read_text())
    assert models["findings"] == []


def test_the_offset_is_said_and_the_bias_window_takes_it_away(tmp_path, cli):
    t = np.arange(1500) / 100.0
    data = wiping(t)
    data[:, 1:4] *= 0.05
    data[:, 3] -= 24.7
    data[:50, 1:] = np.random.default_rng(3).normal(0, 0.01, (50, 6)) + [0, 0, -24.7, 0, 0, 0]  # contact-free start
    pd.DataFrame(data, columns=["t", "fx", "fy", "fz", "tx", "ty", "tz"]).to_csv(tmp_path / "screw.csv", index=False)
    path = manifest(tmp_path, [{"path": "screw.csv"}])
    raw = cli("fit-task", path, "--out", tmp_path / "raw")
    tared = cli("fit-task", path, "--out", tmp_path / "tared", "--bias-window", "0.5")
    assert "offset dominates: fz has a mean of -25.1 N" in raw.output
    assert "offset dominates" not in tared.output
    longest = [json.loads((tmp_path / f / "task_models.json").read_text())["tasks"]["wiping"]["lengths"][0]
               for f in ("raw", "tared")]  # fmt: skip
    assert longest[0] > 20 and longest[1] < 1


def test_drop_spikes_leaves_out_the_rows_it_names(tmp_path, cli):
    data = hostile_recordings()["spike"]
    pd.DataFrame(data, columns=["t", "fx", "fy", "fz", "tx", "ty", "tz"]).to_csv(tmp_path / "spike.csv", index=False)
    result = cli("fit-task", manifest(tmp_path, [{"path": "spike.csv"}]), "--out", tmp_path / "out", "--drop-spikes")
    assert "left out, as asked (--drop-spikes)" in result.output
    kept = np.delete(data, np.arange(400, 411), axis=0)[:, 1:]
    np.testing.assert_allclose(ellipsoids(tmp_path / "out")[0], kept.T @ kept / len(kept), rtol=1e-12)


def test_resample_puts_an_uneven_recording_on_an_even_grid(tmp_path, cli):
    data = hostile_recordings()["uneven"]
    pd.DataFrame(data, columns=["t", "fx", "fy", "fz", "tx", "ty", "tz"]).to_csv(tmp_path / "u.csv", index=False)
    path = manifest(tmp_path, [{"path": "u.csv"}])
    result = cli("fit-task", path, "--out", tmp_path / "out", "--resample", "50", "--lowpass", "5")
    assert result.exit_code == 0, result.output
    assert "resampled to 50 Hz as asked" in result.output
    table = pd.read_parquet(tmp_path / "out" / "ellipsoids.parquet")
    span = data[-1, 0] - data[0, 0]
    assert table["n_samples"].iloc[0] == int(np.floor(span * 50 + 1e-9)) + 1
    plain = cli("fit-task", path, "--out", tmp_path / "plain", "--lowpass", "5")
    assert "--lowpass 5 assumes even sampling" in plain.output


# --- which task is like which ------------------------------------------------------------------------------------


def test_distances_say_each_tasks_nearest_and_how_torque_weighs(simulated, cli, tmp_path):
    root, _, _ = simulated
    result = cli("distances", root / "tasks" / "ellipsoids.parquet", "--out", tmp_path)
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "distance_summary.json").read_text())["tasks"]
    assert summary["names"] == ["drawing", "cutting", "screwdriving"]
    distances = np.array(summary["distances"])
    np.testing.assert_allclose(distances, distances.T)
    for k, task in enumerate(summary["names"]):
        others = [j for j in range(3) if j != k]
        nearest = summary["names"][min(others, key=lambda j: distances[k, j])]
        assert summary["nearest"][task]["task"] == nearest
        distance = distances[k, summary["names"].index(nearest)]
        assert f"nearest task: {task} -> {nearest}, Log-Euclidean distance {distance:.3g}" in result.output
    # the simulator's tools: torques of a few percent of the forces, and a unit that barely moves the distances
    assert all(0.001 < r < 0.2 for r in summary["torque_to_force"].values())
    assert 0 <= summary["change_with_torque_in_Ncm"] < 0.1
    assert "weighed in SI units, N against N.m" in result.output


def test_the_report_finds_task_models_wherever_fit_task_wrote_them(simulated, cli, tmp_path):
    root, _, _ = simulated
    deep = tmp_path / "out" / "all"
    deep.mkdir(parents=True)
    for name in ("task_models.json", "ellipsoids.parquet", "stats.csv", "distances.parquet", "distance_summary.json"):
        (deep / name).write_bytes((root / "tasks" / name).read_bytes())
    result = cli("report", "--results", tmp_path / "out", "--out", tmp_path / "report")
    assert result.exit_code == 0, result.output
    assert f"found task models: {deep / 'task_models.json'}" in result.output
    tables = tmp_path / "report" / "tables"
    task_table = (tables / "task_distances.md").read_text()
    assert "nearest task" in task_table and "screwdriving" in task_table
    axes = (tables / "axes_cutting.md").read_text()
    assert "gamma (N, N.m)" in axes and "| u6 " in axes
    page = (tmp_path / "report" / "index.html").read_text()
    assert "weighed in SI units" in page
    assert "task model's axes" in page or "task model&#x27;s axes" in page
    empty = tmp_path / "empty"
    empty.mkdir()
    nothing = cli("report", "--results", empty)
    assert nothing.exit_code == 2 and "looked at any depth for a sweep" in nothing.output
    assert "task models (task_models.json" in nothing.output
