"""Image logs from ROS 1 or ROS 2 bags: odometry plus a camera topic (pure-Python ``rosbags``).

* Odometry and the optional ground truth as in :mod:`worlds.bag_import` (ticks between
  consecutive ``nav_msgs/Odometry`` messages, their header stamps).
* Images: a ``sensor_msgs/Image`` (encodings :data:`worlds.image_decode.RAW_ENCODINGS`) or
  ``sensor_msgs/CompressedImage`` (JPEG or PNG) topic. Each tick gets the latest image whose header
  stamp is at or before the tick's time, and ticks the images do not cover are dropped
  (:mod:`worlds.image_pairing`). Only the images some tick uses are decoded and written
  (:func:`worlds.image_log.write_image_log`).
* Field of view: from a ``sensor_msgs/CameraInfo`` topic (given, or found in the image topic's
  namespace or the ones above it: ``/cam/camera_info`` for ``/cam/image_raw`` and
  ``/cam/image_raw/compressed``), ``2 atan(width / (2 fx))`` with ``fx = K[0]`` and the width of
  its region of interest if one is set (distortion and an off-centre principal point are not
  taken into account), written in the images folder's ``camera.toml``
  (:class:`worlds.image_log.CameraDescription`), where ``replay`` reads it.

Every image's declared size and encoding are checked in a first pass over the topic, before any
image is decoded: an unknown encoding, a size beyond :data:`~worlds.images.MAX_IMAGE_PIXELS` (a
decompression bomb), frames of changing size, an empty topic or images whose stamps miss the
odometry are one line naming the bag, the topic (and message) and the problem; the second pass
decodes and writes the images, and a truncated or invalid one is refused the same way. Nothing is
written on error.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .bag_import import BagImportError, _connection, _stamp, open_bag, read_odometry
from .image_decode import check_encoding, decode_raw
from .image_log import (
    CameraDescription,
    ImageImport,
    ImageLogError,
    check_outputs,
    write_image_log,
)
from .image_pairing import images_per_tick, pair_ticks
from .images import ImageReadError, check_size, image_size, read_grey
from .trajectory_import import unlabelled_log

IMAGE = "sensor_msgs/msg/Image"
COMPRESSED = "sensor_msgs/msg/CompressedImage"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"


def field_of_view_deg(fx: float, width: float) -> float:
    """Horizontal field of view of a pinhole camera, degrees: ``2 atan(width / (2 fx))``."""
    return math.degrees(2.0 * math.atan(width / (2.0 * fx)))


def _declared(connection, msg, where: str) -> tuple[int, int]:
    """An image message's (width, height) from its fields or its compressed stream's header,
    checked before anything is decoded."""
    if connection.msgtype == IMAGE:
        check_encoding(msg.encoding, where)
        size = int(msg.width), int(msg.height)
        check_size(*size, where)
        return size
    fmt = str(msg.format).lower()
    if "compresseddepth" in fmt or (fmt.strip() and not any(f in fmt for f in ("jpeg", "jpg", "png"))):
        raise ImageReadError(f"{where}: compressed format {msg.format!r} not read (read: JPEG, PNG)")
    return image_size(bytes(msg.data), where)  # an empty format: the stream's own header says


def _decode(connection, msg, where: str) -> np.ndarray:
    if connection.msgtype == IMAGE:
        return decode_raw(msg.encoding, msg.height, msg.width, msg.step, bool(msg.is_bigendian), msg.data, where)
    return read_grey(bytes(msg.data), where)


def _image_stamps(reader, bag, topic: str, connections) -> np.ndarray:
    """First pass: every image's header stamp, its encoding and declared size checked."""
    stamps: list[float] = []
    first: tuple[int, int] | None = None
    for connection, _, raw in reader.messages(connections=connections):
        msg = reader.deserialize(raw, connection.msgtype)
        where = f"{bag}: topic {topic}: message {len(stamps) + 1}"
        size = _declared(connection, msg, where)
        check_size(*size, where, first=first)
        first = first or size
        stamps.append(_stamp(msg.header))
    if not stamps:
        raise BagImportError(f"{bag}: topic {topic} (images): no messages")
    return np.array(stamps)


def _camera_info_topic(reader, bag, image_topic: str, given: str | None) -> str | None:
    if given is not None:
        _connection(reader, bag, given, (CAMERA_INFO,), "camera info")
        return given
    infos = {c.topic for c in reader.connections if c.msgtype == CAMERA_INFO}
    parts = image_topic.split("/")
    for k in range(len(parts) - 1, 0, -1):
        namespace = "/".join(parts[:k])
        found = sorted(t for t in infos if t.rsplit("/", 1)[0] == namespace)
        if len(found) > 1:
            raise BagImportError(
                f"{bag}: topic {image_topic}: camera info topics {', '.join(found)} both fit; "
                "choose one with --camera-info"
            )
        if found:
            return found[0]
    return None


def _field_of_view(reader, bag, topic: str | None, explicit: bool) -> tuple[float | None, str]:
    """The field of view (degrees) from the first camera-info message, and where it came from."""
    if topic is None:
        return None, "no sensor_msgs/CameraInfo topic for the images"
    for connection, _, raw in reader.messages(
        connections=_connection(reader, bag, topic, (CAMERA_INFO,), "camera info")
    ):
        msg = reader.deserialize(raw, connection.msgtype)
        k = getattr(msg, "k", getattr(msg, "K", None))
        fx = float(k[0]) if k is not None and len(k) == 9 else float("nan")
        roi = msg.roi
        width = int(roi.width) if int(roi.width) > 0 else int(msg.width)
        if math.isfinite(fx) and fx > 0 and width > 0:
            fov = field_of_view_deg(fx, width)
            return fov, f"{topic}: fx = {fx:g} px, width {width} px, 2 atan(width / (2 fx)) = {fov:.2f} deg"
        problem = f"{topic}: fx = K[0] = {fx:g} and width {width}: not a calibrated camera"
        if explicit:
            raise BagImportError(f"{bag}: topic {problem}")
        return None, problem
    if explicit:
        raise BagImportError(f"{bag}: topic {topic} (camera info): no messages")
    return None, f"{topic}: no messages"


def import_bag_images(
    bag,
    odometry_topic: str,
    image_topic: str,
    out,
    ground_truth_topic: str | None = None,
    camera_info_topic: str | None = None,
    twist: bool = False,
) -> ImageImport:
    """Write the image log ``out`` (CSV, images folder with the camera's ``camera.toml`` where the
    field of view is known) from a bag (see the module docstring)."""
    bag, out = Path(bag), Path(out)
    check_outputs(out, (bag,))
    reader = open_bag(bag)
    try:
        t, dt, v, w, gt = read_odometry(reader, bag, odometry_topic, ground_truth_topic, twist)
        connections = _connection(reader, bag, image_topic, (IMAGE, COMPRESSED), "images")
        info_topic = _camera_info_topic(reader, bag, image_topic, camera_info_topic)
        fov, fov_note = _field_of_view(reader, bag, info_topic, camera_info_topic is not None)
        stamps = _image_stamps(reader, bag, image_topic, connections)
        order = np.argsort(stamps, kind="stable")
        pairing = pair_ticks(stamps[order], t, dt)
        first, end = pairing.first, pairing.end
        if end - first < 2:
            raise BagImportError(
                f"{bag}: topic {image_topic}: image header stamps {stamps.min():.3f}-{stamps.max():.3f} s cover "
                f"fewer than 2 of the odometry's ticks ({t[0]:.3f}-{t[-1]:.3f} s)"
            )
        message = order[pairing.images]  # per kept tick, the ordinal of its image message
        odometry = pairing.kept(unlabelled_log(t, dt, v, w, gt))
        where = f"{bag}: topic {image_topic}: message"

        def convert(k: int, item) -> np.ndarray:
            connection, _, raw = item
            return _decode(connection, reader.deserialize(raw, connection.msgtype), f"{where} {k + 1}")

        def ended(k: int, read: int) -> Exception:
            return ImageLogError(f"{where} {k + 1}: missing (the topic ended after {read} messages)")

        images = images_per_tick(reader.messages(connections=connections), message, convert, ended)
        camera = None if fov is None else CameraDescription(fov, source=f"ratslam-harness import rosbag: {fov_note}")
        log = write_image_log(out, odometry, images, camera)
    finally:
        reader.close()
    ages = log.t - stamps[message]
    return ImageImport.written(out, log, pairing.dropped(), ages, fov, fov_note)
