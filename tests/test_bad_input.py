"""Every bad input gets one line naming the file (and row or column), exit code 2, and nothing written."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.conftest import wrench_samples

HEADER = "t,fx,fy,fz,tx,ty,tz"


def csv_text(data: np.ndarray, header: str = HEADER) -> str:
    return header + "\n" + "\n".join(",".join(repr(float(v)) for v in row) for row in data) + "\n"


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def manifest(tmp_path: Path, rows: list[dict], name: str = "manifest.csv") -> Path:
    path = tmp_path / name
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


def good_row(path: str, trial: int = 1, **extra) -> dict:
    return {"path": path, "task": "drawing", "subject": "1", "trial": trial, "grasp": "tripod", **extra}


def assert_rejected(result, out: Path, *fragments: str) -> None:
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1, result.output
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    assert not out.exists()
    assert not any(p.name.startswith(f".{out.name}.staging") for p in out.parent.iterdir())


def lines_with(data: np.ndarray, row: int, column: int, value: str) -> str:
    rows = [",".join(repr(float(v)) for v in r) for r in data]
    cells = rows[row].split(",")
    cells[column] = value
    rows[row] = ",".join(cells)
    return HEADER + "\n" + "\n".join(rows) + "\n"


CASES = {
    "missing column": (lambda d: csv_text(d[:, :6], "t,fx,fy,fz,tx,ty"), ["bad.csv", "missing column", "'tz'"]),
    "extra column": (
        lambda d: csv_text(np.column_stack([d, d[:, 1]]), HEADER + ",grip"),
        ["bad.csv", "unexpected column", "'grip'"],
    ),
    "non-numeric": (lambda d: lines_with(d, 56, 2, "abc"), ["bad.csv", "row 57", "'fy'", "non-numeric", "abc"]),
    "NaN": (lambda d: lines_with(d, 9, 3, "nan"), ["bad.csv", "row 10", "'fz'", "NaN"]),
    "empty cell": (lambda d: lines_with(d, 3, 4, ""), ["bad.csv", "row 4", "'tx'", "NaN"]),
    "inf": (lambda d: lines_with(d, 19, 6, "inf"), ["bad.csv", "row 20", "'tz'", "infinite"]),
    "empty file": (lambda d: "", ["bad.csv", "empty file"]),
    "header only": (lambda d: HEADER + "\n", ["bad.csv", "no samples"]),
    "too few samples": (lambda d: csv_text(d[:7]), ["bad.csv", "only 7 samples", "at least 10"]),
    "non-monotonic time": (
        lambda d: csv_text(np.vstack([d[:30], d[30:31] * [0, 1, 1, 1, 1, 1, 1], d[31:]])),
        ["bad.csv", "row 31", "'t'", "not strictly increasing"],
    ),
    "all-zero wrenches": (lambda d: csv_text(d * [1, 0, 0, 0, 0, 0, 0]), ["bad.csv", "all wrench samples are zero"]),
    "rank-deficient wrenches": (
        lambda d: csv_text(d * [1, 1, 1, 1, 0, 0, 0]),
        ["bad.csv", "span only 3 of 6", "singular"],
    ),
}


@pytest.mark.parametrize("case", CASES)
def test_bad_recording_through_a_manifest(case, tmp_path, cli):
    make_text, fragments = CASES[case]
    write(tmp_path, "bad.csv", make_text(wrench_samples()))
    path = manifest(tmp_path, [good_row("bad.csv")])
    out = tmp_path / "out"
    assert_rejected(cli("fit-task", path, "--out", out), out, *fragments)


@pytest.mark.parametrize("case", ["missing column", "non-numeric", "NaN", "empty file", "non-monotonic time"])
def test_bad_recording_given_directly(case, tmp_path, cli):
    make_text, fragments = CASES[case]
    bad = write(tmp_path, "bad.csv", make_text(wrench_samples()))
    out = tmp_path / "out"
    assert_rejected(cli("fit-task", bad, "--task", "drawing", "--out", out), out, *fragments)


def test_bad_parquet_recording_names_row_and_column(tmp_path, cli):
    data = wrench_samples()
    frame = pd.DataFrame(data, columns=HEADER.split(","))
    frame.loc[41, "fx"] = np.inf
    frame.to_parquet(tmp_path / "bad.parquet")
    out = tmp_path / "out"
    assert_rejected(
        cli("fit-task", tmp_path / "bad.parquet", "--out", out), out, "bad.parquet", "row 42", "'fx'", "infinite"
    )


def test_string_column_in_parquet(tmp_path, cli):
    frame = pd.DataFrame(wrench_samples(), columns=HEADER.split(",")).astype({"tz": str})
    frame.loc[12, "tz"] = "oops"
    frame.to_parquet(tmp_path / "bad.parquet")
    out = tmp_path / "out"
    result = cli("fit-task", tmp_path / "bad.parquet", "--out", out)
    assert_rejected(result, out, "bad.parquet", "row 13", "'tz'", "oops")


def test_unknown_unit(tmp_path, recording_factory, cli):
    recording_factory("a.csv")
    path = manifest(tmp_path, [good_row("a.csv", torque_unit="lbf.in")])
    out = tmp_path / "out"
    assert_rejected(cli("fit-task", path, "--out", out), out, "manifest.csv", "row 1", "'torque_unit'", "lbf.in")


def test_manifest_path_that_does_not_exist(tmp_path, recording_factory, cli):
    recording_factory("a.csv")
    path = manifest(tmp_path, [good_row("a.csv"), good_row("missing.csv", trial=2)])
    out = tmp_path / "out"
    assert_rejected(cli("fit-task", path, "--out", out), out, "missing.csv", "file not found")


def test_manifest_itself_missing(tmp_path, cli):
    out = tmp_path / "out"
    assert_rejected(cli("fit-task", tmp_path / "nope.csv", "--out", out), out, "nope.csv", "not found")


def test_duplicate_recording_id(tmp_path, recording_factory, cli):
    recording_factory("a.csv")
    recording_factory("b.csv", seed=1)
    path = manifest(tmp_path, [good_row("a.csv"), good_row("b.csv")])
    out = tmp_path / "out"
    assert_rejected(cli("fit-task", path, "--out", out), out, "manifest.csv", "row 2", "duplicate recording id")


def test_manifest_missing_and_extra_columns(tmp_path, recording_factory, cli):
    recording_factory("a.csv")
    out = tmp_path / "out"
    rows = [{k: v for k, v in good_row("a.csv").items() if k != "grasp"}]
    assert_rejected(cli("fit-task", manifest(tmp_path, rows), "--out", out), out, "missing column", "'grasp'")
    rows = [good_row("a.csv", torque_units="N.m")]
    assert_rejected(cli("fit-task", manifest(tmp_path, rows), "--out", out), out, "unexpected column", "'torque_units'")


def test_sensor_frame_without_tool(tmp_path, recording_factory, cli):
    recording_factory("a.csv")
    path = manifest(tmp_path, [good_row("a.csv", frame="sensor")])
    out = tmp_path / "out"
    assert_rejected(cli("fit-task", path, "--out", out), out, "row 1", "'tool'")


def test_skip_bad_continues_and_lists_the_bad_ones(tmp_path, recording_factory, cli):
    recording_factory("a.csv")
    recording_factory("b.csv", seed=1)
    write(tmp_path, "bad.csv", CASES["NaN"][0](wrench_samples()))
    rows = [good_row("a.csv"), good_row("bad.csv", trial=2), good_row("b.csv", trial=3), good_row("gone.csv", trial=4)]
    out = tmp_path / "out"
    result = cli("fit-task", manifest(tmp_path, rows), "--out", out, "--skip-bad")
    assert result.exit_code == 0, result.output
    assert "skipped 2 bad recording(s)" in result.output
    assert "bad.csv: row 10" in result.output and "gone.csv: file not found" in result.output
    assert len(pd.read_parquet(out / "ellipsoids.parquet")) == 2


def test_skip_bad_with_nothing_usable_is_still_an_error(tmp_path, cli):
    write(tmp_path, "bad.csv", "")
    out = tmp_path / "out"
    result = cli("fit-task", manifest(tmp_path, [good_row("bad.csv")]), "--out", out, "--skip-bad")
    assert result.exit_code == 2
    assert not out.exists()


def test_distances_rejects_a_file_that_is_not_ellipsoids(tmp_path, cli):
    bogus = write(tmp_path, "ellipsoids.parquet", "not parquet")
    out = tmp_path / "out"
    assert_rejected(cli("distances", bogus, "--out", out), out, "ellipsoids.parquet", "not a readable Parquet")


def test_bad_simulator_config(tmp_path, cli):
    config = write(tmp_path, "sim.yaml", "protocol: {subjects: 2, trials: 1}\nsensor: {}\nsubjects: {}\n")
    out = tmp_path / "out"
    assert_rejected(cli("simulate", "--config", config, "--out", out), out, "sim.yaml", "'tasks'")


def test_existing_outputs_survive_a_failed_run(tmp_path, recording_factory, cli):
    recording_factory("a.csv")
    out = tmp_path / "out"
    assert cli("fit-task", manifest(tmp_path, [good_row("a.csv")]), "--out", out).exit_code == 0
    before = (out / "ellipsoids.parquet").read_bytes()
    write(tmp_path, "bad.csv", "")
    result = cli("fit-task", manifest(tmp_path, [good_row("bad.csv")], "m2.csv"), "--out", out)
    assert result.exit_code == 2
    assert (out / "ellipsoids.parquet").read_bytes() == before
