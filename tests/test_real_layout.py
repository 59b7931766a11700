"""Recordings from another tool and layout work through the manifest and tool config alone."""

import shutil

import numpy as np
import pandas as pd

from grasptask.task.frames import wrench_transform
from grasptask.task.tool import load_tool
from tests.conftest import wrench_samples

EXAMPLE_TOOL = "configs/tools/wrist_sensor_example.yaml"


def to_wrist_layout(samples: np.ndarray, tool) -> pd.DataFrame:
    """Object-frame SI samples as the wrist sensor's software would log them."""
    to_sensor = np.linalg.inv(wrench_transform(tool.sensor_rotation, tool.sensor_position))
    sensor = samples[:, 1:] @ to_sensor.T
    return pd.DataFrame(
        {
            "status": 0,
            "Tz": sensor[:, 5] * 100,
            "Fx": sensor[:, 0],
            "Fy": sensor[:, 1],
            "Fz": sensor[:, 2],
            "Tx": sensor[:, 3] * 100,
            "Ty": sensor[:, 4] * 100,
            "time_ms": samples[:, 0] * 1000 + 12345.0,
        }
    )


def test_wrist_sensor_recordings_match_the_object_frame_truth(tmp_path, cli):
    tool = load_tool(EXAMPLE_TOOL)
    shutil.copy(EXAMPLE_TOOL, tmp_path / "wrist.yaml")
    truth, rows = [], []
    for k in range(3):
        samples = wrench_samples(n=400, seed=k)
        truth.append(samples)
        to_wrist_layout(samples, tool).to_csv(tmp_path / f"trial{k}.csv", index=False)
        rows.append(
            {
                "path": f"trial{k}.csv",
                "task": "polishing",
                "subject": "P1",
                "trial": k + 1,
                "grasp": "free",
                "frame": "sensor",
                "tool": "wrist.yaml",
            }
        )
    # the same data in the simulator's own layout: object frame, SI units, canonical columns
    for k, samples in enumerate(truth):
        pd.DataFrame(samples, columns=["t", "fx", "fy", "fz", "tx", "ty", "tz"]).to_parquet(tmp_path / f"si{k}.parquet")
    pd.DataFrame(rows).to_csv(tmp_path / "manifest.csv", index=False)
    reference = [dict(r, path=f"si{k}.parquet", frame="object", tool="") for k, r in enumerate(rows)]
    pd.DataFrame(reference).to_csv(tmp_path / "si_manifest.csv", index=False)

    assert cli("fit-task", tmp_path / "manifest.csv", "--out", tmp_path / "wrist").exit_code == 0
    assert cli("fit-task", tmp_path / "si_manifest.csv", "--out", tmp_path / "si").exit_code == 0
    wrist = pd.read_parquet(tmp_path / "wrist" / "ellipsoids.parquet")
    si = pd.read_parquet(tmp_path / "si" / "ellipsoids.parquet")
    assert list(wrist["group"]) == ["polishing"] * 3
    for a, b in zip(wrist["S"], si["S"], strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)
    for a, b in zip(wrist["S"], truth, strict=True):
        expected = b[:, 1:].T @ b[:, 1:] / len(b)
        np.testing.assert_allclose(np.reshape(a, (6, 6)), expected, rtol=1e-9, atol=1e-12)


def test_manifest_units_override_the_tool_default(tmp_path, cli):
    """Data in N.mm with a manifest saying so; the tool config says N.cm."""
    tool = load_tool(EXAMPLE_TOOL)
    shutil.copy(EXAMPLE_TOOL, tmp_path / "wrist.yaml")
    samples = wrench_samples(n=300, seed=5)
    frame = to_wrist_layout(samples, tool)
    frame[["Tx", "Ty", "Tz"]] *= 10  # N.cm -> N.mm
    frame.to_csv(tmp_path / "rec.csv", index=False)
    row = {
        "path": "rec.csv",
        "task": "t",
        "subject": "1",
        "trial": 1,
        "grasp": "free",
        "frame": "sensor",
        "tool": "wrist.yaml",
        "torque_unit": "N.mm",
    }
    pd.DataFrame([row]).to_csv(tmp_path / "manifest.csv", index=False)
    assert cli("fit-task", tmp_path / "manifest.csv", "--out", tmp_path / "out").exit_code == 0
    s = np.reshape(pd.read_parquet(tmp_path / "out" / "ellipsoids.parquet")["S"][0], (6, 6))
    np.testing.assert_allclose(s, samples[:, 1:].T @ samples[:, 1:] / len(samples), rtol=1e-9, atol=1e-12)


def test_plain_files_with_cli_labels(tmp_path, recording_factory, cli):
    files = [recording_factory(f"r{k}.csv", seed=k) for k in range(3)]
    result = cli("fit-task", *files, "--task", "writing", "--grasp", "tripod", "--out", tmp_path / "out")
    assert result.exit_code == 0, result.output
    table = pd.read_parquet(tmp_path / "out" / "ellipsoids.parquet")
    assert list(table["id"]) == ["r0", "r1", "r2"]
    assert set(table["group"]) == {"writing_tripod"}
