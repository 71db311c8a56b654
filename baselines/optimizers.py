"""The gtsam optimisers used by the pose graph: iSAM2, batch LM and GNC."""

from __future__ import annotations

from collections.abc import Sequence

import gtsam
import numpy as np

from .config import PoseGraphConfig


def make_isam2(config: PoseGraphConfig, factorization: str = "CHOLESKY") -> gtsam.ISAM2:
    """iSAM2 with the configured relinearisation threshold and skip (``factorization``
    "CHOLESKY", gtsam's default, or "QR", slower but robust to ill-conditioning)."""
    params = gtsam.ISAM2Params()
    params.setFactorization(factorization)
    if config.yaw_bias.estimate:
        # Per-variable thresholds: poses ('x') as configured, the bias ('b') much finer,
        # since a bias delta of 0.1 rad/s would be a 6 deg/s error.
        thresholds = gtsam.ISAM2ThresholdMap()
        thresholds.insert(("x", np.full(3, config.optimisation.isam2_relinearize_threshold)))
        thresholds.insert(("b", np.array([config.yaw_bias.isam2_relinearize_threshold_rad_s])))
        params.setRelinearizeThreshold(thresholds)
    else:
        params.setRelinearizeThreshold(config.optimisation.isam2_relinearize_threshold)
    params.relinearizeSkip = config.relinearize_skip
    return gtsam.ISAM2(params)


def _lm_params(config: PoseGraphConfig) -> gtsam.LevenbergMarquardtParams:
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(config.optimisation.batch_max_iterations)
    return params


def batch_lm(graph: gtsam.NonlinearFactorGraph, initial: gtsam.Values, config: PoseGraphConfig) -> gtsam.Values:
    """Batch Levenberg-Marquardt on the whole graph from ``initial``."""
    return gtsam.LevenbergMarquardtOptimizer(graph, initial, _lm_params(config)).optimize()


def run_gnc(
    graph: gtsam.NonlinearFactorGraph,
    initial: gtsam.Values,
    known_inliers: Sequence[int],
    config: PoseGraphConfig,
) -> tuple[gtsam.Values, np.ndarray]:
    """Graduated non-convexity (GncLMOptimizer) over ``graph``.

    ``known_inliers`` are the factor indices GNC must keep (prior, odometry,
    bias prior); every other factor is a loop closure whose weight GNC decides.
    Returns the optimised values and one weight per factor of ``graph``.
    """
    params = gtsam.GncLMParams(_lm_params(config))
    params.setLossType(gtsam.GncLossType.TLS if config.backend.gnc_loss == "tls" else gtsam.GncLossType.GM)
    params.setKnownInliers(list(known_inliers))
    optimizer = gtsam.GncLMOptimizer(graph, initial, params)
    optimizer.setInlierCostThresholdsAtProbability(config.backend.gnc_inlier_probability)
    result = optimizer.optimize()
    return result, np.asarray(optimizer.getWeights(), dtype=float).ravel()
