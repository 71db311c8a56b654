"""Observation logs from recorded trajectories: TUM files of odometry (and ground truth) plus
place labels (a ``t,scene_id`` CSV) or scene numbers synthesised from the ground truth.

TUM format: one pose per line, ``t x y z qx qy qz qw`` (``#`` comments allowed); only x, y and
the yaw of the quaternion are used (a planar robot). Odometry poses become ticks: tick k runs
from pose k - 1 to pose k, with ``v_trans`` the forward motion over the tick (in the frame of
the midpoint heading, as the simulator's odometry) and ``v_rot`` the heading change, per second.

Labels: each tick gets the latest label up to half a median tick after its time (so time
stamps rounded or jittered by less than that land on their tick), if that label is younger than
``label_max_age`` seconds (default: two median tick lengths); otherwise -1 (nothing
recognisable). Ground truth, if given, is interpolated at the tick times (metrics only); with
given labels nothing is known of false positives, so that column is all 0.

Every problem is one line naming the file, the line and the problem
(:class:`TrajectoryImportError`); nothing is written on error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError
from .files import read_text
from .geometry import wrap_angle
from .observation_log import SCENE_ID_MAX, SCENE_ID_MIN, ObservationLog, parse_int
from .real_data import labelled_log
from .world import SceneSpec


class TrajectoryImportError(InputError):
    """A malformed trajectory or label file (one line: file, line, problem)."""


def _read_rows(path: Path, columns: int, what: str) -> np.ndarray:
    text = read_text(path, TrajectoryImportError)
    rows: list[list[float]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        fields = line.replace(",", " ").split()
        if len(fields) != columns:
            raise TrajectoryImportError(
                f"{path}: line {number}: expected {columns} columns ({what}), got {len(fields)}"
            )
        try:
            values = [float(f) for f in fields]
        except ValueError:
            raise TrajectoryImportError(f"{path}: line {number}: not a number in {line!r}") from None
        if not all(math.isfinite(v) for v in values):
            raise TrajectoryImportError(f"{path}: line {number}: non-finite value in {line!r}")
        if rows and values[0] <= rows[-1][0]:
            raise TrajectoryImportError(
                f"{path}: line {number}: t: {values[0]!r} is not after the previous line's {rows[-1][0]!r} (time order)"
            )
        rows.append(values)
    if len(rows) < 2:
        raise TrajectoryImportError(f"{path}: needs at least 2 rows, got {len(rows)}")
    return np.array(rows)


def read_tum(path) -> np.ndarray:
    """Planar poses (n, 4) ``t, x, y, yaw`` from a TUM trajectory file."""
    path = Path(path)
    rows = _read_rows(path, 8, "t x y z qx qy qz qw")
    qx, qy, qz, qw = rows[:, 4], rows[:, 5], rows[:, 6], rows[:, 7]
    norm = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    bad = np.flatnonzero(norm < 1e-9)
    if bad.size:
        raise TrajectoryImportError(f"{path}: pose {bad[0] + 1}: quaternion of zero length")
    yaw = np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    return np.column_stack([rows[:, 0], rows[:, 1], rows[:, 2], yaw])


@dataclass(frozen=True)
class PlaceLabels:
    """Place labels in time order: ``t`` (m,) seconds and ``scene_id`` (m,) integers (kept as
    int64 end to end: ids up to 2**63 - 1 stay distinct)."""

    t: np.ndarray
    scene_id: np.ndarray


def place_labels(rows: list[tuple[float, int]], where: str, error: type[Exception]) -> PlaceLabels:
    """Labels from ``(t, scene_id)`` pairs (time order kept, stable), each id checked against the
    observation log's range (-1 = no scene, up to 2**63 - 1); ``where`` names the source."""
    for time, scene in rows:
        if not SCENE_ID_MIN <= scene <= SCENE_ID_MAX:
            raise error(f"{where}: scene_id {scene} at t={time!r}: must be in {SCENE_ID_MIN}..{SCENE_ID_MAX}")
    times = np.array([r[0] for r in rows], dtype=float)
    ids = np.array([r[1] for r in rows], dtype=np.int64)
    order = np.argsort(times, kind="stable")
    return PlaceLabels(times[order], ids[order])


def read_labels(path) -> PlaceLabels:
    """Place labels from a CSV with header ``t,scene_id``."""
    path = Path(path)
    lines = read_text(path, TrajectoryImportError).splitlines()
    header = [h.strip() for h in lines[0].lstrip("\ufeff").split(",")] if lines else []
    if header != ["t", "scene_id"]:
        raise TrajectoryImportError(f"{path}: line 1: expected the header 't,scene_id', got {','.join(header)!r}")
    rows: list[tuple[float, int]] = []
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        fields = [f.strip() for f in line.split(",")]
        if len(fields) != 2:
            raise TrajectoryImportError(f"{path}: line {number}: expected 2 columns (t,scene_id), got {len(fields)}")
        try:
            t = float(fields[0])
        except ValueError:
            raise TrajectoryImportError(f"{path}: line {number}: t: not a number: {fields[0]!r}") from None
        scene = parse_int(fields[1])
        if scene is None:
            raise TrajectoryImportError(f"{path}: line {number}: scene_id: not an integer: {fields[1]!r}")
        if not math.isfinite(t):
            raise TrajectoryImportError(f"{path}: line {number}: t: not finite")
        if rows and t <= rows[-1][0]:
            raise TrajectoryImportError(
                f"{path}: line {number}: t: {t!r} is not after the previous line's {rows[-1][0]!r} (time order)"
            )
        rows.append((t, scene))
    if not rows:
        raise TrajectoryImportError(f"{path}: no labels")
    return place_labels(rows, str(path), TrajectoryImportError)


def odometry_from_tum(poses: np.ndarray):
    """Ticks (t, dt, v_trans, v_rot) between consecutive odometry poses (midpoint heading)."""
    t = poses[:, 0]
    dt = np.diff(t)
    d = np.diff(poses[:, 1:3], axis=0)
    dtheta = wrap_angle(np.diff(poses[:, 3]))
    mid = poses[:-1, 3] + dtheta / 2
    v_trans = (d[:, 0] * np.cos(mid) + d[:, 1] * np.sin(mid)) / dt
    return t[1:], dt, v_trans, dtheta / dt


def _interpolate_poses(poses: np.ndarray, t: np.ndarray, path) -> np.ndarray:
    if t[0] < poses[0, 0] - 1e-9 or t[-1] > poses[-1, 0] + 1e-9:
        raise TrajectoryImportError(
            f"{path}: ground truth covers {poses[0, 0]:.3f}-{poses[-1, 0]:.3f} s, "
            f"the odometry ticks {t[0]:.3f}-{t[-1]:.3f} s"
        )
    x = np.interp(t, poses[:, 0], poses[:, 1])
    y = np.interp(t, poses[:, 0], poses[:, 2])
    yaw = np.unwrap(poses[:, 3])
    theta = wrap_angle(np.interp(t, poses[:, 0], yaw))
    return np.column_stack([x, y, theta])


def labels_at(labels: PlaceLabels, t: np.ndarray, max_age: float, slack: float = 0.0) -> np.ndarray:
    """Scene number per tick: the latest label at or before the tick's time plus ``slack``, if
    younger than ``max_age``."""
    k = np.searchsorted(labels.t, t + slack, side="right") - 1
    out = np.full(len(t), -1, dtype=np.int64)
    ok = k >= 0
    ok[ok] = t[ok] - labels.t[k[ok]] < max_age
    out[ok] = labels.scene_id[k[ok]]
    return out


def assemble_log(
    t,
    dt,
    v,
    w,
    gt: np.ndarray | None,
    labels: PlaceLabels | None,
    synthesise: SceneSpec | None,
    label_max_age: float | None,
    seed: int,
    gt_missing: str,
    error: type[Exception] = TrajectoryImportError,
) -> ObservationLog:
    """The observation log of imported ticks: ``labels`` held to the
    ticks, or scene numbers synthesised from the ground truth ``gt`` (n, 3) (``error(gt_missing)``
    is raised when it is absent)."""
    if synthesise is not None:
        if gt is None:
            raise error(gt_missing)
        return labelled_log(t, dt, v, w, gt[:, 0], gt[:, 1], gt[:, 2], synthesise, seed)
    if labels is None:
        raise error("neither place labels nor scene numbers to synthesise")
    age = 2.0 * float(np.median(dt)) if label_max_age is None else float(label_max_age)
    return unlabelled_log(t, dt, v, w, gt, labels_at(labels, t, age, slack=0.5 * float(np.median(dt))))


def unlabelled_log(t, dt, v, w, gt: np.ndarray | None = None, scene: np.ndarray | None = None) -> ObservationLog:
    """Imported ticks with the ground truth ``gt`` (n, 3) where there is one, and ``scene``
    numbers, or none (-1: an image log's odometry)."""
    scene = np.full(len(t), -1, dtype=np.int64) if scene is None else scene
    if gt is None:
        return ObservationLog(t=t, dt=dt, v_trans=v, v_rot=w, scene_id=scene)
    return ObservationLog(
        t=t,
        dt=dt,
        v_trans=v,
        v_rot=w,
        scene_id=scene,
        gt_x=gt[:, 0],
        gt_y=gt[:, 1],
        gt_theta=gt[:, 2],
        false_positive=np.zeros(len(t), dtype=bool),
    )


def tum_odometry(odometry, ground_truth=None) -> tuple[ObservationLog, float]:
    """The ticks of a TUM odometry trajectory without scene numbers, the ground truth (TUM)
    interpolated at them if given, and the time of the first pose (the start of the first tick)."""
    poses = read_tum(odometry)
    t, dt, v, w = odometry_from_tum(poses)
    gt = None if ground_truth is None else _interpolate_poses(read_tum(ground_truth), t, ground_truth)
    return unlabelled_log(t, dt, v, w, gt), float(poses[0, 0])


def import_tum(
    odometry,
    ground_truth=None,
    labels=None,
    synthesise: SceneSpec | None = None,
    label_max_age: float | None = None,
    seed: int = 0,
) -> ObservationLog:
    """An observation log from a TUM odometry trajectory, with place labels from ``labels``
    (a ``t,scene_id`` CSV) or synthesised from ``ground_truth`` by the scene model ``synthesise``."""
    if (labels is None) == (synthesise is None):
        raise TrajectoryImportError("labels: give either a label CSV or ask for synthesised scene numbers")
    t, dt, v, w = odometry_from_tum(read_tum(odometry))
    gt = None if ground_truth is None else _interpolate_poses(read_tum(ground_truth), t, ground_truth)
    return assemble_log(
        t,
        dt,
        v,
        w,
        gt,
        None if labels is None else read_labels(labels),
        synthesise,
        label_max_age,
        seed,
        "ground truth: synthesised scene numbers need a ground-truth trajectory",
    )
