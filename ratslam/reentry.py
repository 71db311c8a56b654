"""Re-entry fusion (not in the paper): how far to trust a re-entry against the odometry.

At a re-entry (a switch to a familiar experience ``j``) two poses of the robot are at hand:

- the pose the pose cells give: ``j``'s map pose composed with the peak's offset from ``j``'s
  cells (what the paper uses alone, as if the view were exact);
- the pose the map and the odometry predict: the current experience's map pose composed with
  the odometry since it was entered.

The prediction's error relative to ``j`` is the odometry's error over the path driven since the
robot was last at ``j`` (the map was laid out along that path). :class:`PathNoise` gives its
first-order covariance between any two ticks from running sums, so each experience only keeps
the sums at its last visit; :func:`kalman_fuse` weighs the two poses by their covariances.

Odometry model (per tick of ``dt``): the speed and yaw rate carry white noise of standard
deviation ``sigma_v`` (m/s) and ``sigma_w`` (rad/s). A heading error at tick k displaces every
later position by the lever arm from the position before tick k's step; a speed error moves the
robot along its heading at tick k. With ``q_w = (sigma_w dt)^2``, ``q_v = (sigma_v dt)^2`` and
``(x_k, y_k)`` the dead-reckoned positions, the covariance of the pose at tick n relative to the
pose at tick m, in the dead-reckoning frame, is::

    Σ_θθ = Σ q_w                         Σ_xθ = -Σ q_w (y_n - y_k)      Σ_yθ = Σ q_w (x_n - x_k)
    Σ_xx = Σ q_w (y_n - y_k)^2 + Σ q_v cos^2 θ_k        Σ_yy = Σ q_w (x_n - x_k)^2 + Σ q_v sin^2 θ_k
    Σ_xy = -Σ q_w (x_n - x_k)(y_n - y_k) + Σ q_v cos θ_k sin θ_k

summed over m < k <= n; expanding the squares leaves nine running sums of the dead-reckoned
positions (``N_SUMS``), so the covariance between any two ticks is a difference of sums.
"""

from __future__ import annotations

import math

import numpy as np

# running sums: q_w, q_w x, q_w y, q_w x^2, q_w y^2, q_w x y, q_v c^2, q_v s^2, q_v c s
N_SUMS = 9


class PathNoise:
    """Dead reckoning with running sums of its first-order noise (module doc)."""

    def __init__(self, sigma_v: float, sigma_w: float, track_noise: bool = True):
        self.sigma_v, self.sigma_w = float(sigma_v), float(sigma_w)
        self.track_noise = track_noise  # False: the dead reckoning alone (the sums stay zero)
        self.pose = np.zeros(3)  # dead-reckoned x, y, θ
        self.sums = np.zeros(N_SUMS)

    def integrate(self, dt: float, v_trans: float, v_rot: float) -> None:
        """One tick of odometry, integrated as the experience map does (heading first)."""
        x, y, th = self.pose
        th += v_rot * dt
        c, s = math.cos(th), math.sin(th)
        if self.track_noise:
            qw, qv = (self.sigma_w * dt) ** 2, (self.sigma_v * dt) ** 2
            # the heading error of this tick acts from the position before its step
            self.sums += (qw, qw * x, qw * y, qw * x * x, qw * y * y, qw * x * y, qv * c * c, qv * s * s, qv * c * s)
        self.pose[:] = (x + v_trans * dt * c, y + v_trans * dt * s, th)

    def covariance_since(self, snapshot: np.ndarray, map_heading: float) -> np.ndarray:
        """Covariance (3, 3) of the current pose relative to the pose when ``snapshot`` (a copy
        of :attr:`sums`) was taken, in the map frame whose current heading is ``map_heading``."""
        return self.to_map(self._dr_covariance_since(snapshot), map_heading)

    def covariance_after(self, fix: np.ndarray, map_heading: float) -> np.ndarray:
        """Covariance (3, 3) of the current pose in the map frame (current heading
        ``map_heading``), given a fix (:meth:`fix`) taken at an earlier tick: the fix's
        covariance carried along the path since (a heading error at the fix swings every later
        position about the fix's position) plus the path's own noise."""
        cov0, x0, y0, sums0 = fix[:9].reshape(3, 3), fix[9], fix[10], fix[11:]
        x, y, _ = self.pose
        jac = np.array([[1.0, 0.0, -(y - y0)], [0.0, 1.0, x - x0], [0.0, 0.0, 1.0]])
        return self.to_map(jac @ cov0 @ jac.T + self._dr_covariance_since(sums0), map_heading)

    def fix(self, cov: np.ndarray, map_heading: float) -> np.ndarray:
        """A record of the current pose's covariance ``cov`` (map frame, current heading
        ``map_heading``) for :meth:`covariance_after`: the covariance in the dead-reckoning
        frame, the dead-reckoned position and the running sums, as one flat array."""
        dr_cov = _rotate(cov, self.pose[2] - map_heading)
        return np.concatenate((dr_cov.ravel(), self.pose[:2], self.sums))

    def to_map(self, dr_cov: np.ndarray, map_heading: float) -> np.ndarray:
        """A covariance in the dead-reckoning frame rotated into the map frame, whose heading
        is ``map_heading`` where the dead reckoning's is :attr:`pose`'s."""
        return _rotate(dr_cov, map_heading - self.pose[2])

    def _dr_covariance_since(self, snapshot: np.ndarray) -> np.ndarray:
        w, wx, wy, wxx, wyy, wxy, vcc, vss, vcs = self.sums - snapshot
        x, y, _ = self.pose
        sxx = y * y * w - 2.0 * y * wy + wyy + vcc
        syy = x * x * w - 2.0 * x * wx + wxx + vss
        sxy = -(x * y * w - x * wy - y * wx + wxy) + vcs
        sxt, syt = -(y * w - wy), x * w - wx
        return np.array([[sxx, sxy, sxt], [sxy, syy, syt], [sxt, syt, w]])

    def get_state(self) -> np.ndarray:
        return np.concatenate((self.pose, self.sums))

    def set_state(self, state: np.ndarray) -> None:
        self.pose = np.asarray(state[:3], dtype=float).copy()
        self.sums = np.asarray(state[3:], dtype=float).copy()


def _rotate(cov: np.ndarray, angle: float) -> np.ndarray:
    """A pose covariance (x, y, θ) seen from a frame rotated by ``angle``."""
    rot = np.eye(3)
    rot[:2, :2] = ((math.cos(angle), -math.sin(angle)), (math.sin(angle), math.cos(angle)))
    return rot @ cov @ rot.T


def innovation(predicted, measured) -> np.ndarray:
    """Measured minus predicted pose (x, y, θ), the heading wrapped."""
    nu = np.asarray(measured, dtype=float) - np.asarray(predicted, dtype=float)
    nu[2] = (nu[2] + math.pi) % (2.0 * math.pi) - math.pi
    return nu


def kalman_fuse(predicted, p_cov: np.ndarray, nu: np.ndarray, m_cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The Kalman update of a predicted pose (x, y, θ) with covariance ``p_cov`` by a
    measurement with innovation ``nu`` and covariance ``m_cov``: the fused pose and its
    covariance."""
    gain = p_cov @ np.linalg.inv(p_cov + m_cov)
    cov = (np.eye(3) - gain) @ p_cov
    return np.asarray(predicted, dtype=float) + gain @ nu, 0.5 * (cov + cov.T)


class InnovationScale:
    """How many times larger than its noise model the odometry's errors are, from the latest
    re-entries (adaptive noise; 1 = the model holds).

    A biased gyro or a wrong wheel radius makes the odometry err far more than white noise does;
    trusting its prediction at a re-entry then bends the map. Each re-entry's innovation ν (the
    pose cells' pose minus the prediction) is kept with its prediction covariance P and the view's
    covariance R; the scale s is the one for which the median of ν^T (s P + R)^-1 ν over the
    latest ``window`` re-entries equals the median of a chi-square with 3 degrees of freedom
    (2.366): the median, so that a wrong re-entry (a look-alike place) cannot inflate it alone.
    s never drops below 1 (the odometry is never trusted beyond its model)."""

    MEDIAN_CHI2_3 = 2.366
    MAX_SCALE = 1e6

    def __init__(self, window: int):
        self.window = int(window)
        self.scale = 1.0
        self.peak_scale = 1.0  # the largest scale so far: a bias the model lacks does not go away
        self._nu = np.zeros((0, 3))
        self._p = np.zeros((0, 3, 3))
        self._r = np.zeros((0, 3, 3))

    def add(self, nu: np.ndarray, p_cov: np.ndarray, m_cov: np.ndarray) -> None:
        """Record one re-entry's innovation and covariances, and update :attr:`scale`."""
        if self.window == 0:
            return
        self._nu = np.concatenate((self._nu, [nu]))[-self.window :]
        self._p = np.concatenate((self._p, [p_cov]))[-self.window :]
        self._r = np.concatenate((self._r, [m_cov]))[-self.window :]
        if self._excess(1.0) <= 0.0:
            self.scale = 1.0
        elif self._excess(self.MAX_SCALE) >= 0.0:
            self.scale = self.MAX_SCALE
        else:  # the median statistic falls as s grows: bisect log s
            lo, hi = 0.0, math.log(self.MAX_SCALE)
            for _ in range(30):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if self._excess(math.exp(mid)) > 0.0 else (lo, mid)
            self.scale = math.exp(hi)
        if len(self._nu) == self.window:  # a median of fewer re-entries is too easily one outlier
            self.peak_scale = max(self.peak_scale, self.scale)

    @property
    def count(self) -> int:
        """How many re-entries the scale is measured on (at most ``window``)."""
        return len(self._nu)

    def trusted(self, limit: float) -> bool:
        """Whether the odometry keeps to its model: the scale, once measured over a full window of
        re-entries, has never exceeded ``limit`` (a bias the model lacks does not go away)."""
        return self.peak_scale <= limit

    def _excess(self, s: float) -> float:
        sol = np.linalg.solve(s * self._p + self._r, self._nu[:, :, None])[:, :, 0]
        return float(np.median(np.einsum("ni,ni->n", self._nu, sol))) - self.MEDIAN_CHI2_3

    def get_state(self) -> np.ndarray:
        rows = np.concatenate((self._nu, self._p.reshape(-1, 9), self._r.reshape(-1, 9)), axis=1)
        return np.concatenate(([[self.scale, self.peak_scale] + [0.0] * 19], rows))

    def set_state(self, state: np.ndarray) -> None:
        self.scale, self.peak_scale = float(state[0, 0]), float(state[0, 1])
        rows = np.asarray(state[1:], dtype=float)
        self._nu = rows[:, :3].copy()
        self._p = rows[:, 3:12].reshape(-1, 3, 3).copy()
        self._r = rows[:, 12:21].reshape(-1, 3, 3).copy()
