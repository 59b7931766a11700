"""F/T recordings from ROS bags: bags written with rosbags' own writers from simulated recordings fit to the same
ellipsoids as the CSVs they came from, and a bad bag is one line naming the bag and topic, exit code 2."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from grasptask.stages import FitTaskOptions, run_fit_task
from grasptask.task.fit import ellipsoid_matrices
from grasptask.task.manifest import read_manifest
from grasptask.task.recordings import read_recording, write_recording
from grasptask.task.rosbag import BAG_KINDS, read_wrench_bag, write_wrench_bag
from tests.conftest import wrench_samples

TOPIC = "/ft_sensor/wrench"
BAG_NAMES = {"ros1": "{}.bag", "ros2-sqlite3": "{}_db3", "ros2-mcap": "{}_mcap"}


def _bag_manifest(folder: Path, simulated_root: Path, kind: str, count: int = 6) -> tuple[Path, Path]:
    """The first ``count`` simulated recordings as CSVs and as bags of ``kind``, each with its manifest."""
    entries = read_manifest(simulated_root / "recordings" / "manifest.csv")[:: 105 // count][:count]
    csv_rows, bag_rows = [], []
    for entry in entries:
        samples = read_recording(entry.path)
        write_recording(folder / f"{entry.id}.csv", samples)
        bag = write_wrench_bag(folder / BAG_NAMES[kind].format(entry.id), samples, TOPIC, "tool", kind)
        labels = {"task": entry.task, "subject": entry.subject, "trial": entry.trial, "grasp": entry.grasp}
        labels["id"] = entry.id
        csv_rows.append({"path": f"{entry.id}.csv", **labels})
        bag_rows.append({"path": bag.name, "topic": TOPIC, **labels})
    pd.DataFrame(csv_rows).to_csv(folder / "csv_manifest.csv", index=False)
    pd.DataFrame(bag_rows).to_csv(folder / "bag_manifest.csv", index=False)
    return folder / "csv_manifest.csv", folder / "bag_manifest.csv"


@pytest.mark.parametrize("kind", BAG_KINDS)
def test_a_bag_fits_the_same_ellipsoids_as_its_csv(tmp_path, simulated, kind):
    csv_manifest, bag_manifest = _bag_manifest(tmp_path, simulated[0], kind)
    from_csv = run_fit_task(FitTaskOptions(inputs=[csv_manifest], out=tmp_path / "from_csv"))
    from_bag = run_fit_task(FitTaskOptions(inputs=[bag_manifest], out=tmp_path / "from_bag"))
    assert list(from_bag.ellipsoids["id"]) == list(from_csv.ellipsoids["id"])
    np.testing.assert_allclose(ellipsoid_matrices(from_bag.ellipsoids), ellipsoid_matrices(from_csv.ellipsoids),
                               rtol=0, atol=1e-12)  # fmt: skip


def test_the_time_window_selects_seconds_after_the_first_message(tmp_path):
    samples = wrench_samples(n=300)  # 100 Hz
    bag = write_wrench_bag(tmp_path / "w.bag", samples)
    window = read_wrench_bag(bag, TOPIC, 0.5, 1.5).data
    np.testing.assert_allclose(window[:, 0], samples[50:151, 0], atol=1e-9)
    np.testing.assert_array_equal(window[:, 1:], samples[50:151, 1:])


def test_messages_without_stamps_take_the_time_the_bag_recorded_them(tmp_path):
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS1_NOETIC)
    types = typestore.types
    msgtype = "geometry_msgs/msg/WrenchStamped"
    with Writer(tmp_path / "nostamp.bag") as writer:
        connection = writer.add_connection(TOPIC, msgtype, typestore=typestore)
        for k, row in enumerate(wrench_samples(n=20)):
            header = types["std_msgs/msg/Header"](seq=k, stamp=types["builtin_interfaces/msg/Time"](sec=0, nanosec=0),
                                                  frame_id="ft")  # fmt: skip
            vector = types["geometry_msgs/msg/Vector3"]
            wrench = types["geometry_msgs/msg/Wrench"](force=vector(*row[1:4]), torque=vector(*row[4:7]))
            message = types[msgtype](header=header, wrench=wrench)
            writer.write(connection, 5_000_000_000 + k * 20_000_000, typestore.serialize_ros1(message, msgtype))
    data = read_wrench_bag(tmp_path / "nostamp.bag", TOPIC).data
    np.testing.assert_allclose(data[:, 0], np.arange(20) * 0.02, atol=1e-12)


def _write_manifest(folder: Path, path: str, **extra) -> Path:
    row = {"path": path, "task": "drawing", "subject": "1", "trial": 1, "grasp": "free", **extra}
    pd.DataFrame([row]).to_csv(folder / "manifest.csv", index=False)
    return folder / "manifest.csv"


def _string_bag(path: Path) -> None:
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS1_NOETIC)
    with Writer(path) as writer:
        connection = writer.add_connection(TOPIC, "std_msgs/msg/String", typestore=typestore)
        message = typestore.types["std_msgs/msg/String"](data="not a wrench")
        writer.write(connection, 1, typestore.serialize_ros1(message, "std_msgs/msg/String"))


def _corrupt_bag(path: Path) -> None:
    write_wrench_bag(path, wrench_samples())
    raw = bytearray(path.read_bytes())
    raw[200:] = b"\xff" * (len(raw) - 200)
    path.write_bytes(bytes(raw))


def _sensor_tool(folder: Path) -> None:
    (folder / "tool.yaml").write_text("name: t\nsensor:\n  position_m: [0, 0, 0.1]\n  frame_id: ft_sensor\n")


@pytest.mark.parametrize(
    ("make", "extra", "message"),
    [
        (lambda p: write_wrench_bag(p, wrench_samples()), {"topic": "/missing"}, "no such topic"),
        (_string_bag, {"topic": TOPIC}, "std_msgs/msg/String, not geometry_msgs/msg/WrenchStamped"),
        (lambda p: write_wrench_bag(p, wrench_samples()), {"topic": TOPIC, "start_s": 10, "end_s": 20}, "window"),
        (_corrupt_bag, {"topic": TOPIC}, "not a readable ROS bag"),
        (lambda p: write_wrench_bag(p, wrench_samples()), {}, "name the topic"),
        (lambda p: write_wrench_bag(p, wrench_samples()), {"topic": TOPIC, "time_unit": "ms"}, "time_unit"),
        (
            lambda p: write_wrench_bag(p, wrench_samples(), frame_id="wrist"),
            {"topic": TOPIC, "frame": "sensor", "tool": "tool.yaml"},
            "not the sensor frame 'ft_sensor'",
        ),
        (
            lambda p: write_wrench_bag(p, wrench_samples(), frame_id="ft_sensor"),
            {"topic": TOPIC, "tool": "tool.yaml"},
            "set its frame column to 'sensor'",
        ),
    ],  # fmt: skip
)
def test_a_bad_bag_is_one_line_naming_the_bag_and_topic(tmp_path, cli, make, extra, message):
    make(tmp_path / "rec.bag")
    _sensor_tool(tmp_path)
    manifest = _write_manifest(tmp_path, "rec.bag", **extra)
    result = cli("fit-task", manifest, "--out", tmp_path / "out")
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], result.output
    if message in ("name the topic", "time_unit"):  # the manifest's row is at fault
        assert "manifest.csv: row 1" in lines[0]
    else:
        assert f"rec.bag (topic {extra['topic']})" in lines[0]
    assert not (tmp_path / "out").exists()


def test_a_ros2_bag_is_named_by_its_folder_or_its_storage_file(tmp_path):
    samples = wrench_samples()
    folder = write_wrench_bag(tmp_path / "b", samples, kind="ros2-mcap")
    by_file = read_wrench_bag(next(folder.glob("*.mcap")), TOPIC).data
    np.testing.assert_array_equal(by_file, read_wrench_bag(folder, TOPIC).data)
    shutil.rmtree(folder)
    with pytest.raises(ValueError, match="bag not found"):
        read_wrench_bag(folder, TOPIC)
