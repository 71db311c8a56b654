"""Localisation on a fixed experience map (not in the paper): navigating a map already built.

Once a map is built (after an exploration, or ``RatSLAM.load``), navigating it needs the robot's
pose on it, not a map that keeps changing under the robot. :class:`MapLocaliser` keeps a copy of
the map (experience poses, views, transitions) and tracks the pose on it with an extended Kalman
filter from the same two inputs RatSLAM has, and nothing else (no ground truth):

- predict, every tick: the wheel odometry (heading first, as the experience map integrates it),
  less the yaw-rate bias RatSLAM had found; white noise of ``odom_speed_noise_m_s`` and
  ``odom_heading_noise_rad_s`` per tick (the re-entry fusion's model);
- update, at each *sighting*: a scene number's onset, unless the same number was seen within
  ``repeat_m`` of path before (a cell border's flicker, or standing still, is the same sighting;
  taken again and again, the onsets at the far side of a cell pulled the robot back to its entry).
  The experiences with that view are where the robot may be; the one nearest the prediction in
  Mahalanobis distance, if within ``gate_chi2`` (2 degrees of freedom), picks the place, and the
  centre of that view's experiences within ``cluster_m`` of it is taken as a position measurement
  with ``position_sigma_m`` per axis (a place visited often has several experiences of one view,
  spread over its cell; the nearest of them alone pulls every measurement towards the
  prediction). The view says nothing certain of the heading: the filter learns it from
  successive positions.

Two recoveries, for a robot whose pose has drifted beyond the gate (every scene that would correct
it refused) or that has driven off the routes the map knows:

- relocalisation (``relocalise``): the latest sightings, laid out as the dead reckoning says they
  were, are matched against the map as a sequence (:mod:`ratslam.relocalisation`); a placement
  that explains clearly more of them than the filter's track, and unambiguously, replaces it;
- the way back (``lost_m``): after that much path without a sighting that matched, the robot is
  *lost* and :meth:`way_back` is its own dead-reckoned path back to where it last matched (loops
  erased), which a controller can drive (``harness.navigation.controller``) until a sighting matches.

Measured in the navigation experiment (``ratslam-harness nav office_floor --localise``): see the
README's Navigation section (the filter alone lost the robot for good on some seeds; both
recoveries and the cluster centre brought every seed to 48-50 goals of 50).

The pose cells and the experience map are not stepped: the map stays as it was (a map that goes on
learning while the robot navigates lays experiences wherever a lost robot believes it is and
then re-enters them, and its relaxation moves the routes being driven).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from slamkit.config_fields import check_fields, param

from .pipeline import RatSLAM
from .relocalisation import Alignment, OnsetWindow, ViewIndex, best_alignment, support

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
    repeat_m: float = param(1.0, ge=0)
    """A scene seen again within this much path of its previous onset is the same sighting."""
    cluster_m: float = param(1.0, ge=0)
    """A sighting measures the centre of its view's experiences within this of the one chosen."""
    lost_m: float = param(3.0, gt=0)
    """Lost: this much path since the latest sighting that matched the map (on the routes the
    map knows a sighting comes about every scene cell)."""
    trail_step_m: float = param(0.2, gt=0)
    """The way back keeps the path since the latest match as points this far apart."""
    relocalise: bool = param(True)
    """Relocalise from the latest sightings' sequence (module doc)."""
    window_onsets: int = param(20, ge=3)
    """The sequence: at most this many latest sightings of scenes the map knows ..."""
    window_m: float = param(20.0, gt=0)
    """... over at most this much dead-reckoned path."""
    inlier_m: float = param(0.75, gt=0)
    """A placement explains a sighting that it puts this near an experience of its view."""
    min_support: int = param(8, ge=2)
    """A relocalisation needs at least this many sightings explained ..."""
    support_margin: int = param(3, ge=1)
    """... and this many more than the filter's track and than any placement elsewhere (look-alike
    places explain the same sightings: no relocalisation between them)."""
    relocalised_sigma_deg: float = param(5.0, gt=0)
    """Least 1-sigma of the heading just after a relocalisation; more where the sightings' spread
    leaves the rotation looser (``Alignment.heading_sigma``; position: ``position_sigma_m``)."""

    def __post_init__(self) -> None:
        check_fields(self)


class MapLocaliser:
    """The robot's pose on a fixed copy of ``slam``'s experience map (module doc)."""

    def __init__(self, slam: RatSLAM, config: LocaliserConfig | None = None):
        self.config = c = config if config is not None else LocaliserConfig()
        self.experience_poses = slam.experience_poses.copy()
        self.views = slam.experience_views.copy()
        self.links = slam.links.copy()
        self.link_dt = slam.link_dt.copy()
        self.yaw_bias = slam.yaw_bias
        self.x = np.array(slam.pose, dtype=float)
        self.cov = np.diag([c.initial_sigma_m**2, c.initial_sigma_m**2, math.radians(c.initial_sigma_deg) ** 2])
        self._r = c.position_sigma_m**2 * np.eye(2)
        self._index = ViewIndex(self.experience_poses, self.views)
        self._last_scene = -1
        self._sighted: dict[int, float] = {}  # scene -> path length at its latest onset
        # the dead reckoning alone, in its own frame, and the path driven along it
        self._dr = np.zeros(3)
        self._path_m = 0.0
        self._window = OnsetWindow(c.window_onsets, c.window_m)  # the latest sightings, for relocalising
        self._trail = [self._dr[:2].copy()]  # the way back: dead-reckoned path since the latest match
        self._trail_m = 0.0  # path length at the trail's newest point
        self._matched_m = 0.0  # path length at the latest match
        self.updates = 0  # sightings taken as measurements
        self.relocalisations = 0
        self.times_lost = 0  # how often the robot became lost
        self.ways_back_given_up = 0  # ... and came back to its latest match without a new one
        self._was_lost = False

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

    @property
    def lost(self) -> bool:
        """Whether the robot has gone ``lost_m`` of path without a sighting matching the map."""
        return self._path_m - self._matched_m > self.config.lost_m

    def way_back(self) -> np.ndarray:
        """(K, 2) map points: the path driven since the latest match, newest first, ending where
        that match was (as the dead reckoning has it, carried into the map as the pose is)."""
        a = Alignment.between(self.x, self._dr)
        return np.array([a.apply((x, y, 0.0))[:2] for x, y in reversed(self._trail)])

    def give_up_way_back(self) -> None:
        """Back where the latest match was and still none: the way back starts anew from here."""
        self.ways_back_given_up += 1
        self._matched()

    def stats(self) -> dict[str, int]:
        """Counts of what the localiser did: sightings taken, relocalisations, times lost, ways
        back given up."""
        return {
            "sightings_matched": self.updates,
            "relocalisations": self.relocalisations,
            "times_lost": self.times_lost,
            "ways_back_given_up": self.ways_back_given_up,
        }

    def step(self, dt: float, v_trans: float, v_rot: float, scene_id: int) -> None:
        """One tick: predict with the odometry, update at a new sighting of a scene."""
        self._predict(float(dt), float(v_trans), float(v_rot) - self.yaw_bias)
        scene = int(scene_id)
        if scene >= 0 and scene != self._last_scene and self._new_sighting(scene) and len(self._index.of(scene)):
            self._update(scene)
            if self.config.relocalise:
                self._window.add(scene, self._dr, self._path_m)
                self._relocalise()
        self._last_scene = scene

    def _predict(self, dt: float, v: float, w: float) -> None:
        self.x = _advance(self.x, dt, v, w)
        c, s = math.cos(self.x[2]), math.sin(self.x[2])
        f = np.array([[1.0, 0.0, -v * dt * s], [0.0, 1.0, v * dt * c], [0.0, 0.0, 1.0]])
        g = np.array([[dt * c, -v * dt * dt * s], [dt * s, v * dt * dt * c], [0.0, dt]])  # d/d(v, w)
        q = np.diag([self.config.odom_speed_noise_m_s**2, self.config.odom_heading_noise_rad_s**2])
        self.cov = f @ self.cov @ f.T + g @ q @ g.T
        self._dr = _advance(self._dr, dt, v, w)
        self._path_m += abs(v * dt)
        lost = self.lost
        self.times_lost += int(lost and not self._was_lost)
        self._was_lost = lost
        if not lost and self._path_m - self._trail_m >= self.config.trail_step_m:
            self._extend_trail()

    def _new_sighting(self, scene: int) -> bool:
        last = self._sighted.get(scene)
        self._sighted[scene] = self._path_m
        return last is None or self._path_m - last >= self.config.repeat_m

    def _update(self, scene: int) -> None:
        p = self.cov
        s = p[:2, :2] + self._r
        nu = self.experience_poses[self._index.of(scene), :2] - self.x[:2]
        d2 = np.einsum("ni,ij,nj->n", nu, np.linalg.inv(s), nu)
        k = int(np.argmin(d2))
        if d2[k] > self.config.gate_chi2:
            return
        innovation = nu[np.hypot(*(nu - nu[k]).T) <= self.config.cluster_m].mean(axis=0)
        gain = p @ H_POSITION.T @ np.linalg.inv(s)
        self.x = self.x + gain @ innovation
        self.x[2] = (self.x[2] + math.pi) % (2.0 * math.pi) - math.pi
        cov = (np.eye(3) - gain @ H_POSITION) @ p
        self.cov = 0.5 * (cov + cov.T)
        self.updates += 1
        self._matched()

    def _relocalise(self) -> None:
        """Take the placement the latest sightings' sequence gives, if it explains clearly more of
        them than the filter's track does and than any placement elsewhere would."""
        c = self.config
        track = Alignment.between(self.x, self._dr)
        ours = int(support(*track.as_arrays(), self._window, self._index, c.inlier_m)[0])
        if len(self._window) - ours < c.support_margin:
            return
        found = best_alignment(self._window, self._index, c.inlier_m)
        if found is None:
            return
        best, runner_up = found
        if best.support < max(c.min_support, ours + c.support_margin, runner_up + c.support_margin):
            return
        self.x = best.apply(self._dr)
        # the heading as loose as the sightings leave it: onsets bunched in a room once set it 36 deg
        # off at a claimed 5 deg, and no later sighting could move it (measured on full_floor)
        sh = max(math.radians(c.relocalised_sigma_deg), best.heading_sigma(c.position_sigma_m))
        self.cov = np.diag([c.position_sigma_m**2, c.position_sigma_m**2, min(sh, math.pi) ** 2])
        self.relocalisations += 1
        self._matched()

    def _matched(self) -> None:
        """The robot is where the map has seen it: the way back starts here."""
        self._matched_m = self._trail_m = self._path_m
        self._trail = [self._dr[:2].copy()]

    def _extend_trail(self) -> None:
        """Add the pose to the way back, erasing any loop it closes (a robot that backed off a
        wall and drove on has retraced its own steps: the way back skips them)."""
        here = self._dr[:2].copy()
        pts = np.array(self._trail)
        near = np.flatnonzero(np.hypot(pts[:, 0] - here[0], pts[:, 1] - here[1]) < self.config.trail_step_m)
        if len(near):
            del self._trail[int(near[0]) + 1 :]
        else:
            self._trail.append(here)
        self._trail_m = self._path_m


def _advance(pose: np.ndarray, dt: float, v: float, w: float) -> np.ndarray:
    """``pose`` (x, y, θ) after one tick of odometry, heading first (as ExperienceMap.integrate)."""
    th = pose[2] + w * dt
    return np.array([pose[0] + v * dt * math.cos(th), pose[1] + v * dt * math.sin(th), th])
