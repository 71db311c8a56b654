"""Image logs from a video file and an odometry trajectory (decoder: PyAV, the ``[video]`` extra).

* Odometry: a TUM trajectory (ticks between consecutive poses, as ``import tum``; optional
  ground truth, a TUM file interpolated at the ticks) or an observation log CSV (its ticks and
  ground truth kept, its scene numbers dropped).
* Frame times, on the odometry's clock: ``timestamps``, a file of one time per frame (seconds, one
  a line, ``#`` comments allowed); or frame ``k`` at ``start + k / fps``; or by default the
  container's presentation times, ``start + (pts_k - pts_0) x time base`` (a frame up to half a
  time base after a tick still counts as at it: containers round times to their time base, e.g.
  a millisecond in Matroska). ``start`` is the time of the odometry's first pose (the start of
  its first tick).
* Each tick gets the latest frame at or before it, ticks the frames do not cover are dropped
  (:mod:`worlds.image_pairing`); only frames some tick uses are converted and written
  (:func:`worlds.image_log.write_image_log`).

A first pass reads the packets' times without decoding: a video that ends before the odometry
(last frame time plus one frame interval, against the last tick less one tick), a frame count
that does not match the timestamps file, or a declared frame size beyond
:data:`~worlds.images.MAX_IMAGE_PIXELS` is one line naming the video and the times or sizes,
before any frame is decoded. A frame whose size differs from the first, or that cannot be decoded,
is one line naming the video and the frame. Nothing is written on error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import InputError
from .files import read_text
from .image_log import CameraDescription, ImageImport, check_field_of_view, check_outputs, write_image_log
from .image_pairing import images_per_tick, pair_ticks
from .images import check_size
from .observation_log import ObservationLog
from .trajectory_import import tum_odometry, unlabelled_log


class VideoImportError(InputError):
    """A video, timestamps or odometry file that cannot be imported (one line)."""


def _av():
    try:
        import av
    except ImportError:
        raise VideoImportError("importing video needs PyAV: pip install 'ratslam-harness[video]'") from None
    return av


def read_odometry(odometry, ground_truth=None) -> tuple[ObservationLog, float]:
    """The ticks of a TUM trajectory or an observation log CSV (scene numbers dropped), and the
    time of the first pose (the start of the first tick)."""
    odometry = Path(odometry)
    text = read_text(odometry, VideoImportError)
    first = next((ln.strip() for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")), "")
    if first.lstrip("\ufeff").startswith("t,"):
        if ground_truth is not None:
            raise VideoImportError(f"{ground_truth}: an observation log carries its own ground truth (no --gt)")
        read = ObservationLog.read_csv(odometry)
        log = unlabelled_log(
            read.t, read.dt, read.v_trans, read.v_rot, read.ground_truth() if read.has_ground_truth else None
        )
        return log, float(log.t[0] - log.dt[0])
    return tum_odometry(odometry, ground_truth)


def _read_timestamps(path) -> np.ndarray:
    rows: list[float] = []
    for line, text in enumerate(read_text(path, VideoImportError).splitlines(), start=1):
        cell = text.strip()
        if not cell or cell.startswith("#"):
            continue
        try:
            value = float(cell.split()[0].split(",")[0])
        except ValueError:
            raise VideoImportError(f"{path}: line {line}: not a time in seconds ({cell!r})") from None
        if not np.isfinite(value):
            raise VideoImportError(f"{path}: line {line}: not a finite time ({cell!r})")
        if rows and value <= rows[-1]:
            raise VideoImportError(f"{path}: line {line}: time {value!r} not after the previous one ({rows[-1]!r})")
        rows.append(value)
    if not rows:
        raise VideoImportError(f"{path}: no timestamps")
    return np.array(rows)


def _packet_times(av, video: Path) -> tuple[np.ndarray, float, float, tuple[int, int]]:
    """Presentation times (s, from the first) of the video's frames, read from its packets without
    decoding, the frame interval, the time base (s) and the declared (width, height)."""
    try:
        with av.open(str(video)) as container:
            if not container.streams.video:
                raise VideoImportError(f"{video}: no video stream")
            stream = container.streams.video[0]
            size = int(stream.codec_context.width), int(stream.codec_context.height)
            check_size(*size, f"{video}")
            pts = sorted(p.pts for p in container.demux(stream) if p.pts is not None and p.size > 0)
            base = float(stream.time_base) if stream.time_base else 0.0
            rate = float(stream.average_rate) if stream.average_rate else 0.0
    except av.FFmpegError as e:
        raise VideoImportError(f"{video}: not a readable video ({e})") from None
    if not pts:
        raise VideoImportError(f"{video}: no frames")
    times = (np.array(pts, dtype=np.float64) - pts[0]) * base
    interval = 1.0 / rate if rate > 0 else float(np.median(np.diff(times))) if len(times) > 1 else 0.0
    return times, interval, base, size


def import_video(
    video,
    odometry,
    out,
    fps: float | None = None,
    timestamps=None,
    ground_truth=None,
    fov_deg: float | None = None,
) -> ImageImport:
    """Write the image log ``out`` (CSV and images folder) from a video and an odometry file (see
    the module docstring), with the camera's horizontal field of view ``fov_deg`` (degrees) in its
    ``camera.toml`` if given; the result says how many frames were written and ticks dropped."""
    av = _av()
    video, out = Path(video), Path(out)
    if not video.is_file():
        raise VideoImportError(f"{video}: no such video file")
    check_outputs(out, (video, odometry, timestamps, ground_truth))
    camera = None
    if fov_deg is not None:
        camera = CameraDescription(check_field_of_view(fov_deg, "fov_deg"), source="ratslam-harness import video")
    log, start = read_odometry(odometry, ground_truth)
    times, interval, base, (width, height) = _packet_times(av, video)
    slack = 1e-6  # frame times given exactly; the container's are rounded to its time base
    n = len(times)
    if timestamps is not None:
        frame_t = _read_timestamps(timestamps)
        if len(frame_t) != n:
            raise VideoImportError(f"{video}: {n} frames, but {timestamps} has {len(frame_t)} timestamps")
        interval = float(np.median(np.diff(frame_t))) if n > 1 else interval
    elif fps is not None:
        frame_t = start + np.arange(n) / fps
        interval = 1.0 / fps
    else:
        frame_t = start + times
        slack = max(slack, 0.5 * base)
    video_end = float(frame_t[-1] + interval)
    last_tick = float(log.t[-1])
    if video_end < last_tick - float(np.median(log.dt)):
        raise VideoImportError(
            f"{video}: the video is shorter than the odometry: its {n} frames cover "
            f"{frame_t[0]:.3f}-{video_end:.3f} s, "
            f"the odometry ({odometry}) runs {start:.3f}-{last_tick:.3f} s"
        )
    pairing = pair_ticks(frame_t, log.t, log.dt, slack)
    first, end = pairing.first, pairing.end
    if end - first < 2:
        raise VideoImportError(
            f"{video}: frames from {frame_t[0]:.3f} s leave fewer than 2 odometry ticks "
            f"({log.t[0]:.3f}-{last_tick:.3f} s)"
        )
    pick = pairing.images
    kept = pairing.kept(log)

    def ended(k: int, read: int) -> Exception:
        return VideoImportError(
            f"{video}: frame {k + 1}: cannot be decoded (the stream ends after {read} of the "
            f"{n} frames its packets announce)"
        )

    try:
        with av.open(str(video)) as container:
            frames = _frames(av, container, video, (width, height))
            sliced = write_image_log(out, kept, images_per_tick(frames, pick, _grey, ended), camera)
    except av.FFmpegError as e:
        raise VideoImportError(f"{video}: not a readable video ({e})") from None
    ages = sliced.t - frame_t[pick]
    note = "given" if fov_deg is not None else "a video does not say"
    return ImageImport.written(out, sliced, pairing.dropped(), ages, fov_deg, note)


def _grey(k: int, frame) -> np.ndarray:
    return np.ascontiguousarray(frame.to_ndarray(format="gray"))


def _frames(av, container, video: Path, size: tuple[int, int]):
    """The video's decoded frames in order, each of the declared ``size`` (width, height)."""
    k = 0
    try:
        for frame in container.decode(video=0):
            check_size(
                frame.width, frame.height, f"{video}: frame {k + 1}", first=size, first_is="the video's declared size"
            )
            yield frame
            k += 1
    except av.FFmpegError as e:
        raise VideoImportError(f"{video}: frame {k + 1}: cannot be decoded ({e})") from None
