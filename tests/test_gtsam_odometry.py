"""SE(2) odometry integration, its propagated covariance and the bias-aware odometry factor."""

import gtsam
import numpy as np
import pytest
from gtsam.symbol_shorthand import B, X

from baselines.factors import BiasedOdometry, biased_odometry_factor
from baselines.odometry import TickBuffer, integrate, relative_covariance
from tests.helpers import DT


def _ticks(n=12, seed=0):
    rng = np.random.default_rng(seed)
    dt = np.full(n, DT)
    v = 0.3 + 0.02 * rng.normal(size=n)
    w = 0.4 * np.sin(np.arange(n) / 3.0) + 0.01 * rng.normal(size=n)
    return dt, v, w


def test_integration_matches_gtsam_expmap_composition():
    dt, v, w = _ticks()
    pose = gtsam.Pose2()
    for a, b, c in zip(dt, v, w):
        pose = pose.compose(gtsam.Pose2.Expmap(np.array([b * a, 0.0, c * a])))
    x, y, th = integrate(dt, v, w)
    assert [x, y] == pytest.approx([pose.x(), pose.y()], abs=1e-12)
    assert np.cos(th - pose.theta()) == pytest.approx(1.0, abs=1e-12)


def test_integration_handles_straight_motion_and_bias():
    dt = np.full(7, DT)
    v = np.full(7, 0.3)
    assert integrate(dt, v, np.zeros(7)) == pytest.approx([0.3, 0.0, 0.0], abs=1e-12)
    # A yaw-rate reading of exactly the bias means no turn at all.
    assert integrate(dt, v, np.full(7, 0.05), bias=0.05) == pytest.approx([0.3, 0.0, 0.0], abs=1e-12)


def test_tick_buffer_tracks_vectorised_integration():
    dt, v, w = _ticks()
    buf = TickBuffer()
    for a, b, c in zip(dt, v, w):
        buf.add(a, b, c, 0.0)
    assert [buf.x, buf.y, buf.theta] == pytest.approx(list(integrate(dt, v, w)), abs=1e-12)
    assert buf.distance == pytest.approx(np.sum(v * dt))


def test_covariance_matches_monte_carlo():
    """The propagated covariance agrees with sampled noisy odometry (in gtsam's tangent space)."""
    dt, v, w = _ticks(n=15)
    sv, sw, sl = 0.05, 0.05, 0.01  # larger than the default so sampling error stays small
    cov = relative_covariance(dt, v, w, sv, sw, sl)
    rng = np.random.default_rng(1)
    nominal = gtsam.Pose2(*integrate(dt, v, w))
    samples = []
    for _ in range(3000):
        pose = gtsam.Pose2()
        for a, b, c in zip(dt, v + sv * rng.normal(size=len(v)), w + sw * rng.normal(size=len(w))):
            xi = np.array([b * a, sl * a * rng.normal(), c * a])
            pose = pose.compose(gtsam.Pose2.Expmap(xi))
        samples.append(gtsam.Pose2.Logmap(nominal.between(pose)))
    emp = np.cov(np.array(samples).T)
    assert np.allclose(cov, emp, rtol=0.15, atol=2e-6), (cov, emp)


def test_biased_odometry_factor_jacobians_match_numerical_derivatives():
    dt, v, w = _ticks()
    odo = BiasedOdometry(dt, v, w)
    noise = gtsam.noiseModel.Unit.Create(3)
    factor = biased_odometry_factor(X(0), X(1), B(0), odo, noise)
    values = gtsam.Values()
    values.insert(X(0), gtsam.Pose2(0.3, -0.2, 0.4))
    values.insert(X(1), gtsam.Pose2(1.1, 0.5, 1.3))
    values.insert(B(0), np.array([0.03]))
    jac = factor.linearize(values).jacobian()[0]  # [A_x0 | A_x1 | A_b]
    eps = 1e-6

    def err(vals):
        return factor.unwhitenedError(vals)

    numeric = np.zeros((3, 7))
    col = 0
    for key in (X(0), X(1)):
        for d in range(3):
            delta = np.zeros(3)
            delta[d] = eps
            plus, minus = gtsam.Values(values), gtsam.Values(values)
            plus.update(key, values.atPose2(key).retract(delta))
            minus.update(key, values.atPose2(key).retract(-delta))
            numeric[:, col] = (err(plus) - err(minus)) / (2 * eps)
            col += 1
    plus, minus = gtsam.Values(values), gtsam.Values(values)
    plus.update(B(0), np.array([0.03 + eps]))
    minus.update(B(0), np.array([0.03 - eps]))
    numeric[:, 6] = (err(plus) - err(minus)) / (2 * eps)
    # Unit noise: the linearised factor's A is exactly the Jacobian of the error.
    assert np.allclose(jac, numeric, atol=1e-6), (jac, numeric)


def test_biased_odometry_at_zero_bias_equals_between_factor():
    dt, v, w = _ticks()
    odo = BiasedOdometry(dt, v, w)
    noise = gtsam.noiseModel.Isotropic.Sigma(3, 0.01)
    custom = biased_odometry_factor(X(0), X(1), B(0), odo, noise)
    between = gtsam.BetweenFactorPose2(X(0), X(1), gtsam.Pose2(*integrate(dt, v, w)), noise)
    values = gtsam.Values()
    values.insert(X(0), gtsam.Pose2(0.1, 0.2, 0.3))
    values.insert(X(1), gtsam.Pose2(0.5, 0.9, 0.2))
    values.insert(B(0), np.zeros(1))
    assert custom.error(values) == pytest.approx(between.error(values), rel=1e-12)
