"""From one stream's results and its ground truth to the typed metrics of a variant run.

Ground truth enters the metrics here, after both systems have run (the recorder and the plots
draw it too); neither system ever sees it.
"""

from __future__ import annotations

import numpy as np

from baselines import PoseGraphSLAM
from worlds import ObservationLog

from ..run.runner import PoseGraphMap, StreamResult
from . import metrics
from .results import LoopClosureQuality, PerTrajectory, RelativeError, Rpe, Timing, VariantResult

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


def summarize_stream(res: StreamResult, log: ObservationLog) -> VariantResult:
    """What can be said of a run without ground truth: sizes, snaps and timing."""
    rs = res.ratslam
    return VariantResult(
        ticks=len(log),
        simulated_s=log.duration,
        snaps=int(res.snapped.sum()),
        experiences=int(len(rs.experience_poses)),
        links=int(len(rs.links)),
        keyframes=int(len(res.gtsam.keyframe_poses)),
        loop_closures_proposed=int(len(res.gtsam.loop_closures)),
        isam2_recoveries=int(res.gtsam.isam2_recoveries),
        closures_dropped=int(res.gtsam.closures_dropped),
        timing=_timing(res, log),
    )


def evaluate_stream(
    res: StreamResult, log: ObservationLog, closure_true_distance: float = CLOSURE_TRUE_DISTANCE
) -> VariantResult:
    """Every metric of one variant's run; accuracy needs ground truth (without it, see
    :func:`summarize_stream`). A loop closure counts as true if its keyframes were within
    ``closure_true_distance`` metres in truth (default: for the simulator's 1 m scene cells)."""
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
    for name, final in (("ratslam_final", res.ratslam_final), ("gtsam_final", res.gtsam_final)):
        if final is not None:
            trajectories[name] = (final, gt)
    ate, yaw = {}, {}
    for name, (est, ref) in trajectories.items():
        ate[name], yaw[name] = _ate(est, ref)

    rpe = {}
    for name in ("odometry", "ratslam_online", "gtsam_online"):
        t_err, r_err = metrics.rpe(trajectories[name][0], gt, RPE_DISTANCE)
        rpe[name] = RelativeError(translation_m=float(t_err), rotation_deg=float(np.degrees(r_err)))

    exp_gt = gt[exp_ticks, :2] if len(exp_ticks) else np.zeros((0, 2))
    return VariantResult(
        ticks=len(log),
        simulated_s=log.duration,
        ate=PerTrajectory(**ate),
        alignment_yaw_deg=PerTrajectory(**yaw),
        rpe=Rpe(RPE_DISTANCE, PerTrajectory(**rpe)),
        snaps=int(res.snapped.sum()),
        experiences=int(len(rs.experience_poses)),
        links=int(len(rs.links)),
        multiple_representations=int(metrics.multiple_representations(exp_gt, rs.links, radius=0.5)),
        hash_collisions=int(metrics.hash_collisions(rs.experience_cells[:, :2], exp_gt, cfg.shape[:2])),
        timing=_timing(res, log),
        loop_closure=closure_quality(pg, gt, closure_true_distance),
        keyframes=int(len(pg.keyframe_poses)),
        isam2_recoveries=int(pg.isam2_recoveries),
        closures_dropped=int(pg.closures_dropped),
    )


def closure_quality(pg: PoseGraphSLAM | PoseGraphMap, gt: np.ndarray, true_distance: float) -> LoopClosureQuality:
    """The pose graph's loop closures against ground truth ``gt`` (per tick): true if their
    keyframes were within ``true_distance`` metres."""
    pairs = pg.loop_closures
    if len(pairs) == 0:
        return LoopClosureQuality(proposed=0, accepted=0, true=0, precision=None, recall=None)
    ticks = np.asarray(pg.keyframe_ticks)
    a, b = gt[ticks[pairs[:, 0]], :2], gt[ticks[pairs[:, 1]], :2]
    is_true = np.hypot(*(a - b).T) <= true_distance
    accepted = np.asarray(pg.closure_accepted, dtype=bool)
    precision, recall = metrics.loop_closure_pr(accepted, is_true)
    return LoopClosureQuality(
        proposed=int(len(pairs)),
        accepted=int(accepted.sum()),
        true=int(is_true.sum()),
        precision=precision,
        recall=recall,
        true_distance_m=true_distance,
    )


def _timing(res: StreamResult, log: ObservationLog) -> Timing:
    sim = log.duration
    speeds: dict[str, float | None] = {}
    for system in ("ratslam", "gtsam"):
        wall = res.wall.get(f"{system}_s", 0.0)
        speeds[f"{system}_realtime_factor"] = metrics.realtime_factor(sim, wall)
        speeds[f"{system}_steps_per_s"] = len(log) / wall if wall > 0 else None
    return Timing(
        ratslam_s=round(res.wall["ratslam_s"], 4),
        gtsam_s=round(res.wall["gtsam_s"], 4),
        recording_and_bookkeeping_s=round(res.wall["recording_and_bookkeeping_s"], 4),
        ratslam_realtime_factor=speeds["ratslam_realtime_factor"],
        ratslam_steps_per_s=speeds["ratslam_steps_per_s"],
        gtsam_realtime_factor=speeds["gtsam_realtime_factor"],
        gtsam_steps_per_s=speeds["gtsam_steps_per_s"],
    )
