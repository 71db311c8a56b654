"""The re-entry policy (not in the paper): whether, and where, the robot re-enters an experience.

The experience map (eqs 2-11) switches to the most energetic experience whose view matches. At
each such re-entry it asks this policy one question: *the robot re-enters experience j at this
offset in j's frame: accept, hold or refuse?* (:meth:`ReentryPolicy.judge`), and, once accepted,
*at what pose?* (:meth:`ReentryPolicy.accept`). The paper's answer is always "accept, where the
pose cells say" (every switch below off, as in the published preset,
``RatSLAMConfig.published()``; its re-entry part alone: ``ratslam.PAPER_REENTRIES``). Four rules,
each with its own switch in the configuration:

Path bound (``experience_map.relocalise_path_bound``, :class:`PathBound`): a place further from
the predicted pose (the current pose: the map and the odometry) than the path driven since the
latest re-entry, plus ``relocalise_slack_cells``, cannot be where the robot is, whatever the view
says (a look-alike place, an aliased scene): refused.

Odometry gate (``experience_map.odometry_gate_chi2``, :class:`OdometryGate`): the path bound
assumes the odometry may have erred by all of the path since the latest re-entry; early in an
exploration that is tens of metres, and a look-alike room seen for the first time re-enters the
other room, scene after scene in sequence. With the gate a re-entry is refused when its
innovation (the pose cells' pose minus the prediction) lies beyond the gate's squared Mahalanobis
distance under the odometry's covariance since the robot was last at the place, scaled by how much
more the odometry has erred than its model (the median statistic of
:class:`ratslam.reentry.InnovationScale` over the re-entries taken and, once per scene, those
refused, so that a bias the model lacks, which makes every loop closure look unlikely, opens the
gate, while one look-alike room among well-modelled re-entries does not). The gate trusts the
odometry's model, so it acts only with the fusion on, once three re-entries have been taken (the
first loop closure of a run has nothing to judge the odometry by) and while they show the odometry
keeps to its model (``reentry.odometry_trust_limit``).

Loop-closure sequence (``experience_map.loop_closure_sequence``, :class:`LoopClosureSequence`):
a re-entry that the map's links already lead to from the current experience (within the path
driven since it was entered) continues a known route and is accepted at once. Any other re-entry
closes a new loop on one view, which an aliased scene can fake where the pose cells and the
odometry have drifted alike; it is held as a candidate and accepted only when the next scene's
re-entry agrees with it: the candidate's place composed with the odometry since then lands within
``relocalise_slack_cells`` of the new re-entry's place (consecutive views of one route, not one
match, as in sequence-based place recognition). Until then the map goes on as if no experience
matched (eqs 10-11).

Re-entry fusion (``reentry`` sigmas, :class:`ReentryFusion`; see :mod:`ratslam.reentry`): at an
accepted re-entry the pose the pose cells give (the experience's map pose composed with the
offset) and the pose the map and the odometry predict (the current pose) are fused by a Kalman
update, the prediction's covariance being the odometry's over the path driven since the robot was
last at that experience; the link and the current pose use the fused pose. An innovation beyond
``experience_map.odometry_gate_chi2`` of the prediction (its noise scaled as the re-entries have
shown) is not fused: the odometry has left its model there (a gyro bias the yaw-rate search has
not found yet), and the pose is the pose cells' (the paper's re-entry); a point between the two
explains neither, and its link stays wrong once the bias is taken out of the map.

The policy keeps its own odometry (:class:`ratslam.reentry.PathNoise`: the dead reckoning the
sequence compares consecutive re-entries by and, with the fusion on, its noise), told of every
tick (:meth:`ReentryPolicy.integrate`) and of every experience created and entered.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from slamkit.poses import between, compose, triple, wrap_scalar

from .columns import Growable
from .config import RatSLAMConfig
from .reentry import N_SUMS, InnovationScale, PathNoise, innovation, kalman_fuse

if TYPE_CHECKING:
    from .experience_map import ExperienceMap

GATE_EVIDENCE = 3  # re-entries that must have shown the odometry's errors before the gate acts
_NO_VIEW = -2  # the gate's latest refused scene: none since the latest re-entry taken


class Verdict(Enum):
    """The policy's answer to a re-entry."""

    ACCEPT = "accept"  # re-enter now
    HOLD = "hold"  # not yet: a loop closure waiting for the next scene to agree
    REFUSE = "refuse"  # not a place the robot can be


def _log_likelihood(nu: np.ndarray, cov: np.ndarray) -> float:
    """Log density (up to a constant) of a zero-mean Gaussian with ``cov`` at ``nu``."""
    return -0.5 * (float(nu @ np.linalg.solve(cov, nu)) + math.log(np.linalg.det(cov)))


@dataclass(frozen=True)
class Candidate:
    """A loop closure held until the next scene agrees: re-entering ``experience`` (seen as
    ``view``) at ``offset`` in its frame, when the dead reckoning was at ``odometry``."""

    experience: int
    view: int
    offset: tuple[float, float, float]
    odometry: tuple[float, float, float]


class ReentryInnovation(NamedTuple):
    """A re-entry compared with the prediction: the predicted pose, the pose the pose cells give,
    the innovation (their difference) and the odometry's covariance since the last visit."""

    predicted: tuple[float, float, float]
    measured: tuple[float, float, float]
    nu: np.ndarray
    since_visit: np.ndarray


class PathBound:
    """``relocalise_path_bound``: no re-entry further from the prediction than the path driven
    since the latest re-entry plus ``relocalise_slack_cells``."""

    def __init__(self, config: RatSLAMConfig):
        em = config.experience_map
        self.enabled = em.relocalise_path_bound
        self.slack_m = em.relocalise_slack_cells * config.pose_cells.cell_size_m
        self.path_m = 0.0  # m driven since the latest re-entry

    def integrate(self, dt: float, v_trans: float) -> None:
        self.path_m += abs(v_trans) * dt

    def refuses(self, predicted, place) -> bool:
        """Whether ``place`` (x, y, θ) lies beyond the bound from ``predicted``."""
        x, y, _ = place
        px, py, _ = predicted
        return math.hypot(x - px, y - py) > self.path_m + self.slack_m


class LoopClosureSequence:
    """``loop_closure_sequence``: a re-entry the links do not lead to waits for the next scene."""

    def __init__(self, config: RatSLAMConfig, em: ExperienceMap, odometry: PathNoise):
        cfg = config.experience_map
        self.enabled = cfg.loop_closure_sequence
        self.slack_m = cfg.relocalise_slack_cells * config.pose_cells.cell_size_m
        self.map = em
        self.odometry = odometry
        self.path_m = 0.0  # m driven since the current experience was entered
        self.candidate: Candidate | None = None  # a loop closure waiting for the next scene
        self._held: tuple[int, tuple] | None = None  # this scene's first held re-entry
        self._neighbours: dict[int, list[tuple[int, float]]] = {}  # links both ways, with d_ij
        self._links_seen = 0  # how many of the map's links are in _neighbours

    def integrate(self, dt: float, v_trans: float) -> None:
        self.path_m += abs(v_trans) * dt

    def in_sequence(self, j: int, offset, view: int) -> bool:
        """Whether re-entering ``j`` now is trusted: always with the switch off or before the
        first experience; else when the links lead there from the current experience, or when
        the held candidate of an earlier scene agrees with it."""
        current = self.map.current
        if not self.enabled or current < 0:
            return True
        if self.links_lead_to(current, j, self.path_m + self.slack_m):
            return True
        cand = self.candidate
        return cand is not None and cand.view != view and self._agrees(cand, j, offset)

    def hold(self, j: int, offset) -> None:
        """Note a re-entry not trusted yet (the scene's first is kept)."""
        if self._held is None:
            self._held = (j, offset)

    def declined(self, view: int) -> None:
        """The scene did not re-enter anything: its first held re-entry becomes the candidate the
        next scene must agree with (a later scene's replaces an earlier scene's)."""
        held, self._held = self._held, None
        if held is None or not self.enabled:
            return
        if self.candidate is None or self.candidate.view != view:
            j, offset = held
            self.candidate = Candidate(j, int(view), triple(offset), triple(self.odometry.pose))

    def reentered(self) -> None:
        self.candidate = None
        self._held = None

    def _agrees(self, cand: Candidate, j: int, offset) -> bool:
        """Whether the candidate's place, composed with the odometry driven since, is within the
        slack of where re-entering ``j`` at ``offset`` puts the robot."""
        since = between(cand.odometry, tuple(self.odometry.pose))
        x, y, _ = compose(self.map.robot_at(cand.experience, cand.offset), since)
        xj, yj, _ = self.map.robot_at(j, offset)
        return math.hypot(x - xj, y - yj) <= self.slack_m

    def links_lead_to(self, i: int, j: int, reach_m: float) -> bool:
        """Whether a chain of links joins ``i`` to ``j`` within ``reach_m`` of summed link
        distances (Dijkstra, stopped at the reach: only the neighbourhood is searched)."""
        self._sync_links()
        best = {i: 0.0}
        queue = [(0.0, i)]
        while queue:
            dist, k = heapq.heappop(queue)
            if k == j:
                return True
            if dist > best.get(k, math.inf):
                continue
            for n, d in self._neighbours.get(k, ()):
                nd = dist + d
                if nd <= reach_m and nd < best.get(n, math.inf):
                    best[n] = nd
                    heapq.heappush(queue, (nd, n))
        return False

    def _sync_links(self) -> None:
        """Add the map's links made since the last search to the neighbour lists."""
        d = self.map.link_column("d")
        if len(d) == self._links_seen:
            return
        f, t = self.map.link_column("from"), self.map.link_column("to")
        for k in range(self._links_seen, len(d)):
            a, b, dk = int(f[k]), int(t[k]), float(d[k])
            self._neighbours.setdefault(a, []).append((b, dk))
            self._neighbours.setdefault(b, []).append((a, dk))
        self._links_seen = len(d)

    def forget_links(self) -> None:
        """The map was replaced (state loaded): rebuild the neighbour lists at the next search."""
        self._neighbours = {}
        self._links_seen = 0


class ReentryFusion:
    """The ``reentry`` sigmas: an accepted re-entry fused with the odometry's prediction."""

    def __init__(self, config: RatSLAMConfig, em: ExperienceMap, odometry: PathNoise, visits: Growable):
        fusion = config.reentry
        self.enabled = fusion.enabled
        self.chain_fixes = fusion.chain_fixes
        self.trust_limit = fusion.odometry_trust_limit
        self.window = fusion.innovation_window
        self.gate_chi2 = config.experience_map.odometry_gate_chi2
        self.map = em
        self.odometry = odometry
        self.visits = visits  # the odometry's noise sums at each experience's last visit
        self.innovations = InnovationScale(self.window)
        self.fix = np.zeros(0)  # the latest re-entry's pose covariance (PathNoise.fix); empty: none
        self.view_cov = np.diag(
            [fusion.position_sigma_m**2, fusion.position_sigma_m**2, math.radians(fusion.heading_sigma_deg) ** 2]
        )

    def innovation(self, j: int, offset) -> ReentryInnovation:
        """Re-entering ``j`` at ``offset`` compared with the prediction (:class:`ReentryInnovation`)."""
        pred = self.map.pose
        meas = self.map.robot_at(j, offset)
        since_visit = self.odometry.covariance_since(self.visits.cols["noise"][j], pred[2])
        return ReentryInnovation(pred, meas, innovation(pred, meas), since_visit)

    def beyond_model(self, nu: np.ndarray, p_cov: np.ndarray) -> bool:
        """Whether innovation ``nu`` lies beyond ``experience_map.odometry_gate_chi2`` (squared
        Mahalanobis distance) of the prediction with covariance ``p_cov``, the view's added."""
        d2 = float(nu @ np.linalg.solve(p_cov + self.view_cov, nu))
        return d2 > self.gate_chi2

    def fuse(self, j: int, offset, inn: ReentryInnovation):
        """Kalman update at a re-entry into ``j``: the pose the pose cells give (``offset`` in
        ``j``'s frame; covariance from the reentry sigmas) fused with the pose the map and the
        odometry predict (:meth:`prediction_covariance`). Returns the fused pose as an offset in
        ``j``'s frame."""
        pred, meas, nu, since_visit = inn
        p_cov = self.prediction_covariance(nu, since_visit, pred[2])
        scale = self.innovations.scale
        # the odometry's noise scale is judged on loop-sized paths, whichever covariance is used
        self.innovations.add(nu, since_visit, self.view_cov)
        if not self.innovations.trusted(self.trust_limit) or self.beyond_model(nu, scale * p_cov):
            # the odometry has not shown that it keeps to its model, or errs here far beyond it
            # (a gyro bias not yet found): the pose cells alone
            self._record_fix(self.view_cov, meas[2])
            return offset
        fused, cov = kalman_fuse(pred, scale * p_cov, nu, self.view_cov)
        self._record_fix(cov, fused[2])
        fx, fy, fth = between(self.map.experience_pose(j), fused)
        return (fx, fy, wrap_scalar(fth))

    def _record_fix(self, cov: np.ndarray, heading: float) -> None:
        """Keep the re-entry's pose covariance for the next prediction (``reentry.chain_fixes``)."""
        if self.chain_fixes:
            self.fix = self.odometry.fix(cov, heading)

    def prediction_covariance(self, nu: np.ndarray, since_visit: np.ndarray, heading: float) -> np.ndarray:
        """Covariance (map frame) of the predicted pose relative to the re-entered experience.

        Two models: the map was laid out along the path since the robot was last at the place,
        so the prediction errs by the odometry's error over that path (``since_visit``: a loop
        closed, the map's drift still in it); or, with ``reentry.chain_fixes``, the place sits
        where the map has it relative to the latest re-entry and the prediction errs by that
        fix's fused error carried along the path since (a robot moving about a known map). Of
        the two, the one under which the innovation ``nu`` is the more likely."""
        if not (self.chain_fixes and len(self.fix)):
            return since_visit
        since_fix = self.odometry.covariance_after(self.fix, heading)
        if _log_likelihood(nu, since_fix + self.view_cov) > _log_likelihood(nu, since_visit + self.view_cov):
            return since_fix
        return since_visit


class OdometryGate:
    """``odometry_gate_chi2``: a re-entry the odometry's model (scaled) rules out is refused."""

    def __init__(self, fusion: ReentryFusion):
        self.fusion = fusion
        self.enabled = fusion.enabled and math.isfinite(fusion.gate_chi2)
        self.scale = InnovationScale(fusion.window)
        self.view = _NO_VIEW  # the latest refused scene since the latest re-entry taken

    def acts(self) -> bool:
        """Whether the gate judges now: on, and the re-entries taken show the odometry keeping to
        its model."""
        inn = self.fusion.innovations
        return self.enabled and inn.count >= GATE_EVIDENCE and inn.trusted(self.fusion.trust_limit)

    def refuses(self, j: int, offset) -> bool:
        """Whether the gate refuses re-entering ``j`` at ``offset`` (module doc); a refused
        scene's innovation goes into the gate's scale."""
        _, _, nu, since_visit = self.fusion.innovation(j, offset)
        if not self.fusion.beyond_model(nu, self.scale.scale * since_visit):
            return False
        view = int(self.fusion.map.views[j])
        if view != self.view:  # one refused innovation per scene
            self.scale.add(nu, since_visit, self.fusion.view_cov)
            self.view = view
        return True

    def taken(self, inn: ReentryInnovation) -> None:
        """A re-entry was taken: its innovation goes into the gate's scale."""
        self.scale.add(inn.nu, inn.since_visit, self.fusion.view_cov)
        self.view = _NO_VIEW


class ReentryPolicy:
    """The four re-entry rules (module doc) behind the two questions the map asks."""

    def __init__(self, config: RatSLAMConfig, em: ExperienceMap):
        self.config = config
        self.map = em
        fusion = config.reentry
        # the dead reckoning (also what consecutive re-entries are compared by) and, when fusing,
        # the odometry's noise along the path
        self.odometry = PathNoise(fusion.odom_speed_noise_m_s, fusion.odom_heading_noise_rad_s, fusion.enabled)
        self.visits = Growable({"noise": ((N_SUMS,), float)})  # the noise sums at each last visit
        self.path_bound = PathBound(config)
        self.sequence = LoopClosureSequence(config, em, self.odometry)
        self.fusion = ReentryFusion(config, em, self.odometry, self.visits)
        self.gate = OdometryGate(self.fusion)

    # ------------------------------------------------------------------ told by the map
    def integrate(self, dt: float, v_trans: float, v_rot: float) -> None:
        """One tick of wheel odometry."""
        self.path_bound.integrate(dt, v_trans)
        self.sequence.integrate(dt, v_trans)
        self.odometry.integrate(dt, v_trans, v_rot)

    def created(self, j: int) -> None:
        """Experience ``j`` was added: the robot was there now."""
        k = self.visits.append(noise=self.odometry.sums)
        assert k == j, (k, j)

    def entered(self, j: int) -> None:
        """Experience ``j`` became current."""
        self.visits.cols["noise"][j] = self.odometry.sums
        self.sequence.path_m = 0.0

    # ------------------------------------------------------------------ asked by the map
    def judge(self, j: int, offset, view: int) -> Verdict:
        """The robot would re-enter experience ``j`` (view ``view``), standing at ``offset`` in its
        frame: accept, hold (the loop-closure sequence) or refuse (the path bound, the gate)."""
        if self.map.current >= 0:
            if self.path_bound.enabled and self.path_bound.refuses(self.map.pose, self.map.robot_at(j, offset)):
                return Verdict.REFUSE
            if self.gate.acts() and self.gate.refuses(j, offset):
                return Verdict.REFUSE
        if not self.sequence.in_sequence(j, offset, view):
            self.sequence.hold(j, offset)
            return Verdict.HOLD
        return Verdict.ACCEPT

    def declined(self, view: int) -> None:
        """The scene ``view`` re-entered nothing this tick (it stayed or a new experience follows)."""
        self.sequence.declined(view)

    def accept(self, j: int, offset):
        """Re-entering ``j`` at ``offset`` (an accepted verdict): the offset the link and the pose
        use (fused with the odometry's prediction when the fusion is on)."""
        if self.map.current >= 0 and self.fusion.enabled:
            offset = self.fuse(j, offset)
        self.path_bound.path_m = 0.0
        self.sequence.reentered()
        return offset

    def fuse(self, j: int, offset):
        """The fusion's offset for a re-entry into ``j`` at ``offset`` (:meth:`ReentryFusion.fuse`);
        its innovation feeds both noise scales, the fusion's and the gate's."""
        inn = self.fusion.innovation(j, offset)
        self.gate.taken(inn)
        return self.fusion.fuse(j, offset, inn)

    def restart_innovations(self) -> None:
        """Re-entries' innovation statistics from scratch (the fusion's noise scale and the
        gate's): the odometry they measured has changed (a yaw-rate bias taken off)."""
        self.fusion.innovations = InnovationScale(self.fusion.window)
        self.gate.scale = InnovationScale(self.fusion.window)
        self.gate.view = _NO_VIEW

    # ------------------------------------------------------------------ state i/o
    def get_state(self) -> dict:
        """Arrays that fully describe the policy (saved with the map's, under its keys)."""
        cand = self.sequence.candidate
        return {
            "em_noise": self.visits.view("noise").copy(),
            "em_path_noise": self.odometry.get_state(),
            "em_innovations": self.fusion.innovations.get_state(),
            "em_gate_scale": self.gate.scale.get_state(),
            "em_gate_view": np.array([self.gate.view], dtype=np.int64),
            "em_fix": self.fusion.fix.copy(),
            "em_path_since_reentry": np.array([self.path_bound.path_m, self.sequence.path_m]),
            "em_candidate": (
                np.array([cand.experience, cand.view, *cand.offset, *cand.odometry]) if cand else np.zeros(0)
            ),
        }

    def set_state(self, s: dict) -> None:
        """Restore a state produced by :meth:`get_state`."""
        self.visits.load({"noise": s["em_noise"]})
        self.odometry.set_state(s["em_path_noise"])
        self.fusion.innovations.set_state(s["em_innovations"])
        if "em_gate_scale" in s:  # saved before the odometry gate: its scale starts afresh
            self.gate.scale.set_state(s["em_gate_scale"])
            self.gate.view = int(s["em_gate_view"][0])
        self.fusion.fix = np.asarray(s["em_fix"], dtype=float).copy()
        self.path_bound.path_m, self.sequence.path_m = (float(v) for v in s["em_path_since_reentry"])
        c = s["em_candidate"]
        self.sequence.candidate = Candidate(int(c[0]), int(c[1]), triple(c[2:5]), triple(c[5:8])) if len(c) else None
        self.sequence.forget_links()
