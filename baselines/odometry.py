"""SE(2) integration of wheel odometry between keyframes, with its covariance.

Each tick k reports a forward speed v_k (m/s) and a yaw rate w_k (rad/s) held for
dt_k seconds.  The tick moves the robot by the SE(2) exponential of the twist
(v_k dt_k, 0, (w_k - b) dt_k) — an exact circular arc — where b is a yaw-rate
bias (0 unless the graph estimates one).  Composing the ticks between two
keyframes gives the relative pose measured by an odometry between-factor.

Covariance: every tick's twist carries independent noise with std
(sigma_v dt, sigma_lat dt, sigma_w dt).  A right perturbation eta_k of tick k
moves the end pose P_n by Ad(P_n^-1 P_k) eta_k, so
``Sigma = sum_k Ad_k Q_k Ad_k^T`` with Ad_k the adjoint of P_n^-1 P_k.
"""

from __future__ import annotations

import math

import numpy as np

from slamkit.arcs import SMALL_TURN, cumulative_poses, integrate, tick_increments

__all__ = ["cumulative_poses", "integrate", "relative_covariance", "tick_increments"]


def relative_covariance(
    dt: np.ndarray,
    v: np.ndarray,
    w: np.ndarray,
    sigma_v: float,
    sigma_w: float,
    sigma_lateral: float,
    bias: float = 0.0,
) -> np.ndarray:
    """3x3 covariance (tangent space at the end pose, gtsam's Pose2 convention)."""
    poses = cumulative_poses(dt, v, w, bias)
    xn, yn, tn = poses[-1]
    # T_k = P_n^-1 P_k, the pose of tick k's end seen from the final pose.
    cn, sn = math.cos(tn), math.sin(tn)
    ddx = poses[:, 0] - xn
    ddy = poses[:, 1] - yn
    tx = cn * ddx + sn * ddy
    ty = -sn * ddx + cn * ddy
    tt = poses[:, 2] - tn
    c, s = np.cos(tt), np.sin(tt)
    n = len(dt)
    ad = np.zeros((n, 3, 3))
    ad[:, 0, 0] = c
    ad[:, 0, 1] = -s
    ad[:, 0, 2] = ty
    ad[:, 1, 0] = s
    ad[:, 1, 1] = c
    ad[:, 1, 2] = -tx
    ad[:, 2, 2] = 1.0
    q = np.stack([(sigma_v * dt) ** 2, (sigma_lateral * dt) ** 2, (sigma_w * dt) ** 2], axis=1)
    cov = np.einsum("nij,nj,nkj->ik", ad, q, ad)
    return 0.5 * (cov + cov.T)


class TickBuffer:
    """Odometry ticks since the last keyframe, with a running relative pose.

    The running pose (integrated tick by tick with plain floats) drives the
    keyframe triggers and the current ``pose``; the factor measurement is
    recomputed from the stored ticks with :func:`integrate`.
    """

    __slots__ = ("distance", "dt", "theta", "v", "w", "x", "y")

    def __init__(self) -> None:
        self.dt: list[float] = []
        self.v: list[float] = []
        self.w: list[float] = []
        self.x = 0.0
        self.y = 0.0
        self.theta = 0.0
        self.distance = 0.0

    def __len__(self) -> int:
        return len(self.dt)

    def add(self, dt: float, v: float, w: float, bias: float) -> None:
        """Append one tick and advance the running pose (exact arc, bias removed)."""
        self.dt.append(dt)
        self.v.append(v)
        self.w.append(w)
        a = v * dt
        phi = (w - bias) * dt
        if abs(phi) < SMALL_TURN:
            dx, dy = a * (1.0 - phi * phi / 6.0), a * (phi / 2.0 - phi**3 / 24.0)
        else:
            dx, dy = a * math.sin(phi) / phi, a * (1.0 - math.cos(phi)) / phi
        c, s = math.cos(self.theta), math.sin(self.theta)
        self.x += c * dx - s * dy
        self.y += s * dx + c * dy
        self.theta += phi
        self.distance += abs(a)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The stored ticks as float arrays (dt, v, w)."""
        return (np.asarray(self.dt, dtype=float), np.asarray(self.v, dtype=float), np.asarray(self.w, dtype=float))
