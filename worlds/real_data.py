"""Real robot odometry as observation logs: the CMU Plaza data sets shipped with gtsam.

``Plaza1_.mat`` and ``Plaza2_.mat`` (in the installed gtsam package's ``Data`` folder) hold a
vehicle's dead reckoning ``DR`` (t, Δdistance m, Δheading rad per sample) and its ground truth
``GT`` (t, x, y, heading; one more row than ``DR``: the start pose). Row k of ``DR`` is the motion
from ``GT[k]`` to ``GT[k + 1]`` (same time stamps). Place labels are synthesised from the ground
truth by the simulator's scene model (:class:`~worlds.scenes.SceneLayout` over the driven path),
so a real robot's odometry meets the same ambiguous, sometimes false scene numbers as a
simulated one.

Heading convention: in ``Plaza2`` the recorded heading points backwards (the ground-truth
displacement is at ≈ 180° to it on 99.8% of moving samples; in ``Plaza1`` at ≈ 1°). The importer
measures this and turns the ground-truth heading by π where the displacement runs against it,
so that ``x += v cos θ`` holds for the ground truth as for the odometry.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from .errors import InputError
from .geometry import wrap_angle
from .observation_log import ObservationLog
from .scenes import SceneLayout, observe_scenes
from .world import SceneSpec

PLAZA_SETS = {"plaza1": "Plaza1_.mat", "plaza2": "Plaza2_.mat"}

PLAZA_SCENES = SceneSpec(
    cell_size=2.0,
    heading_sectors=4,
    alias_rate=0.1,
    alias_min_distance=6.0,
    blank_rate=0.1,
    flicker_width=0.2,
    flicker_prob=0.5,
    false_positive_rate=0.002,
)
"""Default scene model for the outdoor Plaza runs: 2 m cells (the vehicle drives 1-3 m/s), four
heading sectors, 10% aliasing (cells at least 6 m apart), 10% blank, 0.2% false positives."""


class RealDataError(InputError):
    """A real data set that is unknown, not installed or malformed (one line: set or file, problem)."""


def plaza_file(name: str) -> Path:
    """Path of a Plaza data set in the installed gtsam package."""
    key = name.lower()
    if key not in PLAZA_SETS:
        raise RealDataError(f"{name}: unknown real data set (known: {', '.join(PLAZA_SETS)})")
    import gtsam

    path = Path(gtsam.__file__).parent / "Data" / PLAZA_SETS[key]
    if not path.is_file():
        raise RealDataError(f"{path}: not in the installed gtsam package")
    return path


def heading_points_backwards(x, y, theta, min_step: float = 0.05) -> bool:
    """Whether most displacements between samples (longer than ``min_step`` m) run against the
    recorded heading."""
    dx, dy = np.diff(x), np.diff(y)
    moving = np.hypot(dx, dy) > min_step
    if not moving.any():
        return False
    err = wrap_angle(np.arctan2(dy, dx) - np.asarray(theta)[:-1])[moving]
    return bool(np.mean(np.abs(err) > math.pi / 2) > 0.5)


def labelled_log(
    t, dt, v_trans, v_rot, gt_x, gt_y, gt_theta, scenes: SceneSpec = PLAZA_SCENES, seed: int = 0
) -> ObservationLog:
    """An observation log from recorded odometry and ground truth, with scene numbers synthesised
    from the ground truth by the scene model ``scenes`` (layout over the driven path; flicker
    and false positives drawn with ``seed``)."""
    layout = SceneLayout.over_path(scenes, gt_x, gt_y)
    obs = observe_scenes(
        layout,
        gt_x,
        gt_y,
        gt_theta,
        np.random.default_rng([seed, 2]),
        scenes.flicker_width,
        scenes.flicker_prob,
        scenes.false_positive_rate,
    )
    return ObservationLog(
        t=np.asarray(t, float),
        dt=np.asarray(dt, float),
        v_trans=np.asarray(v_trans, float),
        v_rot=np.asarray(v_rot, float),
        scene_id=obs.scene_id,
        gt_x=np.asarray(gt_x, float),
        gt_y=np.asarray(gt_y, float),
        gt_theta=np.asarray(gt_theta, float),
        false_positive=obs.false_positive,
    )


def load_plaza(
    name: str,
    scenes: SceneSpec = PLAZA_SCENES,
    seed: int = 0,
    fp_rate: float | None = None,
    duration: float | None = None,
) -> ObservationLog:
    """The Plaza data set ``name`` ("plaza1" or "plaza2") as an observation log: the vehicle's
    own dead reckoning as odometry, ground truth for metrics, synthesised scene numbers.
    ``fp_rate`` overrides the scene model's false-positive rate; ``duration`` (s) keeps the start."""
    from scipy.io import loadmat

    path = plaza_file(name)
    data = loadmat(str(path))
    dr, gt = np.asarray(data["DR"], float), np.asarray(data["GT"], float)
    if dr.ndim != 2 or gt.ndim != 2 or dr.shape[1] < 3 or gt.shape[1] < 4 or len(gt) != len(dr) + 1:
        raise RealDataError(f"{path}: DR/GT: expected DR (n, 3) and GT (n + 1, 4), got {dr.shape} and {gt.shape}")
    t = dr[:, 0]
    dt = np.diff(gt[:, 0])
    if not np.all(dt > 0):
        raise RealDataError(f"{path}: GT: time stamps are not strictly increasing")
    theta = gt[:, 3] + (math.pi if heading_points_backwards(gt[:, 1], gt[:, 2], gt[:, 3]) else 0.0)
    theta = wrap_angle(theta)
    if fp_rate is not None:
        scenes = replace(scenes, false_positive_rate=float(fp_rate))
    if duration is not None:
        keep = t - gt[0, 0] <= duration
        if keep.sum() < 2:
            raise RealDataError(
                f"{name}: --duration {duration:g} s keeps {int(keep.sum())} of the log's ticks, "
                f"{float(np.median(dt)):g} s apart; at least 2 are needed"
            )
        dr, gt, t, dt, theta = dr[keep], gt[np.r_[True, keep]], t[keep], dt[keep], theta[np.r_[True, keep]]
    return labelled_log(t, dt, dr[:, 1] / dt, dr[:, 2] / dt, gt[1:, 1], gt[1:, 2], theta[1:], scenes, seed)
