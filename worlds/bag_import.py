"""Observation logs from ROS 1 or ROS 2 bags (pure-Python ``rosbags``, no ROS install).

* Odometry: a ``nav_msgs/Odometry`` topic. Ticks run between consecutive messages (header
  stamps); by default the motion is the difference of the poses (x, y and the quaternion's yaw,
  as for TUM files), with ``twist=True`` the message's own twist (``linear.x``, ``angular.z``),
  held over the tick that ends at that message.
* Ground truth (optional, metrics only): a second ``nav_msgs/Odometry`` or a
  ``geometry_msgs/PoseStamped`` topic, interpolated at the tick times.
* Camera images instead of place labels: :mod:`worlds.bag_images`.
* Place labels: an integer topic (``std_msgs`` Int8 ... UInt64, field ``data``), placed at each
  message's record time and held as in :mod:`worlds.trajectory_import`; or scene numbers
  synthesised from the ground truth by the scene model.

A missing topic, a topic of another type, or a non-finite value is one line naming the bag, the
topic and the problem (:class:`BagImportError`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .errors import InputError
from .observation_log import ObservationLog
from .trajectory_import import PlaceLabels, _interpolate_poses, assemble_log, odometry_from_tum, place_labels
from .world import SceneSpec

ODOMETRY = "nav_msgs/msg/Odometry"
POSE = "geometry_msgs/msg/PoseStamped"
INTEGERS = tuple(
    f"std_msgs/msg/{k}" for k in ("Int8", "Int16", "Int32", "Int64", "UInt8", "UInt16", "UInt32", "UInt64")
)


class BagImportError(InputError):
    """A bag that cannot be imported (one line: bag, topic, problem)."""


def _yaw(q) -> float:
    return float(np.arctan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z)))


def _stamp(header) -> float:
    return float(header.stamp.sec) + 1e-9 * float(header.stamp.nanosec)


def _connection(reader, bag, topic: str, types: tuple[str, ...], role: str):
    found = [c for c in reader.connections if c.topic == topic]
    if not found:
        known = ", ".join(sorted({c.topic for c in reader.connections})) or "none"
        raise BagImportError(f"{bag}: topic {topic} ({role}): not in the bag (topics: {known})")
    if found[0].msgtype not in types:
        raise BagImportError(f"{bag}: topic {topic} ({role}): type {found[0].msgtype}, expected {' or '.join(types)}")
    return found


def _poses(reader, bag, topic: str, types, role: str, twist: bool = False) -> np.ndarray:
    """Rows ``t, x, y, yaw[, v, w]`` of a pose topic, in message order."""
    rows: list[list[float]] = []
    for connection, _, raw in reader.messages(connections=_connection(reader, bag, topic, types, role)):
        msg = reader.deserialize(raw, connection.msgtype)
        pose = msg.pose.pose if connection.msgtype == ODOMETRY else msg.pose
        row = [_stamp(msg.header), pose.position.x, pose.position.y, _yaw(pose.orientation)]
        if twist:
            row += [msg.twist.twist.linear.x, msg.twist.twist.angular.z]
        if not np.all(np.isfinite(row)):
            raise BagImportError(f"{bag}: topic {topic} ({role}): message {len(rows) + 1}: non-finite value")
        q = pose.orientation
        if math.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w) < 1e-9:  # as worlds.trajectory_import
            raise BagImportError(f"{bag}: topic {topic} ({role}): message {len(rows) + 1}: quaternion of zero length")
        rows.append(row)
    if len(rows) < 2:
        raise BagImportError(f"{bag}: topic {topic} ({role}): needs at least 2 messages, got {len(rows)}")
    table = np.array(rows)
    back = np.flatnonzero(np.diff(table[:, 0]) <= 0)
    if back.size:
        raise BagImportError(
            f"{bag}: topic {topic} ({role}): message {back[0] + 2}: header stamp not after "
            f"the previous one (time order)"
        )
    return table


def _labels(reader, bag, topic: str) -> PlaceLabels:
    rows: list[tuple[float, int]] = []
    for connection, timestamp, raw in reader.messages(
        connections=_connection(reader, bag, topic, INTEGERS, "place labels")
    ):
        rows.append((timestamp * 1e-9, int(reader.deserialize(raw, connection.msgtype).data)))
    if not rows:
        raise BagImportError(f"{bag}: topic {topic} (place labels): no messages")
    return place_labels(rows, f"{bag}: topic {topic} (place labels)", BagImportError)


def open_bag(bag):
    """An opened ``rosbags`` reader of a ROS 1 or ROS 2 bag (close it); one line if it cannot be."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise BagImportError("importing bags needs the rosbags package: pip install 'ratslam-harness[bags]'") from None
    bag = Path(bag)
    if not bag.exists():
        raise BagImportError(f"{bag}: no such bag")
    try:
        reader = AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as e:  # rosbags raises its own error classes
        raise BagImportError(f"{bag}: not a readable bag ({type(e).__name__}: {e})") from None
    return reader


def read_odometry(reader, bag, odometry_topic: str, ground_truth_topic: str | None = None, twist: bool = False):
    """Ticks ``t, dt, v, w`` between consecutive odometry messages, and the ground truth (n, 3)
    at their times or ``None``."""
    odo = _poses(reader, bag, odometry_topic, (ODOMETRY,), "odometry", twist=twist)
    t, dt, v, w = odometry_from_tum(odo[:, :4])
    if twist:
        v, w = odo[1:, 4], odo[1:, 5]
    gt = None
    if ground_truth_topic is not None:
        gt_rows = _poses(reader, bag, ground_truth_topic, (ODOMETRY, POSE), "ground truth")
        gt = _interpolate_poses(gt_rows, t, f"{bag}: topic {ground_truth_topic}")
    return t, dt, v, w, gt


def import_bag(
    bag,
    odometry_topic: str,
    ground_truth_topic: str | None = None,
    label_topic: str | None = None,
    synthesise: SceneSpec | None = None,
    twist: bool = False,
    label_max_age: float | None = None,
    seed: int = 0,
) -> ObservationLog:
    """An observation log from a bag (see the module docstring)."""
    if (label_topic is None) == (synthesise is None):
        raise BagImportError("labels: give either a label topic or ask for synthesised scene numbers")
    bag = Path(bag)
    reader = open_bag(bag)
    try:
        t, dt, v, w, gt = read_odometry(reader, bag, odometry_topic, ground_truth_topic, twist)
        labels = _labels(reader, bag, label_topic) if label_topic is not None else None
    finally:
        reader.close()
    return assemble_log(
        t,
        dt,
        v,
        w,
        gt,
        labels,
        synthesise,
        label_max_age,
        seed,
        "ground truth: synthesised scene numbers need a ground-truth topic",
        BagImportError,
    )
