"""GTSAM Pose2 pose-graph SLAM fed the same stream as RatSLAM.

Per tick: integrate the wheel odometry on SE(2); take a keyframe every
``keyframes.distance_m`` metres, ``keyframes.angle_rad`` radians or at a scene onset;
join consecutive keyframes by an odometry between-factor; when a keyframe's scene
number was seen at earlier keyframes, add a loop-closure factor to the nearest
such sighting (weighed down along a chain of closures between the same two passages when
``closures.chain_correlation`` is positive; closures are handed to iSAM2 a few keyframes at a time, at once if
one contradicts the estimate; keyframes with only odometry wait for the next
update, up to ``optimisation.odometry_batch_keyframes``); optimise online with iSAM2 (robust,
Gaussian or GNC-verified closures).  A constant yaw-rate bias is either a graph variable
(``yaw_bias.estimate``) or, by default, searched from revisited scene numbers
(:mod:`slamkit.yaw_bias`): when one is adopted the graph is rebuilt from the stored ticks
with the corrected odometry.  The SLAM never sees ground truth.
"""

from __future__ import annotations

import math
import numbers

import gtsam
import numpy as np
from gtsam.symbol_shorthand import B, X

from slamkit.arcs import check_tick
from slamkit.poses import fit_se2
from slamkit.yaw_bias import YawBiasSearch

from .closures import ClosureChains, SceneIndex
from .config import PoseGraphConfig
from .factors import (
    BiasedOdometry,
    biased_odometry_factor,
    closure_gaussian,
    closure_mahalanobis,
    closure_noise,
    odometry_noise,
    robust_kernel,
)
from .odometry import TickBuffer, integrate, relative_covariance
from .optimizers import batch_lm, make_isam2, run_gnc

BIAS_KEY = B(0)


def bias_search(cfg: PoseGraphConfig) -> YawBiasSearch:
    """The yaw-rate bias search a pose graph of configuration ``cfg`` runs: its ``yaw_bias``
    fields, revisits scored with its closures' own travel and sigmas."""
    lc = cfg.closures
    return cfg.yaw_bias.bias_search(lc.min_travel_m, lc.sigma_xy_m, lc.sigma_theta_rad)


class PoseGraphSLAM:
    """Keyframe pose graph over odometry and scene-number loop closures.

    Step contract: ``step(dt, v_trans, v_rot, scene_id)`` once per tick (seconds,
    m/s, rad/s, int; -1 = no scene); ``pose`` is the current (x, y, theta) in the
    map frame, whose origin is the robot's pose before the first tick (the first
    keyframe, taken on the first tick, is held by a prior at its odometry pose).
    """

    def __init__(self, config: PoseGraphConfig | None = None) -> None:
        self._config = config if config is not None else PoseGraphConfig()
        if not isinstance(self._config, PoseGraphConfig):
            raise ValueError(f"config: expected a PoseGraphConfig, got {type(self._config).__name__}")
        cfg = self._config
        self._kernel = robust_kernel(cfg)
        # Closure noise models by sigma multiplier (a closure's place in its chain): the factor's
        # own (robust-wrapped for "robust" only) and, for GNC, the robust stand-in a closure not
        # yet judged sits in iSAM2 with.
        self._closure_noises: dict[float, tuple] = {}
        yb = cfg.yaw_bias
        self._search: YawBiasSearch | None = None
        if yb.search and not yb.estimate:
            self._search = bias_search(cfg)
        self._ticks: list[tuple[float, float, float, int]] = []  # every tick, for a rebuild
        self._rebuilds = 0
        # The map frame read out: the graph's own frame, moved after a rebuild onto the frame
        # the map had before it (:meth:`_rebuild`).
        self._frame = gtsam.Pose2()
        self._reset(0.0)

    def _reset(self, bias: float) -> None:
        """An empty graph whose odometry is corrected by the yaw-rate bias ``bias`` (rad/s)."""
        cfg = self._config
        self._scenes = SceneIndex(
            cfg.closures.min_travel_m,
            cfg.closures.max_candidates,
            cfg.closures.candidate_window,
            cfg.closures.recent_tolerance_m,
            cfg.closures.early_tolerance_m,
        )
        self._isam = make_isam2(cfg) if cfg.optimisation.online else None
        self._graph = gtsam.NonlinearFactorGraph()  # every factor, for batch / GNC
        self._values = gtsam.Values()  # initial guesses (the estimate when offline)
        self._known_inliers: list[int] = []  # graph indices of non-closure factors
        self._batch: gtsam.Values | None = None
        self._buffer = TickBuffer()
        self._tick = 0
        self._time = 0.0
        self._path = 0.0
        self._prev_scene = -1
        self._bias = bias
        self._latest = gtsam.Pose2()
        # keyframes
        self._kf_ticks: list[int] = []
        self._kf_times: list[float] = []
        self._kf_path: list[float] = []
        self._kf_scene: list[int] = []
        # each tick's anchor in this graph (rewritten by a rebuild): keyframe, offset from it
        self._tick_kf: list[int] = []
        self._tick_offset: list[tuple[float, float, float]] = []
        # loop closures
        self._lc_i: list[int] = []
        self._lc_j: list[int] = []
        self._lc_tick: list[int] = []
        self._lc_graph_index: list[int] = []
        self._lc_isam_index: list[int] = []  # index of the closure's factor in iSAM2, -1 if absent
        self._lc_provisional: list[bool] = []  # GNC: iSAM2 holds the robust stand-in
        self._lc_gnc_weight: list[float] = []
        self._lc_scale: list[float] = []  # sigma multiplier from the closure's place in its chain
        self._chains = ClosureChains(cfg.closures.chain_correlation, cfg.closures.chain_gap_keyframes)
        self._recoveries = 0  # iSAM2 rebuilds after gtsam refused an update
        self._closures_dropped = 0  # closures left out because gtsam refused them even then
        self._keyframes_since_gnc = 0
        self._pending_closures: list[tuple[int, gtsam.NonlinearFactor]] = []  # proposed, not yet in iSAM2
        self._keyframes_since_flush = 0
        # Odometry-only keyframes not yet handed to iSAM2 (``odometry_batch_keyframes``):
        # their factors and guesses; keyframes from ``_isam_keyframes`` on are not in iSAM2.
        self._deferred_factors: list = []
        self._deferred_values = gtsam.Values()
        self._isam_keyframes = 0
        # iSAM2's estimate of keyframes read since its last update (it changes only with one)
        self._estimates: dict[int, tuple[float, float, float]] = {}

    # ------------------------------------------------------------------ step
    def step(self, dt: float, v_trans: float, v_rot: float, scene_id: int, view_rotation: float = 0.0) -> None:
        """Advance one tick: odometry (dt s, v_trans m/s, v_rot rad/s) and a scene number.
        ``view_rotation`` (a camera view's rotation relative to its template) is accepted for the
        common step contract and not used: a closure's relative pose comes from the odometry."""
        dt, v, w = float(dt), float(v_trans), float(v_rot)
        check_tick(dt, v, w)
        scene = _scene_number(scene_id)
        self._advance(dt, v, w, scene)
        if self._search is not None:
            self._ticks.append((dt, v, w, scene))
            bias = self._search.add(dt, v, w, scene)
            if bias is not None:
                self._rebuild(bias)

    def _rebuild(self, bias: float) -> None:
        """Adopt a searched yaw-rate bias.

        The graph is built anew from every tick so far with the corrected odometry (keyframes,
        closures and iSAM2 alike: the same code path as the first time).  Its frame is then laid
        onto the map's frame before the rebuild (the SE(2) least-squares fit of the new keyframe
        positions to the old estimate at the same ticks), so the map the user holds does not
        turn or shift as a whole at the correction; only its shape changes.
        """
        old_ticks, old_xy = self.keyframe_ticks, self.keyframe_poses[:, :2]
        self._rebuilds += 1
        self._reset(bias)
        for dt, v, w, scene in self._ticks:
            self._advance(dt, v, w, scene)
        new_ticks, new_xy = self.keyframe_ticks, self._graph_poses()[:, :2]
        at_ticks = np.stack([np.interp(new_ticks, old_ticks, old_xy[:, c]) for c in (0, 1)], axis=1)
        self._frame = _fit_se2(new_xy, at_ticks)

    def _advance(self, dt: float, v: float, w: float, scene: int) -> None:
        self._batch = None
        step_index = self._tick
        self._tick += 1
        self._time += dt
        self._path += abs(v * dt)
        self._buffer.add(dt, v, w, self._bias)
        if not self._kf_ticks:
            self._first_keyframe(step_index, scene)
        else:
            buf, cfg = self._buffer, self._config
            onset = (
                cfg.keyframes.on_scene_change
                and scene != -1
                and scene != self._prev_scene
                and buf.distance >= cfg.keyframes.min_distance_m
            )
            if buf.distance >= cfg.keyframes.distance_m or abs(buf.theta) >= cfg.keyframes.angle_rad or onset:
                self._add_keyframe(step_index, scene)
        self._prev_scene = scene
        buf = self._buffer
        self._tick_kf.append(len(self._kf_ticks) - 1)
        self._tick_offset.append((buf.x, buf.y, buf.theta))

    def _record_keyframe(self, step_index: int, scene: int) -> int:
        j = len(self._kf_ticks)
        self._kf_ticks.append(step_index)
        self._kf_times.append(self._time)
        self._kf_path.append(self._path)
        self._kf_scene.append(scene)
        return j

    def _first_keyframe(self, step_index: int, scene: int) -> None:
        cfg = self._config
        buf = self._buffer
        pose0 = gtsam.Pose2(buf.x, buf.y, buf.theta)
        j = self._record_keyframe(step_index, scene)
        factors = gtsam.NonlinearFactorGraph()
        values = gtsam.Values()
        sig = np.array(
            [cfg.odometry.prior_sigma_xy_m, cfg.odometry.prior_sigma_xy_m, cfg.odometry.prior_sigma_theta_rad]
        )
        factors.add(gtsam.PriorFactorPose2(X(j), pose0, gtsam.noiseModel.Diagonal.Sigmas(sig)))
        values.insert(X(j), pose0)
        if cfg.yaw_bias.estimate:
            noise = gtsam.noiseModel.Isotropic.Sigma(1, cfg.yaw_bias.prior_sigma_rad_s)
            factors.add(gtsam.PriorFactorVector(BIAS_KEY, np.zeros(1), noise))
            values.insert(BIAS_KEY, np.zeros(1))
        for n in range(factors.size()):
            self._known_inliers.append(self._graph.size())
            self._graph.add(factors.at(n))
        self._values.insert(values)
        if self._isam is not None:
            self._update_isam([(factors.at(n), None) for n in range(factors.size())], values)
            self._isam_keyframes = 1
        self._latest = pose0
        self._scenes.add(scene, j)
        self._buffer = TickBuffer()

    def _add_keyframe(self, step_index: int, scene: int) -> None:
        cfg = self._config
        dt, v, w = self._buffer.arrays()
        cov = relative_covariance(
            dt, v, w, cfg.odometry.sigma_v_m_s, cfg.odometry.sigma_w_rad_s, cfg.odometry.sigma_lateral_m_s, self._bias
        )
        prev = len(self._kf_ticks) - 1
        j = self._record_keyframe(step_index, scene)
        if cfg.yaw_bias.estimate:
            odo = BiasedOdometry(dt, v, w)
            z = odo.measured(self._bias)
            odo_factor: gtsam.NonlinearFactor = biased_odometry_factor(
                X(prev), X(j), BIAS_KEY, odo, odometry_noise(cov)
            )
        else:
            z = gtsam.Pose2(*integrate(dt, v, w, self._bias))
            odo_factor = gtsam.BetweenFactorPose2(X(prev), X(j), z, odometry_noise(cov))
        guess = self._latest.compose(z)
        new_values = gtsam.Values()
        new_values.insert(X(j), guess)
        self._known_inliers.append(self._graph.size())
        self._graph.add(odo_factor)
        self._values.insert(X(j), guess)

        closures = self._scenes.candidates(scene, self._kf_path, self._path, (guess.x(), guess.y()), self._estimate_xy)
        self._scenes.add(scene, j)
        for i in closures:
            scale = self._chains.scale(i, j)
            factor = gtsam.BetweenFactorPose2(X(i), X(j), gtsam.Pose2(), self._noise(scale)[0])
            self._lc_scale.append(scale)
            self._lc_i.append(i)
            self._lc_j.append(j)
            self._lc_tick.append(step_index)
            self._lc_graph_index.append(self._graph.size())
            self._lc_isam_index.append(-1)
            self._lc_provisional.append(False)
            self._lc_gnc_weight.append(math.nan)
            self._graph.add(factor)
            self._pending_closures.append((len(self._lc_i) - 1, factor))
        self._buffer = TickBuffer()

        if self._isam is None:
            self._latest = guess
            return
        self._keyframes_since_flush += 1
        flush = bool(self._pending_closures) and (
            self._keyframes_since_flush >= cfg.closure_batch or self._disagrees(closures, guess)
        )
        if (
            not flush
            and not cfg.yaw_bias.estimate
            and len(self._deferred_factors) + 1 < cfg.optimisation.odometry_batch_keyframes
        ):
            # Odometry only: iSAM2 would place the keyframe at exactly this guess (its only
            # new factor is satisfied there), so it waits and joins the next update.
            self._deferred_factors.append(odo_factor)
            self._deferred_values.insert(X(j), guess)
            self._latest = guess
            if cfg.backend.kind == "gnc":
                self._keyframes_since_gnc += 1
            return
        closure_factors = self._take_pending() if flush else []
        tagged = [(f, None) for f in self._deferred_factors] + [(odo_factor, None)] + closure_factors
        new_values.insert(self._deferred_values)
        self._deferred_factors = []
        self._deferred_values = gtsam.Values()
        self._isam_keyframes = j + 1
        # Constrain only the new keyframe (and the bias, which every odometry factor
        # touches) to the end of the elimination order.  iSAM2's default constrains every
        # key of the new factors, so the old end of each closure is dragged to the root
        # too; left free, COLAMD places it with less fill.
        last = gtsam.KeyGroupMap()
        last.insert2(X(j), 1)
        if cfg.yaw_bias.estimate:
            last.insert2(BIAS_KEY, 1)
        self._update_isam(tagged, new_values, last=last)
        if closure_factors:
            self._extra_updates()
        if cfg.backend.kind == "gnc":
            self._keyframes_since_gnc += 1
            if self._keyframes_since_gnc >= cfg.backend.gnc_interval_keyframes and self._has_pending():
                self._gnc_verify()
        self._refresh_latest()

    def _flush_closures(self) -> None:
        """Hand the keyframes and closures still waiting for their batch to iSAM2 (end of run)."""
        if self._isam is None or not (self._pending_closures or self._deferred_factors):
            return
        tagged = [(f, None) for f in self._deferred_factors]
        values = self._deferred_values
        self._deferred_factors = []
        self._deferred_values = gtsam.Values()
        self._isam_keyframes = len(self._kf_ticks)
        self._update_isam(tagged + (self._take_pending() if self._pending_closures else []), values)
        self._refresh_latest()

    def _take_pending(self) -> list:
        """The waiting closures as (factor, closure index) for iSAM2; the batch starts anew.
        GNC: a closure not judged yet goes in as the robust stand-in; one GNC already judged (while
        it waited) goes in as an inlier or not at all."""
        tagged = []
        for c, _ in self._pending_closures:
            judged = not math.isnan(self._lc_gnc_weight[c])
            if (
                self._config.backend.kind == "gnc"
                and judged
                and self._lc_gnc_weight[c] < self._config.backend.accept_weight
            ):
                continue
            self._lc_provisional[c] = self._config.backend.kind == "gnc" and not judged
            tagged.append((self._isam_closure_factor(c), c))
        self._pending_closures = []
        self._keyframes_since_flush = 0
        return tagged

    def _isam_closure_factor(self, c: int):
        """The factor iSAM2 holds for closure ``c``: GNC's robust stand-in while the closure is
        provisional, else the closure as in the graph."""
        if self._lc_provisional[c]:
            pending = self._noise(self._lc_scale[c])[1]
            return gtsam.BetweenFactorPose2(X(self._lc_i[c]), X(self._lc_j[c]), gtsam.Pose2(), pending)
        return self._graph.at(self._lc_graph_index[c])

    def _noise(self, scale: float) -> tuple:
        """(closure factor noise, GNC's robust stand-in) for closures of sigma multiplier ``scale``."""
        noises = self._closure_noises.get(scale)
        if noises is None:
            cfg = self._config
            stand_in = gtsam.noiseModel.Robust.Create(self._kernel, closure_gaussian(cfg, scale))
            noises = self._closure_noises[scale] = (closure_noise(cfg, scale), stand_in)
        return noises

    # ------------------------------------------------------------------ iSAM2 updates
    @property
    def _online_isam(self) -> gtsam.ISAM2:
        """The iSAM2 instance (kept only when optimising online)."""
        assert self._isam is not None, "iSAM2 is kept only with optimisation.online"
        return self._isam

    def _update_isam(self, tagged: list, values: gtsam.Values, remove=(), last=None) -> None:
        """One iSAM2 update with ``tagged`` new factors ``(factor, closure index or None)``.

        If gtsam refuses it as an indeterminate (numerically ill-posed) system, iSAM2 is rebuilt
        from everything it held (at its linearisation point) with QR factorisation, which does
        not square the condition number as Cholesky does, and the update is applied to that;
        if even that is refused, this update's closures are left out. Both are counted
        (``isam2_recoveries``, ``closures_dropped``).
        """
        graph = gtsam.NonlinearFactorGraph()
        for factor, _ in tagged:
            graph.add(factor)
        try:
            if last is None:
                result = self._online_isam.update(graph, values, list(remove))
            else:
                result = self._online_isam.update(graph, values, list(remove), last)
            indices = list(result.getNewFactorsIndices())
        except RuntimeError as e:
            if "Indeterminate" not in str(e):
                raise
            indices = self._recover(tagged, values)
        self._estimates.clear()
        for (_, c), idx in zip(tagged, indices):
            if c is not None:
                self._lc_isam_index[c] = idx

    def _extra_updates(self) -> None:
        """iSAM2's further relinearisation steps after closures (``isam2_extra_updates``)."""
        for _ in range(self._config.optimisation.isam2_extra_updates):
            self._online_isam.update()
        self._estimates.clear()

    def _recover(self, tagged: list, values: gtsam.Values) -> list[int]:
        """Rebuild iSAM2 (QR) with what it held plus ``tagged``; returns the indices of ``tagged``."""
        self._recoveries += 1
        theta = self._online_isam.getLinearizationPoint()  # the estimate so far
        n_new_inliers = sum(1 for _, c in tagged if c is None)
        held: list[tuple[gtsam.NonlinearFactor, int | None]]
        held = [(self._graph.at(g), None) for g in self._known_inliers[: len(self._known_inliers) - n_new_inliers]]
        held += [(self._isam_closure_factor(c), c) for c in range(len(self._lc_i)) if self._lc_isam_index[c] >= 0]
        for attempt in range(2):
            if attempt == 1:  # still refused: without this update's closures
                dropped = [c for _, c in tagged if c is not None]
                self._closures_dropped += len(dropped)
                for c in dropped:
                    self._lc_isam_index[c] = -1
                    self._lc_provisional[c] = False
                tagged = [(f, c) for f, c in tagged if c is None]
            everything = held + tagged
            graph = gtsam.NonlinearFactorGraph()
            for factor, _ in everything:
                graph.add(factor)
            initial = gtsam.Values()
            for key in graph.keyVector():
                if initial.exists(key):
                    continue
                source = theta if theta.exists(key) else values
                if source.exists(key):
                    initial.insert(
                        key, source.atPose2(key) if gtsam.Symbol(key).chr() == ord("x") else source.atVector(key)
                    )
            isam = make_isam2(self._config, factorization="QR")
            try:
                result = isam.update(graph, initial)
            except RuntimeError as e:
                if "Indeterminate" not in str(e) or attempt == 1:
                    raise
                continue
            self._isam = isam
            indices = list(result.getNewFactorsIndices())
            for (_factor, c), idx in zip(held, indices):
                if c is not None:
                    self._lc_isam_index[c] = idx
            return indices[len(held) :]  # for ``tagged`` as it now stands
        raise AssertionError("unreachable")

    def _disagrees(self, closures: list[int], guess: gtsam.Pose2) -> bool:
        """Whether a new closure contradicts the current estimate (Mahalanobis distance of its
        residual above ``closures.flush_distance``): such a closure is added at once, not batched."""
        limit = self._config.closures.flush_distance
        if not closures or not math.isfinite(limit):
            return False
        poses_i = np.array([self._estimate_pose2(i) for i in closures])
        poses_j = np.repeat([[guess.x(), guess.y(), guess.theta()]], len(closures), axis=0)
        scale = self._lc_scale[len(self._lc_scale) - len(closures) :]  # the new keyframe's closures
        return bool(np.any(closure_mahalanobis(self._config, poses_i, poses_j, scale) > limit))

    def _estimate_pose2(self, i: int) -> tuple[float, float, float]:
        """Current estimate of keyframe ``i`` (its odometry guess when offline)."""
        if self._isam is None or i >= self._isam_keyframes:
            # offline, or a keyframe waiting for iSAM2 (its guess is what iSAM2 would give)
            p = self._values.atPose2(X(i))
            return p.x(), p.y(), p.theta()
        known = self._estimates.get(i)
        if known is None:
            p = self._online_isam.calculateEstimatePose2(X(i))
            known = self._estimates[i] = (p.x(), p.y(), p.theta())
        return known

    def _refresh_latest(self) -> None:
        j = len(self._kf_ticks) - 1
        self._latest = self._online_isam.calculateEstimatePose2(X(j))
        if self._config.yaw_bias.estimate:
            self._bias = float(self._online_isam.calculateEstimateVector(BIAS_KEY)[0])

    def _estimate_xy(self, i: int) -> tuple[float, float]:
        return self._estimate_pose2(i)[:2]

    # ------------------------------------------------------------------ GNC
    def _has_pending(self) -> bool:
        return any(math.isnan(wt) for wt in self._lc_gnc_weight)

    def _current_values(self) -> gtsam.Values:
        if self._batch is not None:
            return self._batch
        if self._isam is not None:
            values = self._online_isam.calculateEstimate()
            if self._deferred_factors:
                values.insert(self._deferred_values)
            return values
        return self._values

    def _run_gnc(self, initial: gtsam.Values) -> gtsam.Values:
        """GNC inlier selection; stores the closure weights, returns GNC's pose estimate."""
        result, weights = run_gnc(self._graph, initial, self._known_inliers, self._config)
        for c, g in enumerate(self._lc_graph_index):
            self._lc_gnc_weight[c] = float(weights[g])
        return result

    def _gnc_verify(self) -> None:
        """Run GNC on the whole graph; iSAM2 keeps exactly the closures it accepts. Closures still
        waiting for their batch are left to it: the flush hands them over as GNC judged them."""
        self._keyframes_since_gnc = 0
        self._run_gnc(self._current_values())
        waiting = {c for c, _ in self._pending_closures}
        added: list[int] = []
        remove: list[int] = []
        for c in range(len(self._lc_i)):
            inlier = self._lc_gnc_weight[c] >= self._config.backend.accept_weight
            present = self._lc_isam_index[c] >= 0
            if present and (not inlier or self._lc_provisional[c]):
                remove.append(self._lc_isam_index[c])
                self._lc_isam_index[c] = -1
                self._lc_provisional[c] = False
            if inlier and self._lc_isam_index[c] < 0 and c not in waiting:
                added.append(c)
        if added or remove:
            self._update_isam([(self._isam_closure_factor(c), c) for c in added], gtsam.Values(), remove)
            self._extra_updates()

    # ------------------------------------------------------------------ finalize
    def finalize(self) -> None:
        """End-of-run optimisation.

        With ``optimisation.final_batch`` the whole graph is optimised by batch
        Levenberg-Marquardt ("gaussian", "robust") or GNC ("gnc") from the
        current estimate, and the read-access properties report that result
        until the next ``step``.  Without it, the online "gnc" back-end still
        verifies its pending closures; other back-ends do nothing.
        """
        cfg = self._config
        if not self._kf_ticks:
            return
        self._flush_closures()
        if cfg.optimisation.final_batch:
            initial = self._current_values()
            if cfg.backend.kind == "gnc":
                values = self._run_gnc(initial)
            else:
                values = batch_lm(self._graph, initial, cfg)
            self._batch = values
            j = len(self._kf_ticks) - 1
            self._latest = values.atPose2(X(j))
            if cfg.yaw_bias.estimate:
                self._bias = float(values.atVector(BIAS_KEY)[0])
        elif cfg.backend.kind == "gnc" and self._isam is not None and self._has_pending():
            self._gnc_verify()
            self._refresh_latest()

    # ------------------------------------------------------------------ read access
    @property
    def config(self) -> PoseGraphConfig:
        """The configuration (a frozen dataclass)."""
        return self._config

    @property
    def tick(self) -> int:
        """Number of steps taken so far (the first step makes it 1)."""
        return self._tick

    @property
    def pose(self) -> tuple[float, float, float]:
        """Current (x, y, theta): latest keyframe estimate composed with odometry since."""
        if not self._kf_ticks:
            return (0.0, 0.0, 0.0)
        buf = self._buffer
        p = self._frame.compose(self._latest).compose(gtsam.Pose2(buf.x, buf.y, buf.theta))
        return (p.x(), p.y(), p.theta())

    @property
    def anchor(self) -> tuple[int, tuple[float, float, float]]:
        """``(keyframe, offset)``: the latest keyframe (-1 before the first) and the odometry
        integrated since it, in its frame: :attr:`pose` is that keyframe's estimate composed with
        ``offset``, now or, with the final keyframe poses, as the final graph places this tick."""
        if not self._tick_kf:
            return -1, (0.0, 0.0, 0.0)
        x, y, theta = self._tick_offset[-1]
        return self._tick_kf[-1], (float(x), float(y), float(theta))

    @property
    def final_anchors(self) -> tuple[np.ndarray, np.ndarray]:
        """Every tick's :attr:`anchor` in the graph as it is now: (N,) keyframes and (N, 3) offsets.
        The same as the anchors read after each tick unless a searched yaw-rate bias rebuilt the
        graph: a rebuild takes its keyframes anew from the corrected odometry (their indices move)
        and integrates each offset with the bias, so the ticks before it are placed on the graph
        that holds them now."""
        return np.asarray(self._tick_kf, dtype=np.int64), np.asarray(self._tick_offset, dtype=float).reshape(-1, 3)

    @property
    def yaw_bias(self) -> float:
        """Current yaw-rate bias estimate (rad/s): the graph variable's (``yaw_bias.estimate``), the
        searched one (``yaw_bias.search``, 0 until one is adopted), else 0."""
        return self._bias

    @property
    def yaw_bias_rebuilds(self) -> int:
        """How often a searched yaw-rate bias was adopted (each rebuilds the graph)."""
        return self._rebuilds

    @property
    def keyframe_poses(self) -> np.ndarray:
        """(K, 3) current optimised (x, y, theta) of every keyframe."""
        poses = self._graph_poses()
        f = self._frame
        if len(poses) == 0 or f.equals(gtsam.Pose2(), 0.0):
            return poses
        c, s = math.cos(f.theta()), math.sin(f.theta())
        out = np.empty_like(poses)
        out[:, 0] = f.x() + c * poses[:, 0] - s * poses[:, 1]
        out[:, 1] = f.y() + s * poses[:, 0] + c * poses[:, 1]
        out[:, 2] = poses[:, 2] + f.theta()
        return out

    def _graph_poses(self) -> np.ndarray:
        """(K, 3) keyframe estimates in the graph's own frame."""
        if not self._kf_ticks:
            return np.zeros((0, 3))
        return np.asarray(gtsam.utilities.extractPose2(self._current_values()), dtype=float).reshape(-1, 3)

    @property
    def keyframe_ticks(self) -> np.ndarray:
        """(K,) step index at which each keyframe was taken."""
        return np.asarray(self._kf_ticks, dtype=int)

    @property
    def keyframe_times(self) -> np.ndarray:
        """(K,) elapsed time (s, sum of dt up to and including that step) of each keyframe."""
        return np.asarray(self._kf_times, dtype=float)

    @property
    def keyframe_scenes(self) -> np.ndarray:
        """(K,) scene number each keyframe saw (-1 = none)."""
        return np.asarray(self._kf_scene, dtype=int)

    @property
    def loop_closures(self) -> np.ndarray:
        """(L, 2) keyframe indices (i earlier, j later) of every proposed closure."""
        return np.asarray(list(zip(self._lc_i, self._lc_j)), dtype=int).reshape(-1, 2)

    @property
    def closure_ticks(self) -> np.ndarray:
        """(L,) step index at which each closure was proposed."""
        return np.asarray(self._lc_tick, dtype=int)

    @property
    def closure_weights(self) -> np.ndarray:
        """(L,) weight of each closure at the current solution.

        gaussian: 1.0; robust: the kernel weight w(d) at the closure's
        Mahalanobis residual d; gnc: the weight of the latest GNC run, or — for
        closures proposed since and held provisionally with the robust kernel —
        that kernel's weight w(d).
        """
        n = len(self._lc_i)
        if n == 0:
            return np.zeros(0)
        if self._config.backend.kind == "gaussian":
            return np.ones(n)
        weights = np.asarray(self._lc_gnc_weight, dtype=float)
        unjudged = np.isnan(weights) if self._config.backend.kind == "gnc" else np.ones(n, dtype=bool)
        if unjudged.any():
            poses = self.keyframe_poses
            i = np.asarray(self._lc_i)[unjudged]
            j = np.asarray(self._lc_j)[unjudged]
            d = closure_mahalanobis(self._config, poses[i], poses[j], np.asarray(self._lc_scale)[unjudged])
            weights[unjudged] = [self._kernel.weight(float(x)) for x in d]
        return weights

    @property
    def closure_accepted(self) -> np.ndarray:
        """(L,) inlier flag: weight >= ``config.backend.accept_weight``."""
        return self.closure_weights >= self._config.backend.accept_weight

    @property
    def isam2_recoveries(self) -> int:
        """How often gtsam refused an update as indeterminate and iSAM2 was rebuilt (QR)."""
        return self._recoveries

    @property
    def closures_dropped(self) -> int:
        """Closures left out because gtsam refused the update even after a rebuild."""
        return self._closures_dropped

    @property
    def num_keyframes(self) -> int:
        """Number of keyframes so far."""
        return len(self._kf_ticks)


def _fit_se2(src: np.ndarray, dst: np.ndarray) -> gtsam.Pose2:
    """:func:`slamkit.poses.fit_se2` as a ``gtsam.Pose2``."""
    return gtsam.Pose2(*fit_se2(src, dst))


def _scene_number(scene_id) -> int:
    if isinstance(scene_id, (bool, np.bool_)):
        raise ValueError(f"step: scene_id must be an integer, got {scene_id!r}")
    if isinstance(scene_id, numbers.Integral):
        return int(scene_id)
    if isinstance(scene_id, numbers.Real) and float(scene_id).is_integer():
        return int(float(scene_id))
    raise ValueError(f"step: scene_id must be an integer, got {scene_id!r}")
