"""Configuration of the RatSLAM pipeline: one dataclass with documented defaults.

Units: pose-cell quantities are in cell units (x', y' cells of ``cell_size_m``, θ' cells of
``360 / n_theta`` degrees); map quantities are in metres and radians; rates per second.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

_CORRECTIONS = ("stable", "printed")
_ENERGIES = ("sum", "product")


@dataclass(frozen=True)
class RatSLAMConfig:
    """All RatSLAM parameters, with the defaults used for the paper's figures.

    Pose cells (competitive attractor network, wrapping on every axis):
      nx, ny, n_theta: grid size. 60 x 60 cells of 0.25 m wrap every 15 m, so on the large office
        floors one pose-cell region serves several places (the paper's Fig 4 "hash collision").
        36 heading cells of 10 degrees.
      cell_size_m: side of an (x', y') cell, 0.25 m (the paper's indoor value).
      excite_sigma, excite_sigma_theta, excite_radius: separable Gaussian local excitation,
        widths (cells) in (x', y') and in θ', truncation radius; the weights sum to 1, so
        excitation conserves activity. A narrower heading profile keeps the layers of the packet
        moving in nearly the same direction (the packet's x'y' speed is the activity-weighted
        mean of cos Δθ over its heading layers).
      inhibit_sigma, inhibit_sigma_theta, inhibit_radius, inhibit_weight: wider Gaussian local
        inhibition; after excitation the network subtracts ``inhibit_weight`` times the
        inhibition-blurred activity.
      global_inhibition: constant subtracted from every cell afterwards (then clipped at zero).
        It sets how long unsupported activity (one tick of a false view) survives: small enough
        that a few consecutive familiar scenes add up into a packet that wins, large enough that
        a lone false view fades without moving the peak.
      Activity is then normalised to total 1.
      pc_trans_gain: gain on the translation fed to path integration. The clipping in the
        competitive dynamics trims the leading edge of a moving packet, so on the lattice it
        moves ~5% slower than the shift applied (measured for the default network: 0.95 of
        v·t at 0.3 m/s, 0.93 at 0.1 m/s, 0.98 at 0.6 m/s). 1.05 compensates at the paper's
        0.3 m/s; 1.0 is the uncompensated network.
      peak_radius: half-width (cells) of the neighbourhood whose wrap-aware weighted circular
        mean refines the strongest cell into the peak.
      pi_bias_deg_s: constant added to the rotational velocity used by the pose cells' path
        integration only (experience transitions keep the wheel odometry). This is the paper's
        Figs 8-10 manipulation (the bias in path integration only, as the paper did); 0 = off.
      snap_cells: a tick whose peak moves further than this (wrap-aware Euclidean distance in
        cell units) is reported as a snap.

    Local view cells (one per scene number; -1 = nothing recognisable, no view cell):
      view_learn_rate: Hebbian rate λ, association β <- max(β, λ · V · P) with the active cells.
      view_inject: injection strength δ; a familiar view adds δ · V · β to the pose cells.
      view_learn_threshold: pose cells weaker than this fraction of the packet maximum are not
        associated (keeps associations sparse).
      view_fatigue_rate, view_fatigue_recovery: habituation of a view cell. Its activity is
        V = max(1 - fatigue, 0); fatigue grows by the rate on each tick the scene is in view
        (capped at 2) and recovers by the recovery value on every other tick. A scene seen for a
        while therefore injects (and learns) only around its onset (10 ticks at the default) and
        cannot pin the packet; a lone aliased scene injects a bounded amount, while a sequence
        of familiar scenes injects at every scene onset, consistently, and so snaps the packet.
      view_min_age_ticks: associations younger than this many ticks never inject, so a view does
        not pull the packet back to where it was learnt moments ago.

    Experience map (paper eqs 2-14):
      view_confirm_ticks: the experience map acts on a scene (switching to or creating an
        experience) only once the same scene number has been reported on this many consecutive
        ticks; until then the tick counts as "no view" for the map (the pose cells and view cells
        still see it). 1 is the paper's behaviour. With 1, a one-tick false positive that
        happens to come while the packet sits where an experience with that view lies (two
        places sharing pose cells, which the bent pose-cell paths of Figs 8-10 make common)
        switches to that experience and adds a false transition; 2 ignores such one-tick views.
      snap_settle_ticks: after a snap the experience map treats this many ticks as "no view"
        (it neither switches nor creates experiences; odometry is still integrated). When an
        aliased scene gives a rival packet as much activity as the true one, the peak flips
        between the two for a while, and every flip is a snap; a map that follows a flipping peak
        links places metres apart. Waiting until the peak has been stable for a while lets only a
        settled hypothesis close a loop; a true relocalisation is merely delayed. 0 = the paper's
        behaviour (the map acts on every tick's peak).
      offset_transitions: the map switches to an experience whose cells lie within the zone of
        influence of the peak, not on it. True: the transition is measured to the experience's
        own place, i.e. the peak's offset from the experience's cells (at most r_inf cells and
        theta_inf heading cells, expressed in the experience's frame) is taken off the odometry
        stored in the transition, and the current pose starts at that offset. False: the paper's
        transition, as if the robot were exactly at the experience, so every re-entry adds up to
        r_inf cells (0.5 m) of error to the map.
        Measured, experience-map ATE (against ground truth where each experience was created;
        seed 0; small_loop 15 min with 1.5 / 6 deg/s path-integration bias, 1.5 deg/s odometric
        bias; open_plan 15 min; office_floor 50 min on the 40 x 40 grid):
          both on (default)            0.06 / 0.06 / 0.11 / 0.28 / 0.23 m
          snap_settle_ticks = 0        0.22 / 0.07 / 0.30 / 0.60 / 0.30 m
          offset_transitions = False   0.07 / 0.06 / 0.10 / 0.44 / 0.38 m
          both off (the paper's map)   0.15 / 0.05 / 0.20 / 0.74 / 0.52 m
      r_inf: zone of influence radius in (x', y') cells (eqs 2-3).
      theta_inf: zone of influence in θ' cells (eqs 4-5).
      energy: "sum" = paper eq 9, E = E_V (E_xy + E_θ): a view can match on heading alone, so an
        aliased or false-positive scene can switch to an experience metres away; an experience
        stays current for as long as its scene is in view, so the map is sparser (one
        experience per scene visit).
        "product" = E_V E_xy E_θ: the stricter form, the view must agree on place and heading.
        Measured on small_loop (15 min, seed 0, experience ATE; path-integration bias 1.5 / 3 /
        6 deg/s, then 1.5 deg/s odometric bias), with 1% per-tick false positives: product
        0.07 / 0.08 / 0.07 / 0.11 m, sum 0.08 / 0.08 / 0.06 / 0.15 m; with view_confirm_ticks=1
        as well, product 0.12 / 0.12 / 2.63 / 0.10 m, sum 0.86 / 1.52 / 2.68 / 0.87 m.
      alpha_theta, alpha_d: correction rates of eqs 12-14 (paper Table 1: 0.5).
      correction: "stable" = α times the mean residual over the experience's links (converges);
        "printed" = α times the sum of residuals exactly as printed; it overshoots at experiences
        with more than two links and diverges (kept for the record, not for use; measured: the
        small_loop map's poses become non-finite within the 15-minute run).
      correction_iterations: correction passes per tick (the paper runs one per tick).

    Re-entry fusion (not in the paper; off by default, derived for real logs by harness/scale.py):
      reentry_position_sigma_m, reentry_heading_sigma_deg: how well a re-entry (a switch to an
        experience) places the robot: 1-sigma per axis and in heading. Both 0 (the default) is
        the paper: the pose after a re-entry is wherever the pose cells say, relative to the
        experience (``offset_transitions``), as if the view were exact. Both positive: the map
        also predicts that pose (the previous experience's map pose plus the odometry since), with
        a covariance grown from the odometry noise below since the last re-entry (first-order
        propagation in the map frame), and a Kalman update fuses the two; the link and the new
        current pose take the fused pose, and the covariance shrinks. Where the odometry is much
        better than the view (long straight drives with a heading that does not drift, scene cells
        of 2 m recognised anywhere within them) a re-entry then corrects the pose only by as much
        as it knows better; with zero covariance (just after a re-entry) it changes nothing.
        Cause, measured on CMU Plaza 1 (analysis against ground truth): the pose cells' heading at a
        re-entry errs 2.0-3.2 deg rms and its place ~0.7 m (the packet is snapped onto the
        experience's cells although the vehicle drove a parallel lane); the odometry heading does
        not drift. With those errors the map's least-squares optimum is 1.86 m ATE (seed 2) where
        the same links with the closures' true headings give 1.49 m and with true closures
        1.38 m: each re-entry bent the map by the pose cells' heading error.
      odom_speed_noise, odom_heading_noise: white noise on the odometry's speed (m/s) and yaw
        rate (rad/s) per tick, for the prediction's covariance (only used with the fusion on).
      Measured (derived configs: sigmas = the pose graph's closure_sigma_xy and one heading cell
      / sqrt(12) = 2.89 deg, the noise = the pose graph's revisit-tested odometry noise), RatSLAM
      ATE online / experience map, Plaza 1 seeds 0/1/2 (odometry 1.47 m):
          fusion off   1.68/2.13/2.44 // 1.33/1.62/1.77 m
          fusion on    1.42/1.45/1.52 // 1.30/1.33/1.39 m
      Plaza 2 seeds 0/1/2, 0.457 m cells (odometry 15.9 m): off 2.82/2.69/2.91 // 1.37/1.30/1.31 m,
      on 2.98/2.75/2.25 // 1.60/1.87/1.41 m (its heading drifts 8.7 deg per 100 m, so the
      odometry is trusted less and the pose cells' re-entries still hold the map).
      Heading-only fusion (position from the pose cells) with heading sigma 2.89 / 5.77 / 11.5 deg:
      Plaza 1 maps 1.32/1.32/1.54, 1.33/1.28/1.48, 1.33/1.26/1.45 m, Plaza 2 (0.457 m cells)
      1.46/1.33/1.53, 1.86/1.66/1.99, 2.97/2.58/3.14 m: no single value served both logs.
      Weighting re-entry links less in eqs 12-14 (weights 0.25 and 0.0625) did not help
      (Plaza 1 maps 1.31/1.61/1.82 and 1.29/1.60/1.86 m): a re-entry's error is carried by the
      links that follow it (new experiences are laid out from the re-entered one), not by
      the re-entry link alone.
    """

    # pose cells
    nx: int = 60
    ny: int = 60
    n_theta: int = 36
    cell_size_m: float = 0.25
    excite_sigma: float = 1.0
    excite_sigma_theta: float = 0.6
    excite_radius: int = 2
    inhibit_sigma: float = 2.0
    inhibit_sigma_theta: float = 1.0
    inhibit_radius: int = 3
    inhibit_weight: float = 0.5
    global_inhibition: float = 3e-5
    peak_radius: int = 3
    pc_trans_gain: float = 1.05
    pi_bias_deg_s: float = 0.0
    snap_cells: float = 3.0
    # local view cells
    view_learn_rate: float = 1.0
    view_inject: float = 0.1
    view_learn_threshold: float = 0.1
    view_fatigue_rate: float = 0.1
    view_fatigue_recovery: float = 0.05
    view_min_age_ticks: int = 70
    # experience map
    view_confirm_ticks: int = 2
    snap_settle_ticks: int = 50
    offset_transitions: bool = True
    r_inf: float = 2.0
    theta_inf: float = 2.0
    energy: str = "product"
    alpha_theta: float = 0.5
    alpha_d: float = 0.5
    correction: str = "stable"
    correction_iterations: int = 1
    reentry_position_sigma_m: float = 0.0
    reentry_heading_sigma_deg: float = 0.0
    odom_speed_noise: float = 0.0
    odom_heading_noise: float = 0.0

    def __post_init__(self) -> None:
        for name in ("nx", "ny", "n_theta"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 4:
                raise ValueError(f"{name} must be an integer >= 4, got {getattr(self, name)!r}")
        for name in ("excite_radius", "inhibit_radius", "peak_radius"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 0:
                raise ValueError(f"{name} must be a non-negative integer, got {value!r}")
        if 2 * max(self.excite_radius, self.inhibit_radius, self.peak_radius) + 1 > min(self.nx, self.ny, self.n_theta):
            raise ValueError("excite_radius/inhibit_radius/peak_radius: kernel wider than the grid")
        for name in (
            "cell_size_m",
            "pc_trans_gain",
            "excite_sigma",
            "excite_sigma_theta",
            "inhibit_sigma",
            "inhibit_sigma_theta",
            "r_inf",
            "theta_inf",
            "snap_cells",
            "view_learn_rate",
            "view_fatigue_rate",
        ):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive finite number, got {value!r}")
        for name in ("inhibit_weight", "global_inhibition", "view_inject", "view_fatigue_recovery"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a non-negative finite number, got {value!r}")
        if not 0 <= self.view_learn_threshold < 1:
            raise ValueError(f"view_learn_threshold must be in [0, 1), got {self.view_learn_threshold!r}")
        if not isinstance(self.view_confirm_ticks, int) or self.view_confirm_ticks < 1:
            raise ValueError(f"view_confirm_ticks must be an integer >= 1, got {self.view_confirm_ticks!r}")
        if not isinstance(self.snap_settle_ticks, int) or self.snap_settle_ticks < 0:
            raise ValueError(f"snap_settle_ticks must be a non-negative integer, got {self.snap_settle_ticks!r}")
        if not isinstance(self.offset_transitions, bool):
            raise ValueError(f"offset_transitions must be True or False, got {self.offset_transitions!r}")
        if not isinstance(self.view_min_age_ticks, int) or self.view_min_age_ticks < 1:
            raise ValueError(f"view_min_age_ticks must be an integer >= 1, got {self.view_min_age_ticks!r}")
        if not (isinstance(self.pi_bias_deg_s, (int, float)) and math.isfinite(self.pi_bias_deg_s)):
            raise ValueError(f"pi_bias_deg_s must be a finite number, got {self.pi_bias_deg_s!r}")
        for name in ("alpha_theta", "alpha_d"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and 0 <= value <= 1):
                raise ValueError(f"{name} must be in [0, 1], got {value!r}")
        for name in ("reentry_position_sigma_m", "reentry_heading_sigma_deg", "odom_speed_noise", "odom_heading_noise"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a non-negative finite number, got {value!r}")
        if (self.reentry_position_sigma_m > 0) != (self.reentry_heading_sigma_deg > 0):
            raise ValueError("reentry_position_sigma_m and reentry_heading_sigma_deg: both 0 (off) or both positive")
        if not isinstance(self.correction_iterations, int) or self.correction_iterations < 0:
            raise ValueError(
                f"correction_iterations must be a non-negative integer, got {self.correction_iterations!r}"
            )
        if self.correction not in _CORRECTIONS:
            raise ValueError(f"correction must be one of {_CORRECTIONS}, got {self.correction!r}")
        if self.energy not in _ENERGIES:
            raise ValueError(f"energy must be one of {_ENERGIES}, got {self.energy!r}")

    @property
    def theta_cell_rad(self) -> float:
        """Size of one heading cell in radians."""
        return 2.0 * math.pi / self.n_theta

    @property
    def shape(self) -> tuple[int, int, int]:
        """Pose-cell grid shape (nx, ny, n_theta)."""
        return (self.nx, self.ny, self.n_theta)

    def replace(self, **changes) -> RatSLAMConfig:
        """A copy with some fields changed (validated)."""
        return dataclasses.replace(self, **changes)
