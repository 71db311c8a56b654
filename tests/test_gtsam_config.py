"""PoseGraphConfig: documented defaults and one-line errors naming the bad field."""

import dataclasses
import math

import numpy as np
import pytest

from baselines import BackendConfig, LoopClosureConfig, PoseGraphConfig, PoseGraphSLAM, YawBiasConfig
from baselines.config import DEFAULT_ESTIMATOR_K

YAW_BIAS = PoseGraphConfig(yaw_bias=YawBiasConfig(estimate=True))


def test_default_is_online_and_robust():
    cfg = PoseGraphConfig()
    assert cfg.optimisation.online and cfg.backend.kind == "robust"
    assert cfg.backend.estimator == "geman_mcclure"
    assert cfg.backend.kernel_width == DEFAULT_ESTIMATOR_K["geman_mcclure"]
    assert not cfg.optimisation.final_batch and not cfg.yaw_bias.estimate
    assert PoseGraphSLAM().config == cfg


def test_closure_noise_defaults_follow_scene_cell_and_sector():
    cfg = PoseGraphConfig()
    assert cfg.closures.sigma_xy_m == pytest.approx(1.0 / math.sqrt(6.0))  # 1 m cell
    assert cfg.closures.sigma_theta_rad == pytest.approx(math.radians(90.0) / math.sqrt(6.0))  # 90 deg sector


def test_config_is_a_dataclass_for_provenance():
    d = dataclasses.asdict(PoseGraphConfig())
    assert d["backend"]["kind"] == "robust" and "sigma_v_m_s" in d["odometry"]


@pytest.mark.parametrize(
    "changes, field",
    [
        ({"backend": {"kind": "lm"}}, "backend.kind"),
        ({"backend": {"estimator": "tukey"}}, "backend.estimator"),
        ({"backend": {"gnc_loss": "l1"}}, "backend.gnc_loss"),
        ({"odometry": {"sigma_v_m_s": 0.0}}, "odometry.sigma_v_m_s"),
        ({"odometry": {"sigma_w_rad_s": -0.01}}, "odometry.sigma_w_rad_s"),
        ({"odometry": {"sigma_lateral_m_s": float("nan")}}, "odometry.sigma_lateral_m_s"),
        ({"closures": {"sigma_xy_m": 0.0}}, "closures.sigma_xy_m"),
        ({"closures": {"sigma_theta_rad": -1.0}}, "closures.sigma_theta_rad"),
        ({"odometry": {"prior_sigma_xy_m": 0.0}}, "odometry.prior_sigma_xy_m"),
        ({"keyframes": {"distance_m": 0.0}}, "keyframes.distance_m"),
        ({"keyframes": {"angle_rad": float("inf")}}, "keyframes.angle_rad"),
        ({"closures": {"min_travel_m": -1.0}}, "closures.min_travel_m"),
        ({"closures": {"max_candidates": 0}}, "closures.max_candidates"),
        ({"closures": {"max_candidates": 1.5}}, "closures.max_candidates"),
        ({"closures": {"flush_distance": float("nan")}}, "closures.flush_distance"),
        ({"backend": {"estimator_k": 0.0}}, "backend.estimator_k"),
        ({"backend": {"accept_weight": 0.0}}, "backend.accept_weight"),
        ({"backend": {"gnc_inlier_probability": 1.0}}, "backend.gnc_inlier_probability"),
        ({"backend": {"gnc_interval_keyframes": 0}}, "backend.gnc_interval_keyframes"),
        ({"optimisation": {"odometry_batch_keyframes": 0}}, "optimisation.odometry_batch_keyframes"),
        ({"optimisation": {"odometry_batch_keyframes": True}}, "optimisation.odometry_batch_keyframes"),
        ({"optimisation": {"isam2_extra_updates": -1}}, "optimisation.isam2_extra_updates"),
        ({"optimisation": {"isam2_relinearize_skip": 0}}, "optimisation.isam2_relinearize_skip"),
        ({"closures": {"batch_keyframes": 0}}, "closures.batch_keyframes"),
        ({"closures": {"batch_keyframes": 2.5}}, "closures.batch_keyframes"),
        ({"yaw_bias": {"isam2_relinearize_threshold_rad_s": -1.0}}, "yaw_bias.isam2_relinearize_threshold_rad_s"),
        ({"closures": {"recent_tolerance_m": -0.1}}, "closures.recent_tolerance_m"),
        ({"closures": {"early_tolerance_m": float("nan")}}, "closures.early_tolerance_m"),
        ({"optimisation": {"online": 1}}, "optimisation.online"),
        ({"yaw_bias": {"prior_sigma_rad_s": 0.0}}, "yaw_bias.prior_sigma_rad_s"),
        ({"backend": {"kind": "gnc"}, "yaw_bias": {"estimate": True}}, "yaw_bias.estimate"),
        ({"keyframes": {"distance": 0.5}}, "keyframes.distance"),
        ({"backend": "gnc"}, "backend"),
    ],
)
def test_bad_config_raises_one_line_error_naming_the_field(changes, field):
    with pytest.raises(ValueError) as err:
        PoseGraphConfig().replace(**changes)
    message = str(err.value)
    assert message.startswith(field + ":"), message
    assert "\n" not in message


def test_relinearize_skip_default_depends_on_bias_estimation():
    assert PoseGraphConfig().relinearize_skip == 10
    assert YAW_BIAS.relinearize_skip == 1
    assert YAW_BIAS.replace(optimisation={"isam2_relinearize_skip": 5}).relinearize_skip == 5


def test_closure_batch_default_depends_on_bias_estimation():
    """Closures wait for batches of 8 keyframes, 4 when the yaw-bias variable (which lives on
    closures) is estimated; an explicit value wins."""
    assert PoseGraphConfig().closure_batch == 8
    assert YAW_BIAS.closure_batch == 4
    assert YAW_BIAS.replace(closures={"batch_keyframes": 2}).closure_batch == 2


def test_numpy_numbers_are_accepted_and_stored_as_python_numbers():
    closures = LoopClosureConfig(min_travel_m=np.float32(0.5), max_candidates=np.int64(2))
    assert closures.min_travel_m == 0.5 and closures.max_candidates == 2
    assert type(closures.min_travel_m) is float and type(closures.max_candidates) is int


def test_kernel_width_default_or_explicit():
    assert BackendConfig(estimator="cauchy").kernel_width == DEFAULT_ESTIMATOR_K["cauchy"]
    assert BackendConfig(estimator="cauchy", estimator_k=np.int64(2)).kernel_width == 2.0


def test_non_config_object_rejected():
    with pytest.raises(ValueError, match="^config:"):
        PoseGraphSLAM({"backend": "robust"})
