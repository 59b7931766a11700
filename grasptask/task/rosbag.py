"""Force/torque recordings from ROS bags: the ``geometry_msgs/WrenchStamped`` messages of one topic, read with
the pure-Python ``rosbags`` package (no ROS install), into the same ``(n, 7)`` array of t, fx, fy, fz, tx, ty,
tz that :func:`grasptask.task.recordings.read_recording` gives for a CSV.

A ROS 1 bag is a ``.bag`` file; a ROS 2 bag is a folder with ``metadata.yaml`` and ``.db3`` (SQLite) or
``.mcap`` storage, named by the folder or by its storage file. Time is each message's header stamp, seconds
plus nanoseconds (ROS time, in seconds); a driver that leaves its stamps at zero gets the time the bag
recorded the message instead. Forces and torques are as published: ROS's convention (REP 103) is N and N m.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from grasptask.errors import BadInputError
from grasptask.task.recordings import check_values, window_mask

WRENCH_TYPES = ("geometry_msgs/msg/WrenchStamped", "geometry_msgs/WrenchStamped")
ROS2_STORAGE = (".db3", ".mcap")


def is_bag(path: str | Path) -> bool:
    """A ROS 1 ``.bag``, a ROS 2 bag folder, or a ROS 2 bag's storage file."""
    path = Path(path)
    return path.suffix.lower() in (".bag", *ROS2_STORAGE) or (path / "metadata.yaml").is_file()


@dataclass(frozen=True)
class BagRecording:
    """One topic's samples, ``(n, 7)`` in SI units as published, and the frame its messages name."""

    data: np.ndarray
    frame_id: str


def _bag_paths(path: Path) -> list[Path]:
    """What ``AnyReader`` opens: the ``.bag`` file, or the ROS 2 bag's folder."""
    if path.suffix.lower() == ".bag":
        return [path]
    folder = path.parent if path.suffix.lower() in ROS2_STORAGE else path
    if not (folder / "metadata.yaml").is_file():
        raise BadInputError(path, f"not a ROS 2 bag: no metadata.yaml in {folder}")
    return [folder]


def read_wrench_bag(
    path: str | Path, topic: str, start_s: float | None = None, end_s: float | None = None
) -> BagRecording:
    """The ``WrenchStamped`` messages on ``topic``, time-ordered, between ``start_s`` and ``end_s`` seconds
    after the topic's first message (both optional). A missing topic, another message type, an empty window, a
    frame that changes between messages or a bag that cannot be read is one line naming the bag and topic."""
    from rosbags.highlevel import AnyReader  # deferred: only for bag files
    from rosbags.typesys import Stores, get_typestore  # deferred: only for bag files

    path = Path(path)
    where = f"{path} (topic {topic})"
    if not path.exists():
        raise BadInputError(path, "bag not found")
    try:
        with AnyReader(_bag_paths(path), default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            connections = [c for c in reader.connections if c.topic == topic]
            if not connections:
                topics = ", ".join(sorted({c.topic for c in reader.connections})) or "none"
                raise BadInputError(where, f"no such topic in the bag (it has: {topics})")
            wrong = [c.msgtype for c in connections if c.msgtype not in WRENCH_TYPES]
            if wrong:
                raise BadInputError(where, f"messages of type {wrong[0]}, not geometry_msgs/msg/WrenchStamped")
            ticks, received, values, frames = [], [], [], set()
            for connection, received_ns, raw in reader.messages(connections=connections):
                message: Any = reader.deserialize(raw, connection.msgtype)
                stamp, force, torque = message.header.stamp, message.wrench.force, message.wrench.torque
                frames.add(message.header.frame_id)
                # integer nanoseconds: float seconds since 1970 keep only microseconds
                ticks.append(int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec))
                received.append(int(received_ns))
                values.append((force.x, force.y, force.z, torque.x, torque.y, torque.z))
    except BadInputError:
        raise
    except Exception as exc:  # rosbags raises its own errors, and struct / sqlite / KeyError on damaged files
        raise BadInputError(where, f"not a readable ROS bag ({type(exc).__name__}: {exc})") from None
    if not values:
        raise BadInputError(where, "the topic holds no messages")
    if len(frames) > 1:
        raise BadInputError(where, f"messages in more than one frame: {', '.join(sorted(frames))}")
    times = np.array(received if not any(ticks) else ticks, dtype=np.int64)
    order = np.argsort(times, kind="stable")
    seconds = (times[order] - times[order[0]]) * 1e-9
    wrenches = np.array(values, dtype=float)[order]
    keep = window_mask(where, seconds, start_s, end_s)
    data = np.column_stack([seconds[keep], wrenches[keep]])
    check_values(where, data)
    return BagRecording(data, frames.pop())


BAG_KINDS = ("ros1", "ros2-sqlite3", "ros2-mcap")


def write_wrench_bag(
    path: str | Path,
    samples: np.ndarray,
    topic: str = "/ft_sensor/wrench",
    frame_id: str = "ft_sensor",
    kind: str = "ros1",
    start_ns: int = 1_700_000_000_000_000_000,
) -> Path:
    """``(n, 7)`` samples (t in s, wrenches in N and N m) as the ``WrenchStamped`` messages a force/torque
    driver publishes, stamped ``start_ns`` plus each sample's time, in a ROS 1 ``.bag`` or a ROS 2 bag folder
    (``kind``: one of ``BAG_KINDS``); the path to name in a manifest."""
    from rosbags.rosbag1 import Writer as Writer1  # deferred: only for bag files
    from rosbags.rosbag2 import StoragePlugin  # deferred: only for bag files
    from rosbags.rosbag2 import Writer as Writer2  # deferred: only for bag files
    from rosbags.typesys import Stores, get_typestore  # deferred: only for bag files

    if kind not in BAG_KINDS:
        raise ValueError(f"kind must be one of {', '.join(BAG_KINDS)}, got {kind!r}")
    path = Path(path)
    typestore = get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)
    types = typestore.types
    msgtype = "geometry_msgs/msg/WrenchStamped"
    Header, Time = types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
    Wrench, Vector3, Stamped = types["geometry_msgs/msg/Wrench"], types["geometry_msgs/msg/Vector3"], types[msgtype]
    if kind == "ros1":
        writer: Any = Writer1(path)
        serialize = typestore.serialize_ros1
    else:
        plugin = StoragePlugin.MCAP if kind == "ros2-mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=8, storage_plugin=plugin)
        serialize = typestore.serialize_cdr
    with writer:
        connection = writer.add_connection(topic, msgtype, typestore=typestore)
        for sequence, row in enumerate(samples):
            stamp = start_ns + int(round(float(row[0]) * 1e9))
            header = (
                Header(seq=sequence, stamp=Time(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id=frame_id)
                if kind == "ros1"
                else Header(stamp=Time(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id=frame_id)
            )
            message = Stamped(header=header, wrench=Wrench(force=Vector3(*row[1:4]), torque=Vector3(*row[4:7])))
            writer.write(connection, stamp, serialize(message, msgtype))
    return path
