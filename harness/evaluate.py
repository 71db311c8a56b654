"""From one stream's results and its ground truth to the metrics dictionary of a run.

Ground truth enters the metrics here, after both systems have run (the recorder and the plots
draw it too); neither system ever sees it.
"""

from __future__ import annotations

import numpy as np

from worlds import ObservationLog

from . import metrics
from .runner import StreamResult

CLOSURE_TRUE_DISTANCE = 1.5  # m: a loop closure is true if its keyframes were this close in truth
# (for 1 m scene cells: two places in one cell are at most its diagonal, 1.41 m, apart)
RPE_DISTANCE = 5.0  # m travelled


def unwrap_peak_path(peak_metres: np.ndarray, extent: np.ndarray) -> np.ndarray:
    """Continuous pose-cell peak path in metres: undo the grid's wrap-around between ticks."""
    out = peak_metres.copy()
    for axis in range(3):
        out[:, axis] = np.unwrap(peak_metres[:, axis], period=extent[axis])
    return out


def _ate(est: np.ndarray, gt: np.ndarray) -> tuple[float, float]:
    """(ATE RMSE in m, alignment yaw in degrees) after SE(2) alignment."""
    if len(est) < 2:
        return float("nan"), float("nan")
    a = metrics.ate(est, gt)
    return float(a.rmse), float(np.degrees(a.yaw))


def summarize_stream(res: StreamResult, log: ObservationLog) -> dict:
    """What can be said of a run without ground truth: sizes, snaps and timing."""
    rs = res.ratslam
    return {
        "ticks": len(log),
        "simulated_s": log.duration,
        "snaps": int(res.snapped.sum()),
        "experiences": int(len(rs.experience_poses)),
        "links": int(len(rs.links)),
        "keyframes": int(len(res.gtsam.keyframe_poses)),
        "loop_closures_proposed": int(len(res.gtsam.loop_closures)),
        "isam2_recoveries": int(res.gtsam.isam2_recoveries),
        "closures_dropped": int(res.gtsam.closures_dropped),
        "timing": _timing(res, log),
    }


def evaluate_stream(
    res: StreamResult, log: ObservationLog, closure_true_distance: float = CLOSURE_TRUE_DISTANCE
) -> dict:
    """Every metric of one variant's run (a JSON-ready dictionary); accuracy needs ground truth.
    A loop closure counts as true if its keyframes were within ``closure_true_distance`` metres
    in truth (default: for the simulator's 1 m scene cells)."""
    if not log.has_ground_truth:
        return summarize_stream(res, log)
    gt = log.ground_truth()
    rs, pg = res.ratslam, res.gtsam
    cfg = rs.config.pose_cells
    sizes = np.array([cfg.cell_size_m, cfg.cell_size_m, cfg.theta_cell_rad])
    extent = np.array(cfg.shape) * sizes
    peak_path = unwrap_peak_path(res.peak_metres, extent)

    trajectories = {
        "odometry": (res.odometry, gt),
        "ratslam_online": (res.ratslam_pose, gt),
        "pose_cell_path": (peak_path, gt),
    }
    exp_ticks = rs.experience_first_tick  # the place each experience stands for
    if len(exp_ticks):
        trajectories["experience_map"] = (rs.experience_poses, gt[exp_ticks])
    trajectories["gtsam"] = (pg.keyframe_poses, gt[pg.keyframe_ticks])
    trajectories["gtsam_online"] = (res.gtsam_pose, gt)
    ate, yaw = {}, {}
    for name, (est, ref) in trajectories.items():
        ate[name], yaw[name] = _ate(est, ref)

    rpe = {}
    for name in ("odometry", "ratslam_online", "gtsam_online"):
        t_err, r_err = metrics.rpe(trajectories[name][0], gt, RPE_DISTANCE)
        rpe[name] = {"translation_m": float(t_err), "rotation_deg": float(np.degrees(r_err))}

    exp_gt = gt[exp_ticks, :2] if len(exp_ticks) else np.zeros((0, 2))
    return {
        "ticks": len(log),
        "simulated_s": log.duration,
        "ate": ate,
        "alignment_yaw_deg": yaw,
        "rpe": {"distance_m": RPE_DISTANCE, **rpe},
        "snaps": int(res.snapped.sum()),
        "experiences": int(len(rs.experience_poses)),
        "links": int(len(rs.links)),
        "multiple_representations": int(metrics.multiple_representations(exp_gt, rs.links, radius=0.5)),
        "hash_collisions": int(metrics.hash_collisions(rs.experience_cells[:, :2], exp_gt, cfg.shape[:2])),
        "timing": _timing(res, log),
        "loop_closure": _closure_quality(pg, gt, closure_true_distance),
        "keyframes": int(len(pg.keyframe_poses)),
        "isam2_recoveries": int(pg.isam2_recoveries),
        "closures_dropped": int(pg.closures_dropped),
    }


def _closure_quality(pg, gt: np.ndarray, true_distance: float) -> dict:
    pairs = pg.loop_closures
    if len(pairs) == 0:
        return {"proposed": 0, "accepted": 0, "true": 0, "precision": None, "recall": None}
    ticks = np.asarray(pg.keyframe_ticks)
    a, b = gt[ticks[pairs[:, 0]], :2], gt[ticks[pairs[:, 1]], :2]
    is_true = np.hypot(*(a - b).T) <= true_distance
    accepted = np.asarray(pg.closure_accepted, dtype=bool)
    precision, recall = metrics.loop_closure_pr(accepted, is_true)
    return {
        "proposed": int(len(pairs)),
        "accepted": int(accepted.sum()),
        "true": int(is_true.sum()),
        "precision": precision,
        "recall": recall,
        "true_distance_m": true_distance,
    }


def _timing(res: StreamResult, log: ObservationLog) -> dict:
    sim = log.duration
    out = {k: round(v, 4) for k, v in res.wall.items()}
    for system in ("ratslam", "gtsam"):
        wall = res.wall.get(f"{system}_s", 0.0)
        out[f"{system}_realtime_factor"] = metrics.realtime_factor(sim, wall)
        out[f"{system}_steps_per_s"] = len(log) / wall if wall > 0 else None
    return out


def room_laps(
    res: StreamResult, log: ObservationLog, room: tuple[float, float, float, float], cell_size: float, grid_shape
) -> dict:
    """Fig 11: where the first two laps of a room sit in the pose cells and in the experience map.

    Returns the distances between the two laps' centres, in the pose cells (wrap-aware, metres)
    and in the experience map (online pose).
    """
    x0, y0, x1, y1 = room
    gt_x, gt_y = log.ground_truth()[:, :2].T
    inside = (gt_x > x0) & (gt_x < x1) & (gt_y > y0) & (gt_y < y1)
    edges = np.diff(np.concatenate([[0], inside.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    visits = [(a, b) for a, b in zip(starts, ends) if b - a > 20][:2]
    if len(visits) < 2:
        return {
            "laps_found": len(visits),
            "pose_cell_separation_m": float("nan"),
            "experience_map_separation_m": float("nan"),
        }
    n = np.array(grid_shape[:2], dtype=float)

    def circular_centre(cells):
        ang = cells[:, :2] / n * 2 * np.pi
        return np.arctan2(np.sin(ang).mean(0), np.cos(ang).mean(0)) / (2 * np.pi) * n

    (a0, a1), (b0, b1) = visits
    dc = metrics.wrap_cells(circular_centre(res.peak_cells[a0:a1]) - circular_centre(res.peak_cells[b0:b1]), n)
    de = res.ratslam_pose[a0:a1, :2].mean(0) - res.ratslam_pose[b0:b1, :2].mean(0)
    return {
        "laps_found": 2,
        "lap_ticks": [[int(a0), int(a1)], [int(b0), int(b1)]],
        "pose_cell_separation_m": float(np.hypot(*dc) * cell_size),
        "experience_map_separation_m": float(np.hypot(*de)),
    }
