"""Rerun recording of a run (``recording.rrd``), written incrementally, tick by tick.

Timelines: ``tick`` (sequence: step index k) and ``sim_time`` (duration: simulated seconds).

Entity paths (world quantities in metres; the ``/world`` and ``/pose_cells`` subtrees carry a
static mirror transform so that y points up in the viewer, the data themselves are unchanged):

=============================  ===================================================================
``world/walls``                wall segments (static)
``world/ground_truth``         one segment per tick (previous -> current true position)
``world/odometry``             one segment per tick, dead reckoning anchored at the first true pose
``world/false_positives``      a point where a false-positive scene was reported (true position)
``world/ratslam/experiences``  experience map nodes, re-logged every ``every_map`` ticks or more (below)
``world/ratslam/links``        experience map transitions (segments), re-logged with the nodes
``world/gtsam/estimate``       GTSAM keyframe trajectory, re-logged with the experience map
``world/gtsam/closures``       accepted GTSAM loop closures (segments), every ``every_closures`` ticks
``pose_cells/grid``            4 x 4-cell grid lines (static)
``pose_cells/activity``        x'y' projection (sum over θ') of the pose-cell activity, RGB image,
                               every ``every_activity`` ticks; pixel (x', y') is cell (x', y')
``pose_cells/peak``            peak trail in cell coordinates, one segment per tick; snaps
                               (``ratslam.snapped``) drawn as thin red lines, wrap-arounds not drawn
``metrics/ate/*``              ATE so far (m): odometry, experience_map, gtsam (with ground truth)
``metrics/count/*``            experiences, links, snaps, keyframes (every ``every_map`` ticks),
                               accepted loop closures (every ``every_closures`` ticks)
``metrics/<key>``              anything passed to :meth:`Recorder.log_metrics`
``camera/image``               a camera run's view each tick, grey levels (:meth:`Recorder.log_view`)
``camera/template``            the stored template the view matched (or the new one it made), each tick
=============================  ===================================================================

The experience map and the GTSAM estimate change under correction/optimisation, so they are
logged whole, every ``every_map`` ticks while the maps hold fewer than ``map_size`` places
(experiences and keyframes), then every ``every_map`` times ``size // map_size`` ticks, so that a
re-log's cost, which grows with the maps, stays a fixed share of a long run (and at the last tick);
trajectories are one segment per tick. With ground truth, both maps are drawn after SE(2) alignment
(:func:`harness.report.metrics.ate`) of their poses onto the true poses at the ticks each
experience was last active / each keyframe was taken, computed at each re-log; without ground
truth they are drawn in their own frames.
"""

from __future__ import annotations

import contextlib
import math
import os
import uuid
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal, Self

import numpy as np
import pyarrow as pa
import rerun as rr
from rerun.components import LineStrip2DBatch
from rerun.encodings import Vec2DBatch

from ..report import metrics
from .blueprint import default_blueprint

# Colours (RGBA) on the viewer's dark background.
C_WALLS = (200, 200, 200, 255)
C_GT = (240, 240, 240, 200)
C_ODOM = (255, 150, 30, 220)
C_EXP = (70, 160, 255, 255)
C_LINK = (70, 160, 255, 140)
C_GTSAM = (230, 60, 200, 230)
C_CLOSURE = (230, 60, 200, 120)
C_FP = (255, 40, 40, 255)
C_PEAK = (0, 255, 255, 255)
C_SNAP = (255, 50, 50, 255)
C_GRID = (255, 255, 255, 40)

_MIRROR_Y = rr.Transform3D(scale=[1.0, -1.0, 1.0])


def _viridis_lut() -> np.ndarray:
    from matplotlib import colormaps

    return (colormaps["viridis"](np.linspace(0, 1, 256))[:, :3] * 255).astype(np.uint8)


def _segments(segs: np.ndarray) -> pa.Array:
    """Line strips of two points each, ``(n, 2, 2)``, as the Arrow array rerun stores.

    Built in one go: the SDK's own conversion walks the strips in Python (measured 40x slower
    for 6,500 transitions)."""
    segs = np.array(segs, dtype=np.float32, copy=True).reshape(-1, 2, 2)  # never alias the caller's buffer
    offsets = pa.array(np.arange(0, 2 * len(segs) + 1, 2, dtype=np.int32))
    return pa.ListArray.from_arrays(
        offsets, Vec2DBatch(segs.reshape(-1, 2)).as_arrow_array(), type=LineStrip2DBatch._ARROW_DATATYPE
    )


class _SegmentBuffer:
    """Per-tick segments of one entity, sent in columns every ``capacity`` rows."""

    def __init__(self, entity: str, capacity: int):
        self.entity = entity
        self.ticks = np.zeros(capacity, np.int64)
        self.times = np.zeros(capacity, np.float64)
        self.segs = np.zeros((capacity, 2, 2), np.float32)
        self.colors = np.zeros((capacity, 4), np.uint8)
        self.radii = np.zeros(capacity, np.float32)
        self.n = 0

    def add(self, tick, t, a, b, color, radius) -> bool:
        i = self.n
        self.ticks[i], self.times[i] = tick, t
        self.segs[i, 0], self.segs[i, 1] = a, b
        self.colors[i], self.radii[i] = color, radius
        self.n += 1
        return self.n == len(self.ticks)

    def send(self, rec: rr.RecordingStream) -> None:
        n = self.n
        if n == 0:
            return
        # Copies: the SDK may keep referencing the arrays after send_columns returns (zero-copy),
        # and these buffers are overwritten by the next rows.
        rec.send_columns(
            self.entity,
            indexes=[
                rr.TimeColumn("tick", sequence=self.ticks[:n].copy()),
                rr.TimeColumn("sim_time", duration=self.times[:n].copy()),
            ],
            columns=rr.LineStrips2D.columns(
                strips=_segments(self.segs[:n]), colors=self.colors[:n].copy(), radii=self.radii[:n].copy()
            ),
        )
        self.n = 0


class _ImageBuffer:
    """Per-tick images of one entity (grey levels, ``color_model`` "L", or "RGB"), sent in columns
    every ``capacity`` rows (one ``log`` call per image costs about 30 times as much)."""

    def __init__(self, entity: str, capacity: int, color_model: Literal["L", "RGB"] = "L"):
        self.entity, self.capacity, self.color_model = entity, capacity, color_model
        self.ticks: list[int] = []
        self.times: list[float] = []
        self.images: list[np.ndarray] = []

    def add(self, tick: int, t: float, image) -> bool:
        self.ticks.append(tick)
        self.times.append(t)
        self.images.append(np.array(image, dtype=np.uint8, copy=True))  # never alias the caller's buffer
        return len(self.ticks) == self.capacity

    def send(self, rec: rr.RecordingStream) -> None:
        if not self.ticks:
            return
        formats = [
            rr.components.ImageFormat(
                width=im.shape[1], height=im.shape[0], color_model=self.color_model, channel_datatype="U8"
            )
            for im in self.images
        ]
        rec.send_columns(
            self.entity,
            indexes=[
                rr.TimeColumn("tick", sequence=np.array(self.ticks, np.int64)),
                rr.TimeColumn("sim_time", duration=np.array(self.times, np.float64)),
            ],
            columns=rr.Image.columns(buffer=[im.ravel() for im in self.images], format=formats),
        )
        self.ticks, self.times, self.images = [], [], []


class _ClosedOnSuccess:
    """Context manager: ``close()`` when the block succeeds, ``abort()`` on an error (or Ctrl-C),
    so a failing run leaves no half-written recording behind."""

    def close(self) -> Path:
        raise NotImplementedError

    def abort(self) -> None:
        raise NotImplementedError

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        else:
            self.abort()


class Recorder(_ClosedOnSuccess):
    """Writes ``recording.rrd`` for one run; feed it every tick with :meth:`log_tick`.

    Parameters
    ----------
    path:
        Output ``.rrd`` file (written atomically on :meth:`close`).
    walls:
        ``(W, 2, 2)`` wall segments in metres, or None.
    grid_shape:
        Pose-cell grid ``(nx, ny, nθ)``.
    every_activity:
        Log the pose-cell activity image every this many ticks (default 35: 5 s at 7 Hz).
    every_map:
        Re-log the experience map, the GTSAM estimate and the live metrics every this many
        ticks (default 70: 10 s at 7 Hz) while the maps are small (``map_size``).
    map_size:
        Experiences and keyframes together per multiple of ``every_map`` between re-logs
        (default 1000): a map of 6,000 places is re-logged every 6 x ``every_map`` ticks.
    every_closures:
        Re-log GTSAM's accepted loop closures every this many ticks (default 700: 100 s at 7 Hz;
        reading the acceptance flags costs the baseline a pass over all its closures).
    flush_every:
        Per-tick segments (and camera views) are buffered and sent in columns of this many rows
        (default 700: a send costs about as much as a hundred rows).
    align:
        Draw the experience map and GTSAM estimate aligned to ground truth (when given).
    world_bounds:
        ``(x0, y0, x1, y1)`` framing the world panel; default: the walls' bounding box.
    navigation:
        The default blueprint's goal-navigation panels (:mod:`harness.navigation.experiment` logs them).
    camera:
        The default blueprint's camera panels (the view and its matched template, :meth:`log_view`).
    application_id, recording_id:
        Rerun identifiers (default recording id: random). The file's content is determined by
        the inputs; its bytes are not (rerun's chunk and row ids are time-based).
    """

    def __init__(
        self,
        path,
        walls=None,
        grid_shape=(60, 60, 36),
        *,
        every_activity: int = 35,
        every_map: int = 70,
        every_closures: int = 700,
        map_size: int = 1000,
        flush_every: int = 700,
        align: bool = True,
        world_bounds=None,
        application_id: str = "ratslam-harness",
        recording_id: str | None = None,
        navigation: bool = False,
        camera: bool = False,
    ):
        for name, v in (
            ("every_activity", every_activity),
            ("every_map", every_map),
            ("every_closures", every_closures),
            ("map_size", map_size),
            ("flush_every", flush_every),
        ):
            if not (isinstance(v, (int, np.integer)) and v >= 1):
                raise ValueError(f"{name} must be a positive integer number of ticks, got {v!r}")
        if len(grid_shape) < 2 or min(int(g) for g in grid_shape[:2]) < 1:
            raise ValueError(f"grid_shape must be (nx, ny[, nθ]) positive cell counts, got {grid_shape!r}")
        self.path = Path(path)
        self.grid_shape = tuple(int(g) for g in grid_shape)
        self.every_activity, self.every_map, self.align = int(every_activity), int(every_map), bool(align)
        self.every_closures, self.map_size = int(every_closures), int(map_size)
        self.camera = bool(camera)
        walls = None if walls is None else np.asarray(walls, dtype=float).reshape(-1, 2, 2)
        if world_bounds is None and walls is not None and len(walls):
            pts = walls.reshape(-1, 2)
            world_bounds = (*pts.min(axis=0), *pts.max(axis=0))
        self._tmp = self.path.parent / f".{self.path.name}.partial-{os.getpid()}-{uuid.uuid4().hex[:8]}"
        self.rec = rr.RecordingStream(application_id, recording_id=recording_id or uuid.uuid4().hex)
        self.rec.set_log_time_enabled(False)  # only the tick and sim_time timelines
        self.rec.set_log_tick_enabled(False)
        # The encoded stream is kept in memory (about the file's size) and written by this process
        # at close (not rerun's file sink: a sink that fails on a full disk as it starts hangs
        # ``rr.save`` uninterruptibly, rerun 0.41), so a write error is an ``OSError`` here and
        # Ctrl-C always reaches Python. One read: a stream read in pieces repeats its footer.
        self._stream = rr.binary_stream(recording=self.rec)
        self.rec.send_blueprint(
            default_blueprint(self.grid_shape, world_bounds, navigation, camera=camera),
            make_active=False,
            make_default=True,
        )
        self._file = open(self._tmp, "wb")  # noqa: SIM115 (closed by close() or abort())
        self._closed = False
        self._lut = _viridis_lut()
        self._buffers = {
            name: _SegmentBuffer(name, int(flush_every))
            for name in ("world/ground_truth", "world/odometry", "pose_cells/peak")
        }
        self._images = {name: _ImageBuffer(name, int(flush_every)) for name in ("camera/image", "camera/template")}
        self._images["pose_cells/activity"] = _ImageBuffer("pose_cells/activity", max(1, int(flush_every) // 10), "RGB")
        cap = 1024
        self._gt = np.full((cap, 3), np.nan)  # ground truth per tick, for alignment and live ATE
        self._odom = np.full((cap, 3), np.nan)
        self._prev: dict[str, tuple[float, float]] = {}
        # (cos, sin, tx, ty): odometry frame -> ground-truth frame, from the first tick
        self._anchor: tuple[float, float, float, float] | None = None
        self._snaps = 0
        self._last: tuple[int, float, Any, Any] | None = None  # (tick, t, ratslam, gtsam) of the last log_tick
        self._last_map_tick: int | None = None
        self._next_map_tick = self._next_closures_tick = 0
        self._static(walls)

    # ------------------------------------------------------------------ static content
    def _static(self, walls) -> None:
        rec = self.rec
        rec.log("world", _MIRROR_Y, static=True)
        rec.log("pose_cells", _MIRROR_Y, static=True)
        if walls is not None and len(walls):
            rec.log("world/walls", rr.LineStrips2D(walls, colors=[C_WALLS], radii=[0.03]), static=True)
        nx, ny = self.grid_shape[:2]
        xs, ys = np.arange(0, nx + 1, 4, dtype=float), np.arange(0, ny + 1, 4, dtype=float)
        lines = [[[x, 0], [x, ny]] for x in xs] + [[[0, y], [nx, y]] for y in ys]
        rec.log("pose_cells/grid", rr.LineStrips2D(lines, colors=[C_GRID], radii=[0.04]), static=True)
        # the activity image's cells drawn as blocks, under the peak's trail (its pixels come per tick)
        rec.log(
            "pose_cells/activity", rr.Image.from_fields(magnification_filter="Nearest", draw_order=-10.0), static=True
        )
        if self.camera:
            for name in ("camera/image", "camera/template"):
                rec.log(name, rr.Image.from_fields(magnification_filter="Nearest"), static=True)

    # ------------------------------------------------------------------ per tick
    def _grow(self, k: int) -> None:
        if k >= len(self._gt):
            n = max(k + 1, 2 * len(self._gt))
            for name in ("_gt", "_odom"):
                old = getattr(self, name)
                new = np.full((n, 3), np.nan)
                new[: len(old)] = old
                setattr(self, name, new)

    def _segment(
        self, name: str, tick: int, t: float, x: float, y: float, color, radius: float, draw: bool = True
    ) -> None:
        prev = self._prev.get(name)
        self._prev[name] = (x, y)
        if prev is None or not draw:
            return
        buf = self._buffers[name]
        if buf.add(tick, t, prev, (x, y), color, radius):
            buf.send(self.rec)

    def log_tick(
        self, tick: int, t: float, gt_xyt, odom_xyt, ratslam=None, gtsam=None, false_positive: bool = False
    ) -> None:
        """Record step ``tick`` (step index k, increasing) at simulated time ``t`` seconds.

        ``gt_xyt``: true pose (x, y, θ) or None; ``odom_xyt``: dead-reckoned pose in its own
        frame (anchored to the first true pose for display); ``ratslam``/``gtsam``: the systems
        (read through the attributes of ``ratslam.RatSLAM`` / ``baselines.PoseGraphSLAM``) or
        None; ``false_positive``: whether this tick's scene was a false positive.
        """
        if self._closed:
            raise RuntimeError("Recorder.log_tick: the recording is closed")
        k, t = int(tick), float(t)
        if k >= len(self._gt):
            self._grow(k)
        ox, oy, oth = (float(v) for v in odom_xyt[:3])
        self._odom[k] = (ox, oy, oth)
        if gt_xyt is not None:
            gx, gy, gth = (float(v) for v in gt_xyt[:3])
            self._gt[k] = (gx, gy, gth)
            if self._anchor is None:  # odometry frame -> world: make the first poses coincide
                dth = gth - oth
                c, s = math.cos(dth), math.sin(dth)
                self._anchor = (c, s, gx - (c * ox - s * oy), gy - (s * ox + c * oy))
            self._segment("world/ground_truth", k, t, gx, gy, C_GT, 0.025)
        c, s, ax, ay = self._anchor if self._anchor is not None else (1.0, 0.0, 0.0, 0.0)
        wx, wy = c * ox - s * oy + ax, s * ox + c * oy + ay
        self._segment("world/odometry", k, t, wx, wy, C_ODOM, 0.02)
        if false_positive:
            where = (gx, gy) if gt_xyt is not None else (wx, wy)
            self.rec.set_time("tick", sequence=k)
            self.rec.set_time("sim_time", duration=t)
            self.rec.log("world/false_positives", rr.Points2D([where], colors=[C_FP], radii=[0.12]))
        if ratslam is not None:
            peak = ratslam.peak
            px, py = float(peak[0]) + 0.5, float(peak[1]) + 0.5  # cell i covers [i, i + 1) in the image
            snapped = bool(ratslam.snapped)
            self._snaps += snapped
            prev = self._prev.get("pose_cells/peak")
            nx, ny = self.grid_shape[0], self.grid_shape[1]
            wrapped = prev is not None and (abs(px - prev[0]) > nx / 2 or abs(py - prev[1]) > ny / 2)
            self._segment(
                "pose_cells/peak",
                k,
                t,
                px,
                py,
                C_SNAP if snapped else C_PEAK,
                0.06 if snapped else 0.18,
                draw=snapped or not wrapped,
            )
            if k % self.every_activity == 0:
                self._log_activity(k, t, ratslam)
        self._last = (k, t, ratslam, gtsam)
        if k >= self._next_map_tick:
            places = self._log_maps(k, t, ratslam, gtsam)
            self._next_map_tick = k + self.every_map * max(1, places // self.map_size)

    def log_view(self, tick: int, t: float, image, template) -> None:
        """Record a camera run's view at step ``tick`` and the template it matched (both 2-D
        grey levels, uint8)."""
        for name, im in (("camera/image", image), ("camera/template", template)):
            buf = self._images[name]
            if buf.add(int(tick), float(t), im):
                buf.send(self.rec)

    def _log_activity(self, k: int, t: float, ratslam) -> None:
        proj = np.asarray(ratslam.pose_cell_activity).sum(axis=2)  # (nx, ny)
        top = proj.max()
        level = (proj / top * 255).astype(np.uint8) if top > 0 else np.zeros(proj.shape, np.uint8)
        # image rows are y', columns x': pixel (x', y') covers cell (x', y')
        buf = self._images["pose_cells/activity"]
        if buf.add(k, t, self._lut[level.T]):
            buf.send(self.rec)

    def _aligned(self, poses: np.ndarray, ticks: np.ndarray):
        """Poses moved into the ground-truth frame (and the ATE), or unchanged without ground truth."""
        if self.align and len(poses) >= 2:
            ref = self._gt[np.asarray(ticks, dtype=np.int64)]
            ok = np.isfinite(ref[:, 0])
            if ok.sum() >= 2:
                res = metrics.ate(poses[ok], ref[ok])
                return res.apply(poses[:, :2]), res.rmse
        return poses[:, :2], None

    def _log_maps(self, k: int, t: float, ratslam, gtsam, final: bool = False) -> int:
        """Log the maps at tick ``k``; returns their size (experiences and keyframes)."""
        rec = self.rec
        rec.set_time("tick", sequence=k)
        rec.set_time("sim_time", duration=t)
        self._last_map_tick = k
        scalars: dict[str, float] = {"count/snaps": self._snaps}
        places = 0
        if ratslam is not None:
            poses = np.asarray(ratslam.experience_poses, dtype=float).reshape(-1, 3)
            links = np.asarray(ratslam.links, dtype=np.int64).reshape(-1, 2)
            if len(poses):
                xy, err = self._aligned(poses, ratslam.experience_first_tick)
                rec.log("world/ratslam/experiences", rr.Points2D(xy, colors=[C_EXP], radii=[0.07]))
                rec.log("world/ratslam/links", rr.LineStrips2D(_segments(xy[links]), colors=[C_LINK], radii=[0.025]))
                if err is not None:
                    scalars["ate/experience_map"] = err
            scalars["count/experiences"] = len(poses)
            places += len(poses)
            scalars["count/links"] = len(links)
        if gtsam is not None:
            kf = np.asarray(gtsam.keyframe_poses, dtype=float).reshape(-1, 3)
            if len(kf):
                xy, err = self._aligned(kf, gtsam.keyframe_ticks)
                rec.log("world/gtsam/estimate", rr.LineStrips2D([xy], colors=[C_GTSAM], radii=[0.03]))
                if err is not None:
                    scalars["ate/gtsam"] = err
                if final or k >= self._next_closures_tick:
                    self._next_closures_tick = k + self.every_closures
                    pairs = np.asarray(gtsam.loop_closures, dtype=np.int64).reshape(-1, 2)
                    acc = np.asarray(gtsam.closure_accepted, dtype=bool).reshape(-1)
                    rec.log(
                        "world/gtsam/closures",
                        rr.LineStrips2D(_segments(xy[pairs[acc]]), colors=[C_CLOSURE], radii=[0.015]),
                    )
                    scalars["count/loop_closures_accepted"] = int(acc.sum())
            scalars["count/keyframes"] = len(kf)
            places += len(kf)
        gt, od = self._gt[: k + 1], self._odom[: k + 1]
        ok = np.flatnonzero(np.isfinite(gt[:, 0]) & np.isfinite(od[:, 0]))
        if len(ok) >= 2:
            ok = ok[:: max(1, len(ok) // 5000)]
            scalars["ate/odometry"] = metrics.ate_rmse(od[ok], gt[ok])
        for name, v in scalars.items():
            rec.log(f"metrics/{name}", rr.Scalars([float(v)]))
        return places

    # ------------------------------------------------------------------ metrics, closing
    def log_metrics(self, tick: int, values: Mapping, t: float | None = None) -> None:
        """Log numbers as ``metrics/<key>`` scalars at ``tick`` (nested mappings become
        ``metrics/<key>/<subkey>``; non-numeric and non-finite values are skipped)."""
        self.rec.set_time("tick", sequence=int(tick))
        if t is not None:
            self.rec.set_time("sim_time", duration=float(t))

        def walk(prefix, d):
            for key, v in d.items():
                name = f"{prefix}/{key}"
                if isinstance(v, Mapping):
                    walk(name, v)
                elif isinstance(v, (bool, int, float, np.integer, np.floating)) and math.isfinite(float(v)):
                    self.rec.log(name, rr.Scalars([float(v)]))

        walk("metrics", values)

    def flush(self) -> None:
        """Send buffered per-tick segments now."""
        for buf in self._buffers.values():
            buf.send(self.rec)
        for images in self._images.values():
            images.send(self.rec)

    def _drain(self) -> None:
        data = self._stream.read(flush=True)
        if data:
            self._file.write(data)

    def finish_maps(self) -> None:
        """Log the maps as they are now at the last logged tick, unless that tick already has
        them (:meth:`close` does this; call it earlier if the systems change afterwards)."""
        if self._last is not None and self._last_map_tick != self._last[0]:
            k, t, rs, pg = self._last
            if rs is not None:
                self._log_activity(k, t, rs)
            self._log_maps(k, t, rs, pg, final=True)

    def close(self) -> Path:
        """Log the final maps, finish the file and move it to ``path``. Returns ``path``."""
        if self._closed:
            return self.path
        self.finish_maps()
        self.flush()
        self.rec.disconnect()
        self._drain()  # the whole stream at once: its footer indexes it from the file's start
        self._file.close()
        self._closed = True
        os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Stop recording and delete the partial file."""
        if not self._closed:
            self._closed = True
            self.rec.disconnect()
            with contextlib.suppress(OSError):  # the write that failed (a full disk) may fail again
                self._file.close()
            Path(self._tmp).unlink(missing_ok=True)


class StreamRecorder(_ClosedOnSuccess):
    """A :class:`Recorder` fed from an observation log, for the runner's per-tick callback.

    ``on_tick(k, ratslam, gtsam)`` logs tick k with the log's time, ground truth (if any),
    dead-reckoned odometry and false-positive flag (from a camera also the view and the template it
    matched: ``camera``, a :class:`harness.camera.stream.CameraViews`, with ``views``, each tick's
    template number); ``close()`` finishes the file. Used as a
    context manager, it closes on success and aborts (removes the partial file) on an error.
    """

    def __init__(
        self, recorder: Recorder, t, odometry, ground_truth=None, false_positive=None, camera=None, views=None
    ):
        self.recorder = recorder
        self._camera = camera  # harness.camera.stream.CameraViews, or None
        self._views = None if views is None else np.asarray(views, dtype=np.int64)
        self._t = np.asarray(t, dtype=float)
        self._odom = np.asarray(odometry, dtype=float)
        self._gt = None if ground_truth is None else np.asarray(ground_truth, dtype=float)
        self._fp = None if false_positive is None else np.asarray(false_positive, dtype=bool)

    def on_tick(self, k: int, ratslam, gtsam) -> None:
        self.recorder.log_tick(
            k,
            self._t[k],
            None if self._gt is None else self._gt[k],
            self._odom[k],
            ratslam,
            gtsam,
            bool(self._fp[k]) if self._fp is not None else False,
        )
        if self._camera is not None and self._views is not None:
            self.recorder.log_view(k, self._t[k], self._camera.images[k], self._camera.templates[self._views[k]])

    def close(self) -> Path:
        """Finish the recording (see :meth:`Recorder.close`)."""
        return self.recorder.close()

    def abort(self) -> None:
        """Stop recording and delete the partial file (see :meth:`Recorder.abort`)."""
        self.recorder.abort()


def recorder_factory(run_dir, world, log, ratslam_config, odometry, camera=None, **options) -> StreamRecorder:
    """``run_dir/recording.rrd`` for a run of ``log`` (an ``ObservationLog``) in ``world`` (a
    ``World`` or None) with RatSLAM configured by ``ratslam_config``; ``odometry`` (N, 3) is the
    runner's dead reckoning of ``log`` (:func:`harness.run.runner.dead_reckon`); ``camera``: a camera
    run's :class:`harness.camera.stream.CameraViews` (each tick's view and matched template
    recorded, the log's scene numbers being the template numbers); ``options`` go to
    :class:`Recorder`."""
    rec = Recorder(
        Path(run_dir) / "recording.rrd",
        None if world is None else world.walls,
        tuple(ratslam_config.shape),
        camera=camera is not None,
        **options,
    )
    gt = log.ground_truth() if log.has_ground_truth else None
    fp = log.false_positive if log.has_ground_truth else None
    views = None if camera is None else log.scene_id
    return StreamRecorder(rec, log.t, odometry, gt, fp, camera, views)
