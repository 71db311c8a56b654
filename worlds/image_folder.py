"""An image log from a folder of camera images and an odometry trajectory.

The images are the folder's ``.png``, ``.jpg`` and ``.jpeg`` files (other files are ignored). Each
name carries a number, the last one in its stem (``1699999999.25.png``, ``frame_000042.jpg``):

- by default it is the image's time stamp, in ``time_unit`` (seconds unless told: a ROS-style
  name in nanoseconds needs ``time_unit="ns"``);
- with ``rate`` (Hz) it is a frame number: frame ``n`` was taken ``(n - first) / rate`` seconds
  after the odometry's first pose.

The odometry is a TUM trajectory (``t x y z qx qy qz qw``, spaces or commas; ticks between
consecutive poses as :func:`worlds.trajectory_import.odometry_from_tum` makes them), the ground
truth optionally another, interpolated at the ticks' times. Each tick is paired with the latest
image taken at or before its time; ticks before the first image are left out (the log starts at
the first tick that has one). Every image used is checked from its header before anything is
written: a decompression bomb or a frame of another size than the first is one line naming the
file (decoding errors are found when the log is replayed, named by file and line).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError
from .images import MAX_IMAGE_PIXELS, ImageReadError, image_size
from .observation_log import ObservationLog
from .trajectory_import import _interpolate_poses, odometry_from_tum, read_tum

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
_NUMBER = re.compile(r"[0-9]+(?:\.[0-9]+)?")


class ImageFolderError(InputError):
    """An image folder or odometry that cannot make an image log (one line: file, problem)."""


@dataclass(frozen=True)
class ImageFolderLog:
    """The odometry ticks (an observation log without scene numbers) and each tick's image file;
    ``skipped``: ticks left out before the first image."""

    odometry: ObservationLog
    images: list[Path]
    skipped: int


def image_times(folder, rate: float | None = None, time_unit: str = "s", start: float = 0.0):
    """The folder's image files in time order and their times (seconds): the number in each name
    as a time stamp in ``time_unit``, or with ``rate`` as a frame number (time ``start + (n -
    first) / rate``)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ImageFolderError(f"{folder}: not a folder of images")
    if time_unit not in TIME_UNITS:
        raise ImageFolderError(f"time unit: expected one of {', '.join(TIME_UNITS)}, got {time_unit!r}")
    files = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and not p.name.startswith("."))
    if not files:
        raise ImageFolderError(f"{folder}: no .png, .jpg or .jpeg images")
    numbers = []
    for p in files:
        found = _NUMBER.findall(p.stem)
        if not found:
            what = "a frame number" if rate is not None else "a time stamp"
            raise ImageFolderError(f"{p}: the name carries no number ({what} is needed)")
        numbers.append(found[-1])
    if rate is not None:
        if any("." in n for n in numbers):
            bad = next(p for p, n in zip(files, numbers) if "." in n)
            raise ImageFolderError(f"{bad}: with a frame rate the names carry frame numbers, not {bad.stem!r}")
        index = np.array([int(n) for n in numbers], dtype=np.int64)
        times = start + (index - index.min()) / float(rate)
    else:
        times = np.array([float(n) for n in numbers]) * TIME_UNITS[time_unit]
    order = np.argsort(times, kind="stable")
    files, times = [files[i] for i in order], times[order]
    same = np.flatnonzero(np.diff(times) <= 0)
    if len(same):
        a, b = files[same[0]], files[same[0] + 1]
        raise ImageFolderError(f"{b}: the same time as {a.name} ({times[same[0]]!r} s)")
    return files, times


def import_image_folder(
    folder,
    odometry,
    ground_truth=None,
    rate: float | None = None,
    time_unit: str = "s",
) -> ImageFolderLog:
    """Pair the odometry's ticks with the folder's images (module doc); nothing is written."""
    poses = read_tum(odometry)
    t, dt, v, w = odometry_from_tum(poses)
    files, times = image_times(folder, rate, time_unit, start=float(poses[0, 0]))
    k = np.searchsorted(times, t, side="right") - 1  # the latest image at or before each tick
    first = int(np.searchsorted(k, 0))  # k is non-decreasing: ticks before the first image have -1
    if first >= len(t):
        raise ImageFolderError(
            f"{folder}: no image at or before any odometry tick (images {times[0]:.6g}-{times[-1]:.6g} s, "
            f"odometry {t[0]:.6g}-{t[-1]:.6g} s; the names' unit: time_unit / --time-unit, or frame numbers: --rate)"
        )
    t, dt, v, w, k = t[first:], dt[first:], v[first:], w[first:], k[first:]
    used = [files[i] for i in k]
    _check_headers(sorted(set(used), key=used.index))
    log = ObservationLog(t=t, dt=dt, v_trans=v, v_rot=w, scene_id=np.full(len(t), -1, dtype=np.int64))
    if ground_truth is not None:
        gt = _interpolate_poses(read_tum(ground_truth), t, ground_truth)
        log = ObservationLog(
            t=t,
            dt=dt,
            v_trans=v,
            v_rot=w,
            scene_id=log.scene_id,
            gt_x=gt[:, 0],
            gt_y=gt[:, 1],
            gt_theta=gt[:, 2],
            false_positive=np.zeros(len(t), dtype=bool),
        )
    return ImageFolderLog(log, used, first)


def _check_headers(files: list[Path]) -> None:
    """Every image readable as a PNG or JPEG header, within the pixel bound, all of one size."""
    size = None
    for p in files:
        try:
            s = image_size(p)
        except ImageReadError as e:
            raise ImageFolderError(str(e)) from None
        columns, rows = s
        if columns * rows > MAX_IMAGE_PIXELS:
            raise ImageFolderError(
                f"{p}: declares {columns}x{rows} pixels, more than {MAX_IMAGE_PIXELS:,} (a decompression bomb?); "
                "refused before decoding"
            )
        if size is None:
            size, first = s, p
        elif s != size:
            raise ImageFolderError(
                f"{p}: {columns}x{rows} pixels, but the first image ({first.name}) is {size[0]}x{size[1]}; "
                "every frame must have one size"
            )
