"""Shared helpers of the pose-graph baseline tests (ATE, closure truth), and their own tests.

ATE here: keyframe positions against ground truth at ``keyframe_ticks`` after a
least-squares SE(2) alignment (Umeyama without scale), RMSE in metres.
Closure truth: a proposed closure is a true positive when the ground-truth
positions of its two keyframes are within ``CLOSURE_TRUE_RADIUS`` (1.5 m: the
two keyframes share or neighbour a 1 m scene cell); aliased scene numbers and
false positives both give closures beyond it.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from baselines import PoseGraphConfig, PoseGraphSLAM

CLOSURE_TRUE_RADIUS = 1.5  # m


def align_se2(p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R (2x2) and translation t minimising sum |R p_i + t - q_i|^2 (Umeyama, no scale)."""
    mp, mq = p.mean(axis=0), q.mean(axis=0)
    h = (p - mp).T @ (q - mq)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1.0, d]) @ u.T
    return r, mq - r @ mp


def ate_rmse(p: np.ndarray, q: np.ndarray) -> float:
    """RMSE (m) of positions p (N, 2) against q (N, 2) after SE(2) alignment."""
    r, t = align_se2(p, q)
    return float(np.sqrt(np.mean(np.sum((p @ r.T + t - q) ** 2, axis=1))))


def run_slam(log, config: PoseGraphConfig, finalize: bool = True, scenes: bool = True) -> PoseGraphSLAM:
    """Feed a whole observation log through a PoseGraphSLAM (scene ids replaced by -1 if not scenes)."""
    slam = PoseGraphSLAM(config)
    scene_ids = log.scene_id if scenes else np.full(len(log.dt), -1)
    for dt, v, w, s in zip(log.dt, log.v_trans, log.v_rot, scene_ids):
        slam.step(dt, v, w, s)
    if finalize:
        slam.finalize()
    return slam


def keyframe_ate(slam: PoseGraphSLAM, log) -> float:
    """ATE (m) of the keyframe estimate against ground truth at the keyframe ticks."""
    k = slam.keyframe_ticks
    gt = np.stack([log.gt_x[k], log.gt_y[k]], axis=1)
    return ate_rmse(slam.keyframe_poses[:, :2], gt)


def closure_truth(slam: PoseGraphSLAM, log) -> np.ndarray:
    """(L,) bool: ground-truth positions of the closure's keyframes within CLOSURE_TRUE_RADIUS."""
    lc = slam.loop_closures
    if len(lc) == 0:
        return np.zeros(0, dtype=bool)
    k = slam.keyframe_ticks
    gx, gy = log.gt_x[k], log.gt_y[k]
    return np.hypot(gx[lc[:, 0]] - gx[lc[:, 1]], gy[lc[:, 0]] - gy[lc[:, 1]]) <= CLOSURE_TRUE_RADIUS


def precision_recall(accepted: np.ndarray, truth: np.ndarray) -> tuple[float, float]:
    """Precision and recall of accepted closures against the ground-truth rule (1.0 when undefined)."""
    tp = int(np.sum(accepted & truth))
    precision = tp / int(accepted.sum()) if accepted.any() else 1.0
    recall = tp / int(truth.sum()) if truth.any() else 1.0
    return precision, recall


@functools.cache
def sim_log(world: str, duration: float, fp_rate: float, bias_deg_s: float = 0.0, seed: int = 0):
    """Cached simulator stream (the simulator is deterministic per seed)."""
    from worlds import simulate

    return simulate(world, duration=duration, seed=seed, bias_deg_s=bias_deg_s, fp_rate=fp_rate)


# --------------------------------------------------------------------------- helper tests
def test_ate_is_zero_for_a_rigidly_moved_trajectory():
    rng = np.random.default_rng(0)
    q = rng.normal(size=(50, 2)) * 3.0
    a = 0.7
    r = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    p = q @ r.T + np.array([4.0, -2.0])
    assert ate_rmse(p, q) < 1e-12


def test_ate_measures_non_rigid_error_and_ignores_no_scale():
    q = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    # Scaling is not an SE(2) motion: a 2x scaled square keeps an error.
    assert ate_rmse(2.0 * q, q) > 0.3
    # A single point displaced by d: RMSE after the best rigid fit is below d/2 and positive.
    p = q.copy()
    p[0] += [0.4, 0.0]
    assert 0.0 < ate_rmse(p, q) < 0.2


def test_precision_recall_counts():
    accepted = np.array([True, True, False, False])
    truth = np.array([True, False, True, False])
    assert precision_recall(accepted, truth) == pytest.approx((0.5, 0.5))


def test_vectorised_pose2_logmap_matches_gtsam():
    """The closure residual used to score closures equals gtsam's Pose2.Logmap(X_i^-1 X_j)."""
    import gtsam

    from baselines.factors import pose2_logmap_between

    rng = np.random.default_rng(0)
    a = rng.normal(0, 3, (500, 3))
    b = a + rng.normal(0, 1, (500, 3))
    b[:5] = a[:5]  # identical poses
    b[5:10, 2] = a[5:10, 2] + 1e-12  # the small-angle branch
    b[10:15, 2] = a[10:15, 2] + np.pi - 1e-9  # near the wrap
    ref = np.array([gtsam.Pose2.Logmap(gtsam.Pose2(*p).between(gtsam.Pose2(*q))) for p, q in zip(a, b)])
    np.testing.assert_allclose(pose2_logmap_between(a, b), ref, rtol=0, atol=1e-9)
