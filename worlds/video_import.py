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
* Each tick gets the latest frame at or before it (:func:`worlds.image_log.latest_at_or_before`);
  ticks before the first frame are dropped; only frames some tick uses are converted and written.

A first pass reads the packets' times without decoding: a video that ends before the odometry
(last frame time plus one frame interval, against the last tick less one tick), a frame count
that does not match the timestamps file, or a declared frame size beyond
:data:`~worlds.image_decode.MAX_PIXELS` is one line naming the video and the times or sizes,
before any frame is decoded. A frame whose size differs from the first, or that cannot be decoded,
is one line naming the video and the frame. Nothing is written on error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import InputError
from .files import read_text
from .image_decode import check_size
from .image_log import ImageImport, ImageLogWriter, check_outputs, latest_at_or_before
from .observation_log import ObservationLog
from .trajectory_import import _interpolate_poses, odometry_from_tum, read_tum


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
        log = ObservationLog.read_csv(odometry)
        log = ObservationLog(
            t=log.t,
            dt=log.dt,
            v_trans=log.v_trans,
            v_rot=log.v_rot,
            scene_id=np.full(len(log), -1, dtype=np.int64),
            gt_x=log.gt_x,
            gt_y=log.gt_y,
            gt_theta=log.gt_theta,
            false_positive=None if log.gt_x is None else np.zeros(len(log), dtype=bool),
        )
        return log, float(log.t[0] - log.dt[0])
    poses = read_tum(odometry)
    t, dt, v, w = odometry_from_tum(poses)
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
    return log, float(poses[0, 0])


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
) -> ImageImport:
    """Write the image log ``out`` (CSV and images folder) from a video and an odometry file (see
    the module docstring); the result says how many frames were written and ticks dropped."""
    av = _av()
    video, out = Path(video), Path(out)
    if not video.is_file():
        raise VideoImportError(f"{video}: no such video file")
    check_outputs(out, (video, odometry, timestamps, ground_truth))
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
    pick = latest_at_or_before(frame_t, log.t, slack)
    first = int(np.searchsorted(pick, 0))
    if len(log) - first < 2:
        raise VideoImportError(
            f"{video}: frames from {frame_t[0]:.3f} s leave fewer than 2 odometry ticks "
            f"({log.t[0]:.3f}-{last_tick:.3f} s)"
        )
    pick = pick[first:]
    needed = set(pick.tolist())
    last_needed = int(pick.max())
    names: dict[int, str] = {}
    decoded = 0
    with ImageLogWriter(out) as writer:
        try:
            with av.open(str(video)) as container:
                for k, frame in enumerate(container.decode(video=0)):
                    if k > last_needed:
                        break
                    decoded = k + 1
                    if (frame.width, frame.height) != (width, height):
                        raise VideoImportError(
                            f"{video}: frame {k + 1}: {frame.width} x {frame.height} pixels, the video declares "
                            f"{width} x {height}"
                        )
                    if k in needed:
                        names[k] = writer.add(np.ascontiguousarray(frame.to_ndarray(format="gray")))
        except av.FFmpegError as e:
            raise VideoImportError(f"{video}: frame {decoded + 1}: cannot be decoded ({e})") from None
        missing = sorted(needed - set(names))
        if missing:
            raise VideoImportError(
                f"{video}: frame {missing[0] + 1}: cannot be decoded (the stream ends after {decoded} of the "
                f"{n} frames its packets announce)"
            )
        sliced = ObservationLog(
            t=log.t[first:],
            dt=log.dt[first:],
            v_trans=log.v_trans[first:],
            v_rot=log.v_rot[first:],
            scene_id=log.scene_id[first:],
            gt_x=None if log.gt_x is None else log.gt_x[first:],
            gt_y=None if log.gt_y is None else log.gt_y[first:],
            gt_theta=None if log.gt_theta is None else log.gt_theta[first:],
            false_positive=None if log.false_positive is None else log.false_positive[first:],
            image=np.array([names[k] for k in pick.tolist()], dtype=object),
        )
        writer.commit(sliced)
        shape = writer.shape or ()
    age = sliced.t - frame_t[pick]
    return ImageImport(sliced, len(names), first, 0, float(age.max()), shape, None, "a video does not say")
