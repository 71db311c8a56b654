"""PoseGraphConfig: documented defaults and one-line errors naming the bad field."""

import dataclasses
import math

import numpy as np
import pytest

from baselines import PoseGraphConfig, PoseGraphSLAM
from baselines.config import DEFAULT_ESTIMATOR_K


def test_default_is_online_and_robust():
    cfg = PoseGraphConfig()
    assert cfg.online and cfg.backend == "robust"
    assert cfg.estimator == "geman_mcclure" and cfg.kernel_width == DEFAULT_ESTIMATOR_K["geman_mcclure"]
    assert not cfg.final_batch and not cfg.estimate_yaw_bias
    assert PoseGraphSLAM().config == cfg


def test_closure_noise_defaults_follow_scene_cell_and_sector():
    cfg = PoseGraphConfig()
    assert cfg.closure_sigma_xy == pytest.approx(1.0 / math.sqrt(6.0))  # 1 m cell
    assert cfg.closure_sigma_theta == pytest.approx(math.radians(90.0) / math.sqrt(6.0))  # 90 deg sector


def test_config_is_a_dataclass_for_provenance():
    d = dataclasses.asdict(PoseGraphConfig())
    assert d["backend"] == "robust" and "odom_sigma_v" in d


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"backend": "lm"}, "backend"),
        ({"estimator": "tukey"}, "estimator"),
        ({"gnc_loss": "l1"}, "gnc_loss"),
        ({"odom_sigma_v": 0.0}, "odom_sigma_v"),
        ({"odom_sigma_w": -0.01}, "odom_sigma_w"),
        ({"odom_sigma_lateral": float("nan")}, "odom_sigma_lateral"),
        ({"closure_sigma_xy": 0.0}, "closure_sigma_xy"),
        ({"closure_sigma_theta": -1.0}, "closure_sigma_theta"),
        ({"prior_sigma_xy": 0.0}, "prior_sigma_xy"),
        ({"keyframe_distance": 0.0}, "keyframe_distance"),
        ({"keyframe_angle": float("inf")}, "keyframe_angle"),
        ({"closure_min_travel": -1.0}, "closure_min_travel"),
        ({"closure_max_candidates": 0}, "closure_max_candidates"),
        ({"closure_max_candidates": 1.5}, "closure_max_candidates"),
        ({"estimator_k": 0.0}, "estimator_k"),
        ({"accept_weight": 0.0}, "accept_weight"),
        ({"gnc_inlier_probability": 1.0}, "gnc_inlier_probability"),
        ({"gnc_interval": 0}, "gnc_interval"),
        ({"odometry_batch_keyframes": 0}, "odometry_batch_keyframes"),
        ({"odometry_batch_keyframes": True}, "odometry_batch_keyframes"),
        ({"isam2_extra_updates": -1}, "isam2_extra_updates"),
        ({"isam2_relinearize_skip": 0}, "isam2_relinearize_skip"),
        ({"closure_batch_keyframes": 0}, "closure_batch_keyframes"),
        ({"closure_batch_keyframes": 2.5}, "closure_batch_keyframes"),
        ({"isam2_bias_relinearize_threshold": -1.0}, "isam2_bias_relinearize_threshold"),
        ({"closure_recent_tolerance": -0.1}, "closure_recent_tolerance"),
        ({"closure_early_tolerance": float("nan")}, "closure_early_tolerance"),
        ({"online": 1}, "online"),
        ({"yaw_bias_prior_sigma": 0.0}, "yaw_bias_prior_sigma"),
        ({"backend": "gnc", "estimate_yaw_bias": True}, "estimate_yaw_bias"),
    ],
)
def test_bad_config_raises_one_line_error_naming_the_field(kwargs, field):
    with pytest.raises(ValueError) as err:
        PoseGraphConfig(**kwargs)
    message = str(err.value)
    assert message.startswith(field + ":")
    assert "\n" not in message


def test_relinearize_skip_default_depends_on_bias_estimation():
    assert PoseGraphConfig().relinearize_skip == 10
    assert PoseGraphConfig(estimate_yaw_bias=True).relinearize_skip == 1
    assert PoseGraphConfig(estimate_yaw_bias=True, isam2_relinearize_skip=5).relinearize_skip == 5


def test_closure_batch_default_depends_on_bias_estimation():
    """Closures wait for batches of 8 keyframes, 4 when the yaw-bias variable (which lives on
    closures) is estimated; an explicit value wins."""
    assert PoseGraphConfig().closure_batch == 8
    assert PoseGraphConfig(estimate_yaw_bias=True).closure_batch == 4
    assert PoseGraphConfig(estimate_yaw_bias=True, closure_batch_keyframes=2).closure_batch == 2


def test_numpy_numbers_are_accepted():
    cfg = PoseGraphConfig(keyframe_distance=np.float64(0.4), closure_max_candidates=np.int64(2))
    assert cfg.keyframe_distance == 0.4 and cfg.closure_max_candidates == 2


def test_non_config_object_rejected():
    with pytest.raises(ValueError, match="^config:"):
        PoseGraphSLAM({"backend": "robust"})
