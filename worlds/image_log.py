"""Image logs written by the importers: the observation log with an ``image`` column, its images
folder and, where the camera's field of view is known, a configuration file beside it.

The layout is the camera log's (DESIGN.md, ``simulate --camera``): each tick's image file in
``<log stem>_images/`` next to the log, named relative to the log. An image paired with several
ticks is written once. :class:`ImageLogWriter` stages the images in a hidden folder and moves the
folder, the CSV and the field-of-view file into place only once everything is written; on an
error the staging folder is removed and nothing at the destination changes.

The field of view goes into ``<log stem>.camera.toml`` (:func:`camera_config_path`), a
configuration file with one key, ``[ratslam.view] field_of_view_deg``:
``ratslam-harness replay LOG.csv --config LOG.camera.toml`` uses it.
"""

from __future__ import annotations

import math
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from .errors import InputError
from .files import atomic_path
from .observation_log import ObservationLog


@dataclass(frozen=True)
class ImageImport:
    """What an image import wrote: the log, how many images, the ticks dropped before the first
    image and after the last, the oldest image a tick was paired with (s), the images' (rows,
    columns), and the field of view (degrees) with where it came from, or ``None`` with why not."""

    log: ObservationLog
    images: int
    dropped: int
    dropped_at_end: int
    max_age_s: float
    shape: tuple[int, ...]
    fov_deg: float | None
    fov_note: str


class ImageLogError(InputError):
    """An image log that cannot be written (one line: the file or folder and the problem)."""


def images_folder(log_path) -> Path:
    """Where an image log's images go: ``<log stem>_images`` next to the log (as
    ``simulate --camera``)."""
    log_path = Path(log_path)
    return log_path.with_name(f"{log_path.stem}_images")


def camera_config_path(log_path) -> Path:
    """The configuration file that carries a log's field of view: ``<log stem>.camera.toml``."""
    log_path = Path(log_path)
    return log_path.with_name(f"{log_path.stem}.camera.toml")


def field_of_view_deg(fx: float, width: float) -> float:
    """Horizontal field of view of a pinhole camera, degrees: ``2 atan(width / (2 fx))``."""
    return math.degrees(2.0 * math.atan(width / (2.0 * fx)))


def latest_at_or_before(frame_t: np.ndarray, tick_t: np.ndarray, slack: float = 1e-6) -> np.ndarray:
    """Per tick, the index of the latest frame whose time is at or before the tick's (within
    ``slack`` seconds, for time stamps rounded to microseconds); -1 where no frame is yet."""
    return np.searchsorted(frame_t, tick_t + slack, side="right") - 1


def covered_ticks(frame_t: np.ndarray, tick_t: np.ndarray, dt: np.ndarray) -> tuple[int, int]:
    """The ticks ``first:end`` that a stream of frames (times in order) covers: from the first
    tick with a frame at or before it, to the last one no later than the last frame plus twice
    the larger of the median frame interval and the median tick."""
    first = int(np.searchsorted(latest_at_or_before(frame_t, tick_t), 0))
    interval = float(np.median(np.diff(frame_t))) if len(frame_t) > 1 else 0.0
    reach = frame_t[-1] + 2.0 * max(interval, float(np.median(dt)))
    end = int(np.searchsorted(tick_t, reach, side="right"))
    return first, max(first, end)


class ImageLogWriter:
    """Writes an image log: :meth:`add` each image, then :meth:`commit` the log (context manager:
    leaving the block without a commit, or on an error, removes everything staged)."""

    def __init__(self, log_path):
        self.log_path = Path(log_path)
        self.folder = images_folder(self.log_path)
        self._stage = self.folder.with_name(f".{self.folder.name}.tmp-{os.getpid()}")
        self._count = 0
        self._shape: tuple[int, ...] | None = None

    def __enter__(self) -> ImageLogWriter:
        try:
            if self._stage.exists():
                shutil.rmtree(self._stage)
            self._stage.mkdir(parents=True)
        except OSError as e:
            raise ImageLogError(f"{self.folder}: cannot write the images ({e.strerror or e})") from None
        return self

    def __exit__(self, *exc) -> None:
        shutil.rmtree(self._stage, ignore_errors=True)

    @property
    def shape(self) -> tuple[int, ...] | None:
        """The (rows, columns) of the images added so far (all the same)."""
        return self._shape

    def add(self, grey: np.ndarray) -> str:
        """Write one (rows, columns) uint8 image; its name relative to the log."""
        self._count += 1
        name = f"{self._count:06d}.png"
        try:
            Image.fromarray(grey, mode="L").save(self._stage / name, optimize=False)
        except OSError as e:
            raise ImageLogError(f"{self.folder}: cannot write the images ({e.strerror or e})") from None
        self._shape = grey.shape
        return f"{self.folder.name}/{name}"

    def commit(self, log: ObservationLog, fov_deg: float | None = None, fov_source: str = "") -> None:
        """Write the log's CSV (its ``image`` column naming the added images) and, with
        ``fov_deg``, the field-of-view file (``fov_source`` says where it came from); then move
        the images folder and both files into place (a field-of-view file of an earlier import
        of the same log is removed when there is none now)."""
        try:
            self._commit(log, fov_deg, fov_source)
        except OSError as e:
            raise ImageLogError(f"{self.log_path}: cannot write the image log ({e.strerror or e})") from None

    def _commit(self, log: ObservationLog, fov_deg: float | None, fov_source: str) -> None:
        config = camera_config_path(self.log_path)
        with atomic_path(self.log_path) as csv_tmp:
            log.write_csv(csv_tmp)
            if fov_deg is None:
                config.unlink(missing_ok=True)
            else:
                with atomic_path(config) as config_tmp:
                    config_tmp.write_text(
                        f"# The field of view of the camera that took {self.log_path.name}'s images "
                        f"({fov_source}).\n# Replay with it: ratslam-harness replay {self.log_path.name} "
                        f"--config {config.name}\n[ratslam.view]\nfield_of_view_deg = {fov_deg!r}\n"
                    )
            if self.folder.exists():
                shutil.rmtree(self.folder)
            self._stage.rename(self.folder)


def check_outputs(out: Path, inputs: tuple) -> None:
    """Refuse an images folder that would replace one of the inputs (a bag directory, a video)."""
    folder = images_folder(out)
    for f in inputs:
        if f is not None and os.path.realpath(folder) == os.path.realpath(f):
            raise ImageLogError(
                f"{folder}: is the input {f}; the images folder would replace it (choose another --out)"
            )
