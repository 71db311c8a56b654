"""Noise models and factors of the pose graph.

* odometry: ``BetweenFactorPose2`` with the propagated covariance
  (:mod:`baselines.odometry`), or — when a yaw-rate bias is estimated — a
  ``CustomFactor`` (:class:`BiasedOdometry`) linking two keyframes and the bias variable;
* loop closure: ``BetweenFactorPose2`` measuring the identity (same scene cell,
  same heading sector) with a diagonal noise, wrapped in an M-estimator for the
  robust back-end.
"""

from __future__ import annotations

import math

import gtsam
import numpy as np

from .config import PoseGraphConfig
from .odometry import integrate

IDENTITY = gtsam.Pose2()


def robust_kernel(config: PoseGraphConfig):
    """The configured gtsam M-estimator (kernel width in Mahalanobis units)."""
    k = config.backend.kernel_width
    m = gtsam.noiseModel.mEstimator
    if config.backend.estimator == "cauchy":
        return m.Cauchy.Create(k)
    if config.backend.estimator == "huber":
        return m.Huber.Create(k)
    if config.backend.estimator == "dcs":
        return m.DCS.Create(k)
    return m.GemanMcClure.Create(k)


def closure_gaussian(config: PoseGraphConfig, scale: float = 1.0):
    """Diagonal Gaussian noise of a scene-match loop closure (x, y, theta), its sigmas times
    ``scale`` (a closure's place in its chain, :class:`~baselines.closures.ClosureChains`)."""
    s_xy, s_th = config.closures.sigma_xy_m, config.closures.sigma_theta_rad
    return gtsam.noiseModel.Diagonal.Sigmas(np.array([s_xy, s_xy, s_th]) * scale)


def closure_noise(config: PoseGraphConfig, scale: float = 1.0):
    """Noise model put on closure factors: robust-wrapped only for the robust back-end."""
    gaussian = closure_gaussian(config, scale)
    if config.backend.kind == "robust":
        return gtsam.noiseModel.Robust.Create(robust_kernel(config), gaussian)
    return gaussian


def pose2_logmap_between(poses_i: np.ndarray, poses_j: np.ndarray) -> np.ndarray:
    """``Pose2.Logmap(X_i^-1 X_j)`` for (L, 3) arrays of (x, y, theta), vectorised (gtsam's
    closed form: theta, and the translation mapped through the inverse of V(theta))."""
    poses_i, poses_j = np.asarray(poses_i, dtype=float).reshape(-1, 3), np.asarray(poses_j, dtype=float).reshape(-1, 3)
    ci, si = np.cos(poses_i[:, 2]), np.sin(poses_i[:, 2])
    dx, dy = poses_j[:, 0] - poses_i[:, 0], poses_j[:, 1] - poses_i[:, 1]
    tx, ty = ci * dx + si * dy, -si * dx + ci * dy  # R_i^T (t_j - t_i)
    w = np.arctan2(np.sin(poses_j[:, 2] - poses_i[:, 2]), np.cos(poses_j[:, 2] - poses_i[:, 2]))
    c, s = np.cos(w), np.sin(w)
    c_1 = c - 1.0
    det = c_1 * c_1 + s * s
    small = np.abs(w) < 1e-10
    safe = np.where(small, 1.0, det)
    ux, uy = c * tx + s * ty - tx, -s * tx + c * ty - ty  # R^T t - t
    vx, vy = -uy * (w / safe), ux * (w / safe)  # Rot2(pi/2) * (...) * w / det
    return np.column_stack([np.where(small, tx, vx), np.where(small, ty, vy), w])


def closure_mahalanobis(config: PoseGraphConfig, poses_i: np.ndarray, poses_j: np.ndarray, scale=1.0) -> np.ndarray:
    """Mahalanobis norm of closure residuals Log(X_i^-1 X_j) for (L, 3) pose arrays; ``scale``:
    each closure's sigma multiplier (scalar or (L,))."""
    c = config.closures
    sig = np.array([c.sigma_xy_m, c.sigma_xy_m, c.sigma_theta_rad])
    return np.linalg.norm(pose2_logmap_between(poses_i, poses_j) / sig, axis=1) / np.asarray(scale, dtype=float)


def odometry_noise(cov: np.ndarray):
    """Full-covariance Gaussian of one odometry between-factor."""
    return gtsam.noiseModel.Gaussian.Covariance(cov)


class BiasedOdometry:
    """Odometry between two keyframes as a function of the yaw-rate bias b.

    ``measured(b)`` re-integrates the stored ticks with (w - b); the error of the
    factor on (X_i, X_j, b) is ``Log(measured(b)^-1 X_i^-1 X_j)``, the same as a
    ``BetweenFactorPose2`` whose measurement follows the bias.  dmeasured/db is a
    central difference (the integration is exact, so this is accurate to ~1e-9).
    """

    _H = 1e-5  # rad/s step of the bias derivative

    def __init__(self, dt: np.ndarray, v: np.ndarray, w: np.ndarray) -> None:
        self.dt, self.v, self.w = dt, v, w

    def measured(self, bias: float) -> gtsam.Pose2:
        x, y, th = integrate(self.dt, self.v, self.w, bias)
        return gtsam.Pose2(x, y, th)

    def error(self, this: gtsam.CustomFactor, values: gtsam.Values, jacobians) -> np.ndarray:
        keys = this.keys()
        xi = values.atPose2(keys[0])
        xj = values.atPose2(keys[1])
        b = float(values.atVector(keys[2])[0])
        z = self.measured(b)
        if jacobians is None:
            return gtsam.Pose2.Logmap(z.between(xi.between(xj)))
        h_i = np.zeros((3, 3), order="F")
        h_j = np.zeros((3, 3), order="F")
        rel = xi.between(xj, h_i, h_j)
        h_z = np.zeros((3, 3), order="F")
        h_rel = np.zeros((3, 3), order="F")
        err_pose = z.between(rel, h_z, h_rel)
        h_log = np.zeros((3, 3), order="F")
        e = gtsam.Pose2.Logmap(err_pose, h_log)
        zp = self.measured(b + self._H)
        zm = self.measured(b - self._H)
        dz_db = (gtsam.Pose2.Logmap(z.between(zp)) - gtsam.Pose2.Logmap(z.between(zm))) / (2.0 * self._H)
        jacobians[0] = h_log @ h_rel @ h_i
        jacobians[1] = h_log @ h_rel @ h_j
        jacobians[2] = (h_log @ h_z @ dz_db).reshape(3, 1)
        return e


def biased_odometry_factor(key_i: int, key_j: int, key_b: int, odo: BiasedOdometry, noise) -> gtsam.CustomFactor:
    """CustomFactor on (X_i, X_j, b) for one keyframe interval."""
    return gtsam.CustomFactor(noise, [key_i, key_j, key_b], odo.error)


def wrap_angle(theta: float) -> float:
    """Wrap an angle into (-pi, pi]."""
    return math.atan2(math.sin(theta), math.cos(theta))
