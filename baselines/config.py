"""Configuration of the GTSAM Pose2 pose-graph baseline.

Every default is documented next to the field; the numbers that come from the
simulated robot (odometry noise, scene-cell size, heading sectors) are the
simulator's world defaults (7 Hz ticks, 0.3 m/s, 1 m x 1 m x 90 deg scene cells).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

BACKENDS = ("gaussian", "robust", "gnc")
ESTIMATORS = ("cauchy", "huber", "dcs", "geman_mcclure")
GNC_LOSSES = ("tls", "gm")

# Kernel width (in whitened residual units, i.e. Mahalanobis distance) used when
# ``estimator_k`` is left at None.  Cauchy and Huber take the usual 95%-efficiency
# constants; DCS takes Agarwal et al.'s recommended Phi = 1; Geman-McClure is
# given k = 3 so that an inlier at about 3 sigma still keeps about half its weight.
DEFAULT_ESTIMATOR_K = {
    "cauchy": 2.3849,
    "huber": 1.345,
    "dcs": 1.0,
    "geman_mcclure": 3.0,
}


@dataclass(frozen=True)
class PoseGraphConfig:
    """Parameters of :class:`baselines.PoseGraphSLAM`.

    The default is what a practitioner picks for aliased, false-positive-prone
    place labels: online (iSAM2) optimisation with a robust (Geman-McClure)
    loop-closure kernel, no batch pass at the end, no yaw-bias variable.

    Keyframes
    ---------
    keyframe_distance:
        A new keyframe is taken once the robot has travelled this far (m, path
        length of the integrated odometry) since the last one. 0.5 m is half a
        scene cell, so every 1 m cell a corridor passes through gets a keyframe.
    keyframe_angle:
        ... or once its integrated heading changed by this much (rad) since the
        last keyframe (30 deg: corners of a corridor get a keyframe each 30 deg).
    keyframe_on_scene_change:
        Also take a keyframe when a new scene number begins (different from the
        previous tick's, not -1), provided at least ``keyframe_min_distance`` was
        travelled since the last keyframe.  A scene onset is where the robot
        crosses into a scene cell, so such keyframes sit near the same spot on
        every visit and make loop closures more precise than mid-cell keyframes
        (small_loop, 15 min, clean: ATE 0.088 m with, 0.098 m without).
    keyframe_min_distance:
        Minimum travel (m) for a scene-change keyframe (0.1 m, about 2 ticks at
        0.3 m/s, so that flicker at a cell border does not create a keyframe on
        every tick).

    Odometry noise
    --------------
    odom_sigma_v, odom_sigma_w:
        Standard deviation of the per-tick noise on the measured forward speed
        (m/s) and yaw rate (rad/s).  The simulator adds independent noise of
        0.01 m/s and 0.01 rad/s to every 7 Hz tick.  A tick of length dt then
        moves the robot by ``v dt`` with std ``odom_sigma_v * dt`` and turns it by
        ``w dt`` with std ``odom_sigma_w * dt``.  These per-tick covariances are
        propagated on SE(2) over all ticks between two keyframes (first-order,
        through the adjoint of the remaining motion), which gives the full 3x3
        covariance of each odometry between-factor; for a straight 0.5 m interval
        at 0.3 m/s (about 12 ticks) that is sigma_x ~ 5 mm, sigma_theta ~ 5 mrad
        and a lateral sigma_y ~ 1.5 mm that comes from the heading noise.
    odom_sigma_lateral:
        Per-tick noise on a sideways velocity (m/s) the robot cannot have (it is
        non-holonomic).  Only a small floor that keeps the covariance of very
        short intervals positive definite.
    prior_sigma_xy, prior_sigma_theta:
        Prior on the first keyframe (m, rad), taken on the first tick and held at
        its odometry pose from the origin (the robot's pose before that tick):
        this fixes the map frame.

    Loop closures
    -------------
    closure_sigma_xy, closure_sigma_theta:
        What a matching scene number tells: both keyframes lie in the same
        1 m x 1 m scene cell and face into the same 90 deg heading sector.  The
        closure measures the identity relative pose; if both poses are uniform
        over the cell and sector, each component of their difference has
        variance w^2/6 for cell/sector width w, so sigma_xy = 1 m / sqrt(6)
        = 0.408 m and sigma_theta = (pi/2) / sqrt(6) = 0.641 rad.
    closure_min_travel:
        Earlier keyframes less than this odometric path length (m) before the
        new one are the same visit, already tied by odometry: never closure
        candidates (4 m, more than the 2-3 m a scene label can persist through
        flicker and slow turns).
    closure_max_candidates:
        How many earlier sightings of the same scene number a new keyframe is
        linked to.  Candidates are all earlier keyframes with that scene number
        (beyond ``closure_min_travel``), ranked by distance to the new keyframe
        in the current estimate (nearest first, ties to the earlier keyframe):
        with aliased scene numbers the sighting that agrees with the map so far
        is the most plausible one; the robust back-end judges the rest.
    closure_candidate_window:
        Only the most recent this-many sightings of a scene number are ranked
        (12).  This bounds how far back in time a closure reaches, and so how
        much of iSAM2's Bayes tree a closure re-eliminates: with 64 every lap of
        a loop driven for hours is tied to any of the 64 laps before it, the
        graph becomes a mesh of all of them, and on small_loop an update took
        48 ms at 4,000 keyframes (411 ms at 10,000); with 12, 3.9 ms median and
        21 ms p99 at 10,000 (with ``closure_batch_keyframes`` 4).
    closure_batch_keyframes, closure_flush_distance:
        Closures are handed to iSAM2 together, at most every this-many
        keyframes (None: 8, or 4 with the yaw-bias variable; see
        ``closure_batch``), instead of one update per closure: on a revisit nearly
        every keyframe proposes one (91% of keyframes on the office floor), and
        one update with four closures costs little more than one with one
        (they re-eliminate mostly the same part of the tree).  A closure that
        contradicts the current estimate (Mahalanobis distance of its residual
        above ``closure_flush_distance``, 1.0) is added at once with those
        waiting, so a map that is wrong is corrected without delay (inf: never
        early).  Batching alone (8 keyframes, no early flush) cost 20% of
        keyframe ATE on the small loop with the yaw-bias variable, whose bias
        estimate lives on closures.
        Measured against the previous default (window 64, every closure at
        once), keyframe / online ATE in m: fig7 0.090 / 0.096 -> 0.092 / 0.103;
        fig8 bias variable 0.093 / 0.582 -> 0.101 / 0.575; fig9 bias variable
        0.093 / 0.861 -> 0.098 / 0.861; fig11 0.074 / 0.264 -> 0.076 / 0.266;
        fig13 0.095 / 0.116 -> 0.095 / 0.117; the 2.5-hour fig4 office stream
        in 72 s instead of 123 s.  Batches of 8 (with the early flush and the
        odometry batches of ``odometry_batch_keyframes``): the 9,000 s office
        stream's pose graph in 37 s CPU instead of 48 s, keyframe / online ATE
        0.0646 / 0.1282 -> 0.0662 / 0.1316 m; fig7 0.0915 / 0.1025 -> 0.093 /
        0.105, fig11 0.077 / 0.267 -> 0.077 / 0.264, fig13 0.095 / 0.117 ->
        0.095 / 0.120 (all within 4%).  The yaw-bias variable keeps 4: its
        bias estimate lives on closures, and it lost 20% with batches of 8.
    closure_recent_tolerance:
        If positive, sightings no more than this much (m) farther than the
        nearest one count as equally near, and the most recent of them is
        linked.  This keeps closures local in time, which makes iSAM2 updates on
        long runs cheaper (small_loop, 2,000 keyframes: 2.1 ms instead of 7 ms
        median), but chains each lap to the previous one, and the along-track
        offset between the linked keyframes then accumulates: at 0.25 m the ATE
        moved from 0.088/0.105 to 0.078/0.135 m (seeds 0/1), at 0.5 m to
        0.41/0.48 m.  Default 0: plain nearest.  When positive it takes
        precedence over ``closure_early_tolerance``.
    closure_early_tolerance:
        If positive, sightings no more than this much (m) farther than the
        nearest one count as equally near, and the earliest of them is linked;
        the ranked window then holds the earliest half and the most recent half
        of ``closure_candidate_window`` sightings.  Every lap is then tied to
        the same early sightings (the map's anchor) instead of to whichever lap
        happens to be nearest, so the graph stays a star around the first laps
        instead of a mesh of all laps: the Bayes tree's root clique stays about
        one lap in size and iSAM2 updates stay bounded on long runs.  The
        price: the linked sighting can be up to the tolerance farther than the
        nearest, so keyframe ATE improves but the online pose (the estimate at
        every tick) gets rougher.  Measured at 0.2 m against 0 (15-min streams,
        world defaults, seeds 0/1/2, robust): keyframe ATE small_loop
        0.056/0.064/0.059 m instead of 0.090/0.109/0.105, open_plan
        0.086/0.069/0.061 instead of 0.095/0.061/0.063; online ATE small_loop
        0.084/0.104/0.091 instead of 0.096/0.124/0.117, open_plan
        0.127/0.109/0.148 instead of 0.116/0.097/0.130; online RPE
        (translation) small_loop 0.051/0.055/0.057 m instead of
        0.045/0.050/0.048, open_plan 0.071/0.084/0.076 instead of
        0.066/0.081/0.072; office floor (5 min, keyframe ATE) within 0.003 m;
        robust recall on small_loop with 10% false positives down by up to
        0.013.  At 0.1 m the losses are smaller (online ATE open_plan
        0.119/0.099/0.134) and so is the speed-up.  Timing at 0.2 m
        (bench/bench_gtsam.py, small_loop, median over the 200 keyframes
        ending at 1,000 / 10,000): iSAM2 update 0.75 / 3.9 ms instead of
        1.24 / 411 ms; with the back-substitution gtsam defers to the next
        estimate read, 1.34 / 18.2 ms instead of 1.88 / 441 ms.  Default 0
        (off: the nearest sighting), because of the online losses.

    Back-end
    --------
    backend:
        "gaussian": every closure is trusted (least squares, the naive baseline).
        "robust": closures get an M-estimator kernel (``estimator``).
        "gnc": graduated non-convexity (gtsam's GncLMOptimizer) decides which
        closures are inliers.  Online, GNC is re-run on the whole graph every
        ``gnc_interval`` keyframes (when closures are waiting); iSAM2 then holds
        the accepted closures with their Gaussian noise and drops the rejected
        ones; a closure not yet judged is held meanwhile with the robust kernel
        of ``estimator``.
    estimator:
        Kernel of the robust back-end: "cauchy", "huber", "dcs" (dynamic
        covariance scaling) or "geman_mcclure" (default: a redescending kernel;
        on 10%-false-positive office-floor streams it kept the map within
        0.17 m where Cauchy drifted to 0.40 m and Huber to 1.6 m).
    estimator_k:
        Kernel width in Mahalanobis units; None = ``DEFAULT_ESTIMATOR_K``.
    accept_weight:
        A closure counts as accepted (inlier) if its weight at the solution is at
        least this (robust: kernel weight w(d) at the closure's Mahalanobis
        residual d; gnc: GNC weight, which ends near 0 or 1).
    gnc_loss:
        GNC surrogate: "tls" (truncated least squares) or "gm" (Geman-McClure).
    gnc_inlier_probability:
        Chi-square probability that sets GNC's inlier threshold per closure.
    gnc_interval:
        Online GNC: re-run the inlier selection every this many keyframes when
        closures are waiting (and at ``finalize``).  Each run is a batch GNC over
        the whole graph (~0.2-0.5 s at 1,000 keyframes); 50 keyframes (~25 m of
        travel) keeps a 15-minute run within a few seconds.

    Optimisation
    ------------
    online:
        Optimise incrementally with iSAM2 after every keyframe (default, like
        RatSLAM).  If False, keyframes are placed by chaining odometry and nothing
        is optimised until ``finalize`` (which then needs ``final_batch``).
    final_batch:
        ``finalize()`` runs a batch Levenberg-Marquardt (or, for "gnc", a GNC)
        optimisation of the whole graph, starting from the current estimate.
    isam2_relinearize_threshold, isam2_relinearize_skip:
        iSAM2's relinearisation threshold (on the tangent-space delta) and the
        number of updates between relinearisation checks.  Threshold 0.1 is
        gtsam's default; skip None means gtsam's default 10, or 1 when a yaw
        bias is estimated.  Measured on small_loop: 0.1/10 gives the same
        accuracy as 0.01/1 at about half the update time (1,000 keyframes),
        but with the bias variable a stale linearisation at the first loop
        closure sends b into the wrong 360-deg-per-lap basin (3 deg/s case:
        b -> -2.7 deg/s, ATE 3 m) while 0.1/1 recovers b = 2.995 deg/s.
    odometry_batch_keyframes:
        A keyframe that brings only its odometry factor (no closure to hand
        over) waits, and joins the next iSAM2 update (the next closure batch, or
        once this many keyframes have gathered: 8, about 4 m).  iSAM2 would
        place such a keyframe exactly at its odometry guess (its one new factor
        is satisfied there), so the estimate is unchanged up to linearisation
        noise; what is saved is one update and one back-substitution per
        keyframe, each of which re-eliminates the Bayes tree's root clique, and
        that clique grows with time on long revisiting runs (158 variables after
        2.5 hours on the office floor).  Estimate reads of a waiting keyframe
        give its guess.  Never applied with ``estimate_yaw_bias`` (every
        odometry update refines the bias the next keyframes integrate with).
        Measured against 1 (an update on every keyframe, the previous
        behaviour), pose graph alone on the office floor stream, CPU s in one
        session: 3,000 s 4.1 -> 2.4, 9,000 s 81.5 -> 48.1 (6,000 s: 26.1 ->
        14.7); keyframe / online ATE at 9,000 s 0.0644 / 0.1276 ->
        0.0646 / 0.1282 m.  Figures (keyframe / online ATE, m): fig7
        0.092 / 0.103 -> 0.0915 / 0.1025; fig8 and fig9 bias variable
        unchanged (0.101 / 0.575, 0.098 / 0.861); fig11 0.076 / 0.266 ->
        0.077 / 0.267; fig13 0.095 / 0.117 -> 0.095 / 0.117; fig4
        0.064 / 0.128 -> 0.064 / 0.126 (default), 0.065 / 0.128 (lookalike
        rooms).  fig4 end to end in one (contended) session: 236 s -> 157 s;
        pose graph per variant 164 / 154 s -> 91 / 104 s (two variants in
        parallel), 46 / 55 s run one after the other.  bench/bench_gtsam.py
        --quick, small_loop at 2,000 keyframes: update + back-substitution per
        keyframe median 2.4 ms -> 0 (most keyframes make no update), mean
        3.3 ms, p99 13.3 -> 17.3 ms (an update now carries up to 4 keyframes;
        per update call 10 ms median).  It does not bound
        the growth: the graph itself (each visit tied to the nearest of the 12
        latest sightings) has a root clique that grows with time; a batch
        COLAMD or METIS ordering of the final 9,000 s graph still has cliques
        of 277 / 178 variables; closure batches of 8 on top (instead of 4)
        take the 9,000 s stream from 48 to 37 s CPU at keyframe / online ATE
        0.0662 / 0.1316 m (fig7 0.093 / 0.105, fig11 0.077 / 0.264, fig13
        0.095 / 0.120, fig4 0.066 / 0.133), but cost the yaw-bias variant 20%
        (see ``closure_batch_keyframes``), so they are the default only
        without the yaw-bias variable; and
        rebuilding iSAM2 with a fresh COLAMD
        ordering every 500 keyframes (0.16 s per rebuild)
        saved nothing (78 s CPU against 73-82 s without).
    isam2_extra_updates:
        Extra iSAM2 iterations run right after a keyframe that added loop
        closures (each is one Gauss-Newton step on the affected part).
    batch_max_iterations:
        Iteration cap of the batch LM / GNC inner optimiser.

    Yaw-rate bias
    -------------
    estimate_yaw_bias:
        Add one constant yaw-rate bias variable b (rad/s) to the graph, as GTSAM
        users do with IMU biases: each odometry factor re-integrates its ticks
        with (w - b) and is linked to b (a Python ``gtsam.CustomFactor``).  Off by
        default.  Not available with the "gnc" back-end: gtsam's GncOptimizer
        clones every factor, which a Python CustomFactor cannot do.
        Measured on small_loop (15 min): at 1.5 and 3 deg/s it recovers b to
        0.02 deg/s and ATE ~0.1 m (without it: ~3 m); at 6 deg/s it settles in
        a wrong basin (b ~ 0.27 deg/s, ~3 m).  It is fragile to false closures:
        b is constrained only by loop closures, so a false one can be explained
        by a wrong bias at little cost; at the world's default 0.002
        false-positive rate it works, at 0.02 and 0.1 per tick it fails (~3 m)
        even with no real bias.
    yaw_bias_prior_sigma:
        Zero-mean prior on b (rad/s); 0.2 rad/s ~ 11 deg/s.
    isam2_bias_relinearize_threshold:
        iSAM2 relinearisation threshold of b (rad/s).  Must be far below the
        pose threshold: with b held at its first linearisation point the
        3 deg/s case stays at ~3 m ATE.
    """

    keyframe_distance: float = 0.5
    keyframe_angle: float = math.radians(30.0)
    keyframe_on_scene_change: bool = True
    keyframe_min_distance: float = 0.1

    odom_sigma_v: float = 0.01
    odom_sigma_w: float = 0.01
    odom_sigma_lateral: float = 0.001
    prior_sigma_xy: float = 1e-3
    prior_sigma_theta: float = 1e-3

    closure_sigma_xy: float = 1.0 / math.sqrt(6.0)
    closure_sigma_theta: float = (math.pi / 2.0) / math.sqrt(6.0)
    closure_min_travel: float = 4.0
    closure_max_candidates: int = 1
    closure_candidate_window: int = 12
    closure_recent_tolerance: float = 0.0
    closure_early_tolerance: float = 0.0
    closure_batch_keyframes: int | None = None
    closure_flush_distance: float = 1.0
    odometry_batch_keyframes: int = 8

    backend: str = "robust"
    estimator: str = "geman_mcclure"
    estimator_k: float | None = None
    accept_weight: float = 0.5
    gnc_loss: str = "tls"
    gnc_inlier_probability: float = 0.99
    gnc_interval: int = 50

    online: bool = True
    final_batch: bool = False
    isam2_relinearize_threshold: float = 0.1
    isam2_relinearize_skip: int | None = None
    isam2_extra_updates: int = 0
    batch_max_iterations: int = 100

    estimate_yaw_bias: bool = False
    yaw_bias_prior_sigma: float = 0.2
    isam2_bias_relinearize_threshold: float = 1e-4

    def __post_init__(self) -> None:
        if self.backend not in BACKENDS:
            raise ValueError(f"backend: unknown back-end {self.backend!r}, expected one of {BACKENDS}")
        if self.estimator not in ESTIMATORS:
            raise ValueError(f"estimator: unknown estimator {self.estimator!r}, expected one of {ESTIMATORS}")
        if self.estimate_yaw_bias is True and self.backend == "gnc":
            raise ValueError(
                "estimate_yaw_bias: not available with backend 'gnc' (gtsam's GNC clones every factor "
                "and the Python CustomFactor carrying the bias cannot be cloned)"
            )
        if self.gnc_loss not in GNC_LOSSES:
            raise ValueError(f"gnc_loss: unknown GNC loss {self.gnc_loss!r}, expected one of {GNC_LOSSES}")
        positive = (
            "keyframe_distance",
            "keyframe_angle",
            "odom_sigma_v",
            "odom_sigma_w",
            "odom_sigma_lateral",
            "prior_sigma_xy",
            "prior_sigma_theta",
            "closure_sigma_xy",
            "closure_sigma_theta",
            "yaw_bias_prior_sigma",
        )
        for name in positive:
            value = getattr(self, name)
            if not _is_real(value) or not math.isfinite(value) or value <= 0.0:
                raise ValueError(f"{name}: must be a positive finite number, got {value!r}")
        for name in (
            "keyframe_min_distance",
            "closure_min_travel",
            "closure_recent_tolerance",
            "closure_early_tolerance",
            "isam2_relinearize_threshold",
            "isam2_bias_relinearize_threshold",
        ):
            value = getattr(self, name)
            if not _is_real(value) or not math.isfinite(value) or value < 0.0:
                raise ValueError(f"{name}: must be a non-negative finite number, got {value!r}")
        if not _is_real(self.closure_flush_distance) or not self.closure_flush_distance > 0.0:
            raise ValueError(
                f"closure_flush_distance: must be a positive number (inf: never), got {self.closure_flush_distance!r}"
            )
        if self.estimator_k is not None and (
            not _is_real(self.estimator_k) or not math.isfinite(self.estimator_k) or self.estimator_k <= 0.0
        ):
            raise ValueError(f"estimator_k: must be None or a positive finite number, got {self.estimator_k!r}")
        if not _is_real(self.accept_weight) or not 0.0 < self.accept_weight <= 1.0:
            raise ValueError(f"accept_weight: must lie in (0, 1], got {self.accept_weight!r}")
        if not _is_real(self.gnc_inlier_probability) or not 0.0 < self.gnc_inlier_probability < 1.0:
            raise ValueError(f"gnc_inlier_probability: must lie in (0, 1), got {self.gnc_inlier_probability!r}")
        if self.isam2_relinearize_skip is not None and (
            not _is_int(self.isam2_relinearize_skip) or self.isam2_relinearize_skip < 1
        ):
            raise ValueError(
                f"isam2_relinearize_skip: must be None or an integer >= 1, got {self.isam2_relinearize_skip!r}"
            )
        if self.closure_batch_keyframes is not None and (
            not _is_int(self.closure_batch_keyframes) or self.closure_batch_keyframes < 1
        ):
            raise ValueError(
                f"closure_batch_keyframes: must be None or an integer >= 1, got {self.closure_batch_keyframes!r}"
            )
        for name in (
            "closure_max_candidates",
            "closure_candidate_window",
            "gnc_interval",
            "odometry_batch_keyframes",
            "batch_max_iterations",
        ):
            value = getattr(self, name)
            if not _is_int(value) or value < 1:
                raise ValueError(f"{name}: must be an integer >= 1, got {value!r}")
        if not _is_int(self.isam2_extra_updates) or self.isam2_extra_updates < 0:
            raise ValueError(f"isam2_extra_updates: must be an integer >= 0, got {self.isam2_extra_updates!r}")
        for name in ("keyframe_on_scene_change", "online", "final_batch", "estimate_yaw_bias"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name}: must be a bool, got {getattr(self, name)!r}")

    @property
    def closure_batch(self) -> int:
        """Closure batch size actually used (see ``closure_batch_keyframes``)."""
        if self.closure_batch_keyframes is not None:
            return int(self.closure_batch_keyframes)
        return 4 if self.estimate_yaw_bias else 8

    @property
    def relinearize_skip(self) -> int:
        """iSAM2 relinearisation interval actually used (see ``isam2_relinearize_skip``)."""
        if self.isam2_relinearize_skip is not None:
            return int(self.isam2_relinearize_skip)
        return 1 if self.estimate_yaw_bias else 10

    @property
    def kernel_width(self) -> float:
        """Robust kernel width actually used (``estimator_k`` or the estimator's default)."""
        return DEFAULT_ESTIMATOR_K[self.estimator] if self.estimator_k is None else float(self.estimator_k)


def _is_real(value: object) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def _is_int(value: object) -> bool:
    return isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_))
