"""Localisation on a fixed experience map (not in the paper): navigating a map already built.

Once a map is built (after an exploration, or ``RatSLAM.load``), navigating it needs the robot's
pose on it, not a map that keeps changing under the robot. :class:`MapLocaliser` keeps a copy of
the map (experience poses, views, transitions) and tracks the pose on it with an extended Kalman
filter from the same two inputs RatSLAM has, and nothing else (no ground truth):

- predict, every tick: the wheel odometry (heading first, as the experience map integrates it),
  less the yaw-rate bias RatSLAM had found; white noise of ``odom_speed_noise_m_s`` and
  ``odom_heading_noise_rad_s`` per tick (the re-entry fusion's model);
- update, at each scene onset (a scene number other than the previous tick's): the experiences
  with that view are where the robot may be; the one nearest the prediction in Mahalanobis
  distance, if within ``gate_chi2`` (2 degrees of freedom), is taken as a position measurement
  with ``position_sigma_m`` per axis (a scene places the robot within its cell; the view says
  nothing certain of the heading, which the filter learns from successive positions).

The odometry's noise model is trusted as given: an odometry that errs more than it (a wheel-scale
error) needs larger noise values, or the gate refuses the scenes that would correct it. Adapting
the noise to the innovations (the prediction's covariance scaled, at each update, by the median
statistic of the latest 15 onsets' innovations, as the re-entry fusion does) was measured in the
navigation experiment (office_floor as shipped, seeds 0 / 1): 8 / 49 goals with the taken onsets'
innovations, 6 / 14 with the refused ones too, against 44 / 49 without: the inflated gate lets
look-alike scenes in.

The pose cells and the experience map are not stepped: the map stays as it was (a map that goes on
learning while the robot navigates lays experiences wherever a lost robot believes it is and
then re-enters them, and its relaxation moves the routes being driven).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .config_fields import check_fields, param
from .pipeline import RatSLAM

H_POSITION = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # a scene measures (x, y)


@dataclass(frozen=True)
class LocaliserConfig:
    """Parameters of :class:`MapLocaliser` (module doc)."""

    position_sigma_m: float = param(1.0 / math.sqrt(6.0), gt=0)
    """1-sigma per axis of where a scene places the robot (uniform over a 1 m scene cell)."""
    odom_speed_noise_m_s: float = param(0.01, ge=0)
    """White noise on the odometry's speed per tick."""
    odom_heading_noise_rad_s: float = param(0.01, ge=0)
    """White noise on the odometry's yaw rate per tick."""
    gate_chi2: float = param(9.21, gt=0)
    """Largest squared Mahalanobis distance of a scene's experience from the prediction that is
    still taken as a measurement (9.21: 99% of a chi-square with 2 degrees of freedom)."""
    initial_sigma_m: float = param(0.05, ge=0)
    """1-sigma per axis of the starting pose (the map's own pose of the robot)."""
    initial_sigma_deg: float = param(2.0, ge=0)
    """1-sigma of the starting heading."""

    def __post_init__(self) -> None:
        check_fields(self)


class MapLocaliser:
    """The robot's pose on a fixed copy of ``slam``'s experience map (module doc)."""

    def __init__(self, slam: RatSLAM, config: LocaliserConfig | None = None):
        self.config = config if config is not None else LocaliserConfig()
        self.experience_poses = slam.experience_poses.copy()
        self.views = slam.experience_views.copy()
        self.links = slam.links.copy()
        self.link_dt = slam.link_dt.copy()
        self.yaw_bias = slam.yaw_bias
        self.x = np.array(slam.pose, dtype=float)
        c = self.config
        self.cov = np.diag([c.initial_sigma_m**2, c.initial_sigma_m**2, math.radians(c.initial_sigma_deg) ** 2])
        self._r = c.position_sigma_m**2 * np.eye(2)
        self._last_scene = -1
        self.updates = 0  # scene onsets taken as measurements

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, θ) in the map's frame."""
        return float(self.x[0]), float(self.x[1]), float(self.x[2])

    @property
    def nearest_experience(self) -> int:
        """The experience nearest the pose (-1 for an empty map)."""
        if not len(self.experience_poses):
            return -1
        d = np.hypot(*(self.experience_poses[:, :2] - self.x[:2]).T)
        return int(np.argmin(d))

    def step(self, dt: float, v_trans: float, v_rot: float, scene_id: int) -> None:
        """One tick: predict with the odometry, update at a scene onset."""
        self._predict(float(dt), float(v_trans), float(v_rot) - self.yaw_bias)
        scene = int(scene_id)
        if scene >= 0 and scene != self._last_scene:
            self._update(scene)
        self._last_scene = scene

    def _predict(self, dt: float, v: float, w: float) -> None:
        x, y, th = self.x
        th += w * dt  # heading first, as ExperienceMap.integrate
        c, s = math.cos(th), math.sin(th)
        f = np.array([[1.0, 0.0, -v * dt * s], [0.0, 1.0, v * dt * c], [0.0, 0.0, 1.0]])
        g = np.array([[dt * c, -v * dt * dt * s], [dt * s, v * dt * dt * c], [0.0, dt]])  # d/d(v, w)
        q = np.diag([self.config.odom_speed_noise_m_s**2, self.config.odom_heading_noise_rad_s**2])
        self.x = np.array([x + v * dt * c, y + v * dt * s, th])
        self.cov = f @ self.cov @ f.T + g @ q @ g.T

    def _update(self, scene: int) -> None:
        candidates = np.flatnonzero(self.views == scene)
        if not len(candidates):
            return
        p = self.cov
        s = p[:2, :2] + self._r
        nu = self.experience_poses[candidates, :2] - self.x[:2]
        d2 = np.einsum("ni,ij,nj->n", nu, np.linalg.inv(s), nu)
        k = int(np.argmin(d2))
        if d2[k] > self.config.gate_chi2:
            return
        gain = p @ H_POSITION.T @ np.linalg.inv(s)
        self.x = self.x + gain @ nu[k]
        self.x[2] = (self.x[2] + math.pi) % (2.0 * math.pi) - math.pi
        cov = (np.eye(3) - gain @ H_POSITION) @ p
        self.cov = 0.5 * (cov + cov.T)
        self.updates += 1
