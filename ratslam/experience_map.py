"""The experience map (paper eqs 2-14).

An experience ``e_i`` is its pose-cell coordinates (x'_i, y'_i, θ'_i), its view (scene number)
``V_i`` and its map pose (x_i, y_i, θ_i). A transition (link) ``i -> j`` stores the odometry
accumulated between leaving ``i`` and entering ``j``: distance d_ij, bearing θ_ij of ``j`` relative
to ``i``'s heading, heading change φ_ij, and elapsed time.

Zone of influence (eqs 2-9), with r and Δθ' measured wrap-aware in cell units::

    E_xy = max(1 - r / r_inf, 0)          r   = |(x'_pc, y'_pc) - (x'_i, y'_i)|       (eqs 2-3)
    E_θ  = max(1 - Δθ' / θ_inf, 0)        Δθ' = |θ'_pc - θ'_i|                     (eqs 4-5)
    E_V  = 1 if V == V_i else 0                                                     (eqs 6-8)
    E_i  = E_V (E_xy + E_θ)     ("sum", eq 9)    or    E_V E_xy E_θ   ("product")

No experience with positive energy -> a new experience at the current pose (eqs 10-11), linked
from the previous one; otherwise the most energetic experience becomes current (with a link from
the previous one if they are not linked yet). The switch happens anywhere within the zone of
influence; with ``offset_transitions`` (``ExperienceMapConfig``) the new link is measured to the experience's own place
(the odometry composed with the inverse of the peak's offset from the experience's cells) and
the current pose starts at that offset, so a consistent map neither gains an error nor makes
the pose jump at a re-entry.

Re-entry fusion (``reentry``, on by default; not in the paper, see :mod:`ratslam.reentry`): at a
switch, the pose the pose cells give (the experience's map pose composed with the peak's offset)
and the pose the map and the odometry predict (the current pose) are fused by a Kalman update,
the prediction's covariance being the odometry's over the path driven since the robot was last at
that experience; the link and the current pose use the fused pose. An innovation beyond
``experience_map.odometry_gate_chi2`` of the prediction (its noise scaled as the re-entries have
shown) is not fused: the odometry has left its model there (a gyro bias the yaw-rate search has
not found yet), and the pose is the pose cells' (the paper's re-entry); a point between the two
explains neither, and its link stays wrong once the bias is taken out of the map.

Loop-closure sequence (``experience_map.loop_closure_sequence``, on by default; not in the paper):
a re-entry that the map's links already lead to from the current experience (within the path
driven since it was entered) continues a known route and is taken at once. Any other re-entry
closes a new loop on one view, which an aliased scene can fake where the pose cells and the
odometry have drifted alike; it is held as a candidate and taken only when the next scene's
re-entry agrees with it: the candidate's place composed with the odometry since then lands within
``relocalise_slack_cells`` of the new re-entry's place (consecutive views of one route, not one
match, as in sequence-based place recognition). Until then the map goes on as if no experience
matched (eqs 10-11).

Odometry gate (``experience_map.odometry_gate_chi2``, not in the paper): the path bound assumes
the odometry may have erred by all of the path since the latest re-entry; early in an exploration
that is tens of metres, and a look-alike room seen for the first time re-enters the other room,
scene after scene in sequence. With the gate a re-entry is refused when its innovation (the pose
cells' pose minus the prediction) lies beyond the gate's squared Mahalanobis distance under the
odometry's covariance since the robot was last at the place, scaled by how much more the
odometry has erred than its model (the median statistic of :class:`ratslam.reentry.InnovationScale`
over the re-entries taken and, once per scene, those refused, so that a bias the model lacks,
which makes every loop closure look unlikely, opens the gate, while one look-alike room among
well-modelled re-entries does not). The gate trusts the odometry's model, so it acts only once
three re-entries have been taken (the first loop closure of a run has nothing to judge the
odometry by) and while they show the odometry keeps to its model (``reentry.odometry_trust_limit``).

Map correction (eqs 12-14), every tick, all experiences at once (Jacobi)::

    Δθ_i = α_θ [ Σ_j (θ_j - θ_i - φ_ij) + Σ_k (θ_k - θ_i + φ_ki) ]
    Δx_i = α_d [ Σ_j (x_j - d_ij cos(θ_i + θ_ij) - x_i) + Σ_k (x_k + d_ki cos(θ_k + θ_ki) - x_i) ]
    Δy_i = α_d [ Σ_j (y_j - d_ij sin(θ_i + θ_ij) - y_i) + Σ_k (y_k + d_ki sin(θ_k + θ_ki) - y_i) ]

over links ``i -> j`` (from i) and ``k -> i`` (to i). Eq 14 as printed ends its second sum with
``- y_k``; that is a typo for ``- y_i`` (compare eq 13). ``correction="printed"`` uses the sums
as printed (overshoots and diverges where an experience has more than two links);
``correction="stable"`` divides each sum by the experience's number of links (α times the mean
residual), which converges.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix, identity
from scipy.sparse.linalg import factorized

from . import map_kernels
from .config import RatSLAMConfig
from .reentry import N_SUMS, InnovationScale, PathNoise, innovation, kalman_fuse

_PI = math.pi
_NO_DIVISOR = np.zeros(0)
_GATE_EVIDENCE = 3  # re-entries that must have shown the odometry's errors before the gate acts


def wrap_angle(a):
    """Wrap radians into [-π, π]."""
    a = np.asarray(a)
    return a - (2.0 * _PI) * np.round(a * (1.0 / (2.0 * _PI)))


def _log_likelihood(nu: np.ndarray, cov: np.ndarray) -> float:
    """Log density (up to a constant) of a zero-mean Gaussian with ``cov`` at ``nu``."""
    return -0.5 * (float(nu @ np.linalg.solve(cov, nu)) + math.log(np.linalg.det(cov)))


def _wrap_scalar(a: float) -> float:
    return (a + _PI) % (2.0 * _PI) - _PI


@dataclass(frozen=True)
class _Candidate:
    """A loop closure held until the next scene agrees: re-entering ``experience`` (seen as
    ``view``) at ``offset`` in its frame, when the dead reckoning was at ``odometry``."""

    experience: int
    view: int
    offset: tuple[float, float, float]
    odometry: tuple[float, float, float]


def _triple(v) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _compose(a, b) -> tuple[float, float, float]:
    """Pose ``b`` (in ``a``'s frame) in the frame ``a`` is in."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def _between(a, b) -> tuple[float, float, float]:
    """Pose ``b`` in ``a``'s frame (both in one frame)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, b[2] - a[2])


class _Growable:
    """Column arrays with amortised O(1) append."""

    def __init__(self, spec: dict[str, tuple[tuple, type]]):
        self._spec = spec
        self.n = 0
        self._cap = 64
        self.cols: dict[str, np.ndarray] = {
            k: np.zeros((self._cap, *shape), dtype=dt) for k, (shape, dt) in spec.items()
        }

    def append(self, **values) -> int:
        if self.n == self._cap:
            self._cap *= 2
            for k, arr in self.cols.items():
                new = np.zeros((self._cap,) + arr.shape[1:], dtype=arr.dtype)
                new[: self.n] = arr[: self.n]
                self.cols[k] = new
        i = self.n
        for k, v in values.items():
            self.cols[k][i] = v
        self.n += 1
        return i

    def view(self, key: str) -> np.ndarray:
        return self.cols[key][: self.n]

    def load(self, arrays: dict[str, np.ndarray]) -> None:
        n = len(next(iter(arrays.values())))
        self._cap = max(64, 1 << max(n - 1, 1).bit_length())
        self.n = n
        for k, (shape, dt) in self._spec.items():
            self.cols[k] = np.zeros((self._cap,) + shape, dtype=dt)
            self.cols[k][:n] = arrays[k]


class ExperienceMap:
    """Experiences, transitions and the map correction of eqs 12-14."""

    def __init__(self, config: RatSLAMConfig):
        self.config = config
        # map poses as separate x, y, θ columns: contiguous arrays for the per-tick correction
        self._exp = _Growable(
            {
                "x": ((), float),
                "y": ((), float),
                "th": ((), float),
                "cell": ((3,), float),
                "view": ((), np.int64),
                "first": ((), np.int64),
                "last": ((), np.int64),
                "degree": ((), float),
                "noise": ((N_SUMS,), float),  # the odometry's noise sums at the last visit
            }
        )
        self._link = _Growable(
            {
                "from": ((), np.int64),
                "to": ((), np.int64),
                "d": ((), float),
                "theta": ((), float),
                "phi": ((), float),
                "dt": ((), float),
            }
        )
        self._by_view: dict[int, list[int]] = {}
        self._linked: set[tuple[int, int]] = set()
        self.current = -1
        # odometry accumulated since the current experience was entered, in its frame
        self._acc = np.zeros(4)  # x, y, phi, t
        self._path_since_reentry = 0.0  # m driven since the latest switch to a familiar experience
        self._path_since_enter = 0.0  # m driven since the current experience was entered
        self._candidate: _Candidate | None = None  # a loop closure waiting for the next scene
        self._neighbours: dict[int, list[tuple[int, float]]] = {}  # links both ways, with d_ij
        # re-entry fusion (off with zero view sigmas)
        fusion = config.reentry
        self._fuse = fusion.enabled
        # the dead reckoning (also what consecutive re-entries are compared by) and, when fusing,
        # the odometry's noise along the path
        self._noise = PathNoise(fusion.odom_speed_noise_m_s, fusion.odom_heading_noise_rad_s, fusion.enabled)
        self._innovations: InnovationScale
        self._gate_scale: InnovationScale
        self._gate_view: int
        self._restart_innovations()
        self._fix = np.zeros(0)  # the latest re-entry's pose covariance (PathNoise.fix); empty: none
        self._view_cov = np.diag(
            [fusion.position_sigma_m**2, fusion.position_sigma_m**2, math.radians(fusion.heading_sigma_deg) ** 2]
        )
        self._grid = np.array(config.shape, dtype=float)
        self._divisor_key: tuple | None = None

    # ------------------------------------------------------------------ read access
    @property
    def size(self) -> int:
        return self._exp.n

    @property
    def poses(self) -> np.ndarray:
        """Map poses (N, 3): x, y (m), θ (rad), as a new array."""
        return np.stack((self._exp.view("x"), self._exp.view("y"), self._exp.view("th")), axis=1)

    def set_poses(self, poses: np.ndarray) -> None:
        """Overwrite all map poses with an (N, 3) array."""
        poses = np.asarray(poses, dtype=float)
        n = self._exp.n
        for k, key in enumerate(("x", "y", "th")):
            self._exp.cols[key][:n] = poses[:, k]

    @property
    def cells(self) -> np.ndarray:
        return self._exp.view("cell")

    @property
    def views(self) -> np.ndarray:
        return self._exp.view("view")

    @property
    def first_tick(self) -> np.ndarray:
        return self._exp.view("first")

    @property
    def last_tick(self) -> np.ndarray:
        return self._exp.view("last")

    @property
    def links(self) -> np.ndarray:
        return np.stack((self._link.view("from"), self._link.view("to")), axis=1)

    def link_column(self, key: str) -> np.ndarray:
        """One link attribute: "d", "theta", "phi" or "dt"."""
        return self._link.view(key)

    @property
    def pose(self) -> tuple[float, float, float]:
        """Current pose: the current experience's map pose composed with the odometry
        accumulated since it was entered (the origin before the first experience)."""
        ax, ay, aphi, _ = self._acc
        if self.current < 0:
            return (float(ax), float(ay), float(_wrap_scalar(aphi)))
        cols = self._exp.cols
        x, y, th = cols["x"][self.current], cols["y"][self.current], cols["th"][self.current]
        c, s = math.cos(th), math.sin(th)
        return (float(x + c * ax - s * ay), float(y + s * ax + c * ay), float(_wrap_scalar(th + aphi)))

    # ------------------------------------------------------------------ odometry
    def integrate(self, dt: float, v_trans: float, v_rot: float) -> None:
        """Accumulate wheel odometry since the current experience was entered."""
        acc = self._acc
        acc[2] += v_rot * dt
        acc[0] += v_trans * dt * math.cos(acc[2])
        acc[1] += v_trans * dt * math.sin(acc[2])
        acc[3] += dt
        self._path_since_reentry += abs(v_trans) * dt
        self._path_since_enter += abs(v_trans) * dt
        self._noise.integrate(dt, v_trans, v_rot)

    # ------------------------------------------------------------------ eqs 2-9
    def energy(self, peak_cell: np.ndarray, view: int, ids: np.ndarray | None = None) -> np.ndarray:
        """Energy E_i (eqs 2-9) of experiences ``ids`` (default: all) for a peak and a view."""
        cfg = self.config.experience_map
        if ids is None:
            ids = np.arange(self._exp.n)
        cells = self._exp.cols["cell"][ids]
        d = np.abs(cells - peak_cell)
        d = np.minimum(d, self._grid - d)  # wrap-aware
        r = np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2)  # eq 3
        e_xy = np.maximum(1.0 - r / cfg.r_inf_cells, 0.0)  # eq 2
        e_th = np.maximum(1.0 - d[:, 2] / cfg.theta_inf_cells, 0.0)  # eqs 4-5
        e_v = (self._exp.cols["view"][ids] == view).astype(float)  # eqs 6-8
        if cfg.energy == "sum":
            return e_v * (e_xy + e_th)  # eq 9
        return e_v * e_xy * e_th

    # ------------------------------------------------------------------ eqs 10-11
    def add_experience(self, pose, cell, view: int, tick: int) -> int:
        """Append an experience with a given map pose, pose-cell coordinates and view; returns
        its index (eqs 10-11 call this with the current pose)."""
        x, y, th = (float(v) for v in pose)
        j = self._exp.append(x=x, y=y, th=th, cell=cell, view=view, first=tick, last=tick, noise=self._noise.sums)
        self._by_view.setdefault(int(view), []).append(j)
        return j

    def _new_experience(self, tick: int, peak_cell: np.ndarray, view: int) -> int:
        return self.add_experience(self.pose, peak_cell, view, tick)

    def _add_link(self, i: int, j: int, offset=(0.0, 0.0, 0.0)) -> None:
        """Link the current experience ``i`` to ``j``, the robot being at ``offset`` in ``j``'s
        frame: j's place relative to i is the accumulated odometry composed with offset⁻¹."""
        ax, ay, aphi, at = self._acc
        ox, oy, oth = offset
        phi = aphi - oth
        c, s = math.cos(phi), math.sin(phi)
        self.add_transition(i, j, ax - (c * ox - s * oy), ay - (s * ox + c * oy), phi, at)

    def add_transition(self, i: int, j: int, dx: float, dy: float, dphi: float, dt: float) -> bool:
        """Link i -> j from odometry (dx, dy, dphi) accumulated in i's frame over dt seconds.
        Returns False (and adds nothing) if i == j or the two are already linked."""
        key = (min(i, j), max(i, j))
        if i == j or key in self._linked:
            return False
        ax, ay, aphi, at = dx, dy, dphi, dt
        self._link.append(
            **{
                "from": i,
                "to": j,
                "d": math.hypot(ax, ay),
                "theta": math.atan2(ay, ax),
                "phi": _wrap_scalar(aphi),
                "dt": at,
            }
        )
        self._linked.add(key)
        self._add_neighbours(i, j, math.hypot(ax, ay))
        deg = self._exp.cols["degree"]
        deg[i] += 1.0
        deg[j] += 1.0
        return True

    def update(self, tick: int, peak_cell: np.ndarray, view: int) -> str:
        """Experience selection for this tick. ``view`` is the scene number (-1: no view, which
        never switches or creates experiences). Returns "none", "create" or "switch"."""
        if view < 0:
            return "none"
        ids = self._by_view.get(int(view))
        if ids:
            ids_arr = np.asarray(ids)
            e = self.energy(peak_cell, view, ids_arr)
            held = None  # the most energetic re-entry waiting for the next scene
            for k in np.argsort(-e, kind="stable"):  # most energetic first (eq 9)
                if e[k] <= 0.0:
                    break
                j = int(ids_arr[k])
                if j == self.current:
                    self._hold(held, view)
                    return "none"
                offset = self._reentry_offset(j, peak_cell)
                if offset is None:
                    continue
                if not self._closes_in_sequence(j, offset, view):
                    held = held or (j, offset)
                    continue
                self._switch(j, tick, offset)
                return "switch"
            self._hold(held, view)
        # eqs 10-11: no experience with positive energy (or none a plausible re-entry)
        j = self._new_experience(tick, peak_cell, view)
        if self.current >= 0:
            self._add_link(self.current, j)
        self._enter(j, tick)
        return "create"

    def _switch(self, j: int, tick: int, offset) -> None:
        """Re-enter ``j``, the robot at ``offset`` in its frame (fused with the odometry's
        prediction when the re-entry fusion is on)."""
        if self.current >= 0 and self._fuse:
            offset = self.fuse_reentry(j, offset)
        if self.current >= 0:
            self._add_link(self.current, j, offset)
        self._enter(j, tick, offset)
        self._path_since_reentry = 0.0
        self._candidate = None

    def _reentry_offset(self, j: int, peak_cell: np.ndarray):
        """Where the pose cells put the robot in ``j``'s frame if it re-enters ``j`` now, or None
        if that re-entry is not plausible: with ``experience_map.relocalise_path_bound``, a place
        further from the predicted pose than the path driven since the latest re-entry (plus
        ``relocalise_slack_cells``) cannot be where the robot is, whatever the view says (a
        look-alike place, an aliased scene)."""
        cfg = self.config.experience_map
        offset = self.peak_offset(j, peak_cell) if cfg.offset_transitions else (0.0, 0.0, 0.0)
        if self.current >= 0 and cfg.relocalise_path_bound:
            x, y, _ = self._robot_at(j, offset)
            px, py, _ = self.pose
            if math.hypot(x - px, y - py) > self._path_since_reentry + self._slack_m:
                return None
        if (
            self.current >= 0
            and self._fuse
            and math.isfinite(cfg.odometry_gate_chi2)
            and self._innovations.count >= _GATE_EVIDENCE
            and self._innovations.trusted(self.config.reentry.odometry_trust_limit)
            and self._gated(j, offset)
        ):
            return None
        return offset

    def _gated(self, j: int, offset) -> bool:
        """Whether ``experience_map.odometry_gate_chi2`` refuses re-entering ``j`` at ``offset``
        (module doc, odometry gate); a refused scene's innovation goes into the gate's scale."""
        _, _, nu, since_visit = self._reentry_innovation(j, offset)
        gate = self._gate_scale
        if not self._beyond_model(nu, gate.scale * since_visit):
            return False
        view = int(self._exp.cols["view"][j])
        if view != self._gate_view:  # one refused innovation per scene
            gate.add(nu, since_visit, self._view_cov)
            self._gate_view = view
        return True

    @property
    def _slack_m(self) -> float:
        """How well a view places the robot (``relocalise_slack_cells``), in metres."""
        return self.config.experience_map.relocalise_slack_cells * self.config.pose_cells.cell_size_m

    # ------------------------------------------------------------------ loop-closure sequence
    def _closes_in_sequence(self, j: int, offset, view: int) -> bool:
        """Whether re-entering ``j`` now is trusted (module doc, loop-closure sequence): always
        without ``loop_closure_sequence``; else when the links lead there from the current
        experience, or when the held candidate of an earlier scene agrees with it."""
        if not self.config.experience_map.loop_closure_sequence or self.current < 0:
            return True
        if self._links_lead_to(self.current, j, self._path_since_enter + self._slack_m):
            return True
        cand = self._candidate
        return cand is not None and cand.view != view and self._agrees(cand, j, offset)

    def _hold(self, held, view: int) -> None:
        """Keep the first re-entry of a scene that was not trusted as the candidate the next scene
        must agree with (a later scene's replaces an earlier scene's)."""
        if held is None or not self.config.experience_map.loop_closure_sequence:
            return
        if self._candidate is None or self._candidate.view != view:
            j, offset = held
            self._candidate = _Candidate(j, int(view), _triple(offset), _triple(self._noise.pose))

    def _agrees(self, cand: _Candidate, j: int, offset) -> bool:
        """Whether the candidate's place, composed with the odometry driven since, is within the
        slack of where re-entering ``j`` at ``offset`` puts the robot."""
        since = _between(cand.odometry, tuple(self._noise.pose))
        x, y, _ = _compose(self._robot_at(cand.experience, cand.offset), since)
        xj, yj, _ = self._robot_at(j, offset)
        return math.hypot(x - xj, y - yj) <= self._slack_m

    def _add_neighbours(self, i: int, j: int, d: float) -> None:
        self._neighbours.setdefault(i, []).append((j, d))
        self._neighbours.setdefault(j, []).append((i, d))

    def _links_lead_to(self, i: int, j: int, reach_m: float) -> bool:
        """Whether a chain of links joins ``i`` to ``j`` within ``reach_m`` of summed link
        distances (Dijkstra, stopped at the reach: only the neighbourhood is searched)."""
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

    def _robot_at(self, j: int, offset) -> tuple[float, float, float]:
        """The map pose of a robot at ``offset`` (forward, left, heading) in ``j``'s frame."""
        c = self._exp.cols
        return _compose((c["x"][j], c["y"][j], c["th"][j]), offset)

    def _reentry_innovation(self, j: int, offset):
        """Re-entering ``j`` at ``offset``: the predicted pose, the pose the pose cells give, the
        innovation (their difference) and the odometry's covariance since the last visit to ``j``."""
        pred = self.pose
        meas = self._robot_at(j, offset)
        since_visit = self._noise.covariance_since(self._exp.cols["noise"][j], pred[2])
        return pred, meas, innovation(pred, meas), since_visit

    def fuse_reentry(self, j: int, offset):
        """Kalman update at a re-entry into ``j``: the pose the pose cells give (``offset`` in
        ``j``'s frame; covariance from the reentry sigmas) fused with the pose the map and the
        odometry predict (:meth:`prediction_covariance`). Returns the fused pose as an offset in
        ``j``'s frame."""
        pred, meas, nu, since_visit = self._reentry_innovation(j, offset)
        p_cov = self.prediction_covariance(nu, since_visit, pred[2])
        scale = self._innovations.scale
        # the odometry's noise scale is judged on loop-sized paths, whichever covariance is used
        self._innovations.add(nu, since_visit, self._view_cov)
        self._gate_scale.add(nu, since_visit, self._view_cov)
        self._gate_view = -2
        if not self._innovations.trusted(self.config.reentry.odometry_trust_limit) or self._beyond_model(
            nu, scale * p_cov
        ):
            # the odometry has not shown that it keeps to its model, or errs here far beyond it
            # (a gyro bias not yet found): the pose cells alone
            self._record_fix(self._view_cov, meas[2])
            return offset
        fused, cov = kalman_fuse(pred, scale * p_cov, nu, self._view_cov)
        self._record_fix(cov, fused[2])
        c = self._exp.cols
        fx, fy, fth = _between((c["x"][j], c["y"][j], c["th"][j]), fused)
        return (fx, fy, _wrap_scalar(fth))

    def _beyond_model(self, nu: np.ndarray, p_cov: np.ndarray) -> bool:
        """Whether innovation ``nu`` lies beyond ``experience_map.odometry_gate_chi2`` (squared
        Mahalanobis distance) of the prediction with covariance ``p_cov``, the view's added."""
        d2 = float(nu @ np.linalg.solve(p_cov + self._view_cov, nu))
        return d2 > self.config.experience_map.odometry_gate_chi2

    def _record_fix(self, cov: np.ndarray, heading: float) -> None:
        """Keep the re-entry's pose covariance for the next prediction (``reentry.chain_fixes``)."""
        if self.config.reentry.chain_fixes:
            self._fix = self._noise.fix(cov, heading)

    def prediction_covariance(self, nu: np.ndarray, since_visit: np.ndarray, heading: float) -> np.ndarray:
        """Covariance (map frame) of the predicted pose relative to the re-entered experience.

        Two models: the map was laid out along the path since the robot was last at the place,
        so the prediction errs by the odometry's error over that path (``since_visit``: a loop
        closed, the map's drift still in it); or, with ``reentry.chain_fixes``, the place sits
        where the map has it relative to the latest re-entry and the prediction errs by that
        fix's fused error carried along the path since (a robot moving about a known map). Of
        the two, the one under which the innovation ``nu`` is the more likely."""
        if not (self.config.reentry.chain_fixes and len(self._fix)):
            return since_visit
        since_fix = self._noise.covariance_after(self._fix, heading)
        if _log_likelihood(nu, since_fix + self._view_cov) > _log_likelihood(nu, since_visit + self._view_cov):
            return since_fix
        return since_visit

    def peak_offset(self, j: int, peak_cell: np.ndarray) -> tuple[float, float, float]:
        """Where the pose-cell peak is relative to experience ``j``'s cells, in ``j``'s frame:
        (forward m, left m, heading rad), from the wrap-aware cell difference."""
        cfg = self.config.pose_cells
        cell = self._exp.cols["cell"][j]
        d = np.asarray(peak_cell, dtype=float) - cell
        d -= self._grid * np.round(d / self._grid)  # wrap-aware
        dx, dy = d[0] * cfg.cell_size_m, d[1] * cfg.cell_size_m
        c, s = math.cos(cell[2] * cfg.theta_cell_rad), math.sin(cell[2] * cfg.theta_cell_rad)
        return (c * dx + s * dy, -s * dx + c * dy, float(d[2]) * cfg.theta_cell_rad)

    def _enter(self, j: int, tick: int, offset=(0.0, 0.0, 0.0)) -> None:
        """Make ``j`` current; the robot is at ``offset`` in its frame."""
        self.current = j
        self._exp.cols["last"][j] = tick
        self._exp.cols["noise"][j] = self._noise.sums
        self._acc[:3] = offset
        self._acc[3] = 0.0
        self._path_since_enter = 0.0

    # ------------------------------------------------------------------ eqs 12-14
    def link_residuals(self) -> np.ndarray:
        """Per link i -> j: (x_j - x̂_j, y_j - ŷ_j, wrap(θ_j - θ_i - φ_ij)), where x̂_j, ŷ_j is
        where i's map pose and the link put j."""
        return np.stack(self._residual_columns(), axis=1)

    def _residual_columns(self):
        m = self._link.n
        lk, ex = self._link.cols, self._exp.cols
        fi, tj = lk["from"][:m], lk["to"][:m]
        thi = ex["th"].take(fi)
        ang = thi + lk["theta"][:m]
        d = lk["d"][:m]
        rx = ex["x"].take(tj) - ex["x"].take(fi) - d * np.cos(ang)
        ry = ex["y"].take(tj) - ex["y"].take(fi) - d * np.sin(ang)
        rt = wrap_angle(ex["th"].take(tj) - thi - lk["phi"][:m])
        return rx, ry, rt

    def _inverse_degree(self) -> np.ndarray:
        """Per-experience 1 / link count for the stable form (empty for the printed sums);
        recomputed only when the map grows."""
        key = (self._exp.n, self._link.n, self.config.experience_map.correction)
        if self._divisor_key != key:
            if self.config.experience_map.correction == "stable":
                self._divisor = 1.0 / np.maximum(self._exp.cols["degree"][: self._exp.n], 1.0)
            else:
                self._divisor = _NO_DIVISOR
            self._divisor_key = key
        return self._divisor

    def correct(self) -> None:
        """One pass of eqs 12-14 over all links (simultaneous update, compiled loop)."""
        n, m = self._exp.n, self._link.n
        if m == 0:
            return
        cfg = self.config.experience_map
        ex, lk = self._exp.cols, self._link.cols
        map_kernels.correct(
            ex["x"],
            ex["y"],
            ex["th"],
            n,
            lk["from"],
            lk["to"],
            lk["d"],
            lk["theta"],
            lk["phi"],
            m,
            self._inverse_degree(),
            cfg.alpha_d,
            cfg.alpha_theta,
        )

    # ------------------------------------------------------------------ yaw-rate bias
    def remove_yaw_bias(self, change: float, settle: bool = True) -> None:
        """The odometry's yaw rate was found to carry ``change`` rad/s more bias than assumed so
        far (:mod:`ratslam.yaw_bias`); the caller feeds the corrected rate from now on. Every
        transition loses the bias's turn over its elapsed time dt_ij: φ_ij by change·dt_ij, the
        bearing θ_ij by half that (the path turned gradually). With ``settle`` (a change that
        turns the map by a lot over its span: the turn grows along the whole map, which the
        per-tick correction, eqs 12-14, a local relaxation, takes thousands of passes to spread)
        the correction is solved to its fixed point at once (:meth:`settle`). The re-entries'
        innovation statistics start afresh: they measured the biased odometry."""
        m = self._link.n
        lk = self._link.cols
        turn = change * lk["dt"][:m]
        lk["phi"][:m] -= turn
        lk["theta"][:m] -= 0.5 * turn
        if settle:
            self._turn_along_creation(turn)
            self.settle()
        self._restart_innovations()

    def _turn_along_creation(self, turn: np.ndarray) -> None:
        """Turn every experience's heading by the transitions' heading corrections ``turn``
        (one per link) summed along the links that created the experiences, the current
        experience held: a start for :meth:`settle` within a fraction of a turn of its solution
        even where the bias turned the map by more than half a turn between two visits of a
        place (the settle's residuals are wrapped about the current headings: a loop closure
        whose residual had grown past half a turn was closed the wrong way round)."""
        n, m = self._exp.n, self._link.n
        f, t = self._link.cols["from"][:m], self._link.cols["to"][:m]
        delta = np.zeros(n)
        placed = np.zeros(n, dtype=bool)
        for k in range(m):  # the first link to reach an experience created it (eqs 10-11) ...
            placed[f[k]] = True  # ... unless it left it first (the first experience: a root)
            j = t[k]
            if not placed[j]:
                placed[j] = True
                delta[j] = delta[f[k]] - turn[k]
        anchor = self.current if self.current >= 0 else 0
        th = self._exp.cols["th"][:n]
        th[:] = wrap_angle(th + delta - delta[anchor])

    def _restart_innovations(self) -> None:
        """Re-entries' innovation statistics from scratch: the fusion's noise scale and the
        odometry gate's, fed by the re-entries taken and, once per scene, by those the gate
        refused (``_gate_view`` -2: no scene refused since the latest re-entry)."""
        window = self.config.reentry.innovation_window
        self._innovations = InnovationScale(window)
        self._gate_scale = InnovationScale(window)
        self._gate_view = -2

    def settle(self, heading_passes: int = 3) -> None:
        """The map correction (eqs 12-14, ``correction="stable"``) run to its fixed point, solved
        directly. At the fixed point every experience's link residuals sum to zero: the normal
        equations of least squares over the links, first for the headings (eq 12 does not
        involve the positions; residuals wrapped about the current headings, re-linearised
        ``heading_passes`` times), then for the positions given the headings (eqs 13-14 are
        linear in them). The current experience stays where it is (the residuals fix the map only
        up to a rigid motion), so the robot's pose does not jump."""
        n, m = self._exp.n, self._link.n
        if n < 2 or m == 0:
            return
        ex, lk = self._exp.cols, self._link.cols
        f, t = lk["from"][:m], lk["to"][:m]
        rows = np.arange(m)
        inc = coo_matrix((np.r_[np.ones(m), -np.ones(m)], (np.r_[rows, rows], np.r_[t, f])), shape=(m, n)).tocsr()
        anchor = self.current if self.current >= 0 else 0
        free = np.flatnonzero(np.arange(n) != anchor)
        a = inc[:, free]
        normal = (a.T @ a).tocsc() + 1e-12 * identity(len(free), format="csc")  # a map in pieces stays solvable
        solve = factorized(normal)
        th = ex["th"][:n]
        for _ in range(heading_passes):
            r = wrap_angle(th[t] - th[f] - lk["phi"][:m])
            th[free] -= solve(a.T @ r)
        ang = th[f] + lk["theta"][:m]
        for col, step in (("x", lk["d"][:m] * np.cos(ang)), ("y", lk["d"][:m] * np.sin(ang))):
            p = ex[col][:n]
            r = p[t] - p[f] - step
            p[free] -= solve(a.T @ r)

    # ------------------------------------------------------------------ state i/o
    def get_state(self) -> dict:
        """Arrays that fully describe the map (for save/load)."""
        s = {f"em_{k}": self._exp.view(k).copy() for k in self._exp.cols}
        s.update({f"lk_{k}": self._link.view(k).copy() for k in self._link.cols})
        s["em_current"] = np.array([self.current], dtype=np.int64)
        s["em_acc"] = self._acc.copy()
        s["em_path_noise"] = self._noise.get_state()
        s["em_innovations"] = self._innovations.get_state()
        s["em_gate_scale"] = self._gate_scale.get_state()
        s["em_gate_view"] = np.array([self._gate_view], dtype=np.int64)
        s["em_fix"] = self._fix.copy()
        s["em_path_since_reentry"] = np.array([self._path_since_reentry, self._path_since_enter])
        cand = self._candidate
        s["em_candidate"] = (
            np.array([cand.experience, cand.view, *cand.offset, *cand.odometry]) if cand else np.zeros(0)
        )
        return s

    def set_state(self, s: dict) -> None:
        """Restore a state produced by :meth:`get_state`."""
        self._exp.load({k: s[f"em_{k}"] for k in self._exp.cols})
        self._link.load({k: s[f"lk_{k}"] for k in self._link.cols})
        self.current = int(s["em_current"][0])
        self._acc = np.asarray(s["em_acc"], dtype=float).copy()
        self._noise.set_state(s["em_path_noise"])
        self._innovations.set_state(s["em_innovations"])
        if "em_gate_scale" in s:  # saved before the odometry gate: its scale starts afresh
            self._gate_scale.set_state(s["em_gate_scale"])
            self._gate_view = int(s["em_gate_view"][0])
        self._fix = np.asarray(s["em_fix"], dtype=float).copy()
        self._path_since_reentry, self._path_since_enter = (float(v) for v in s["em_path_since_reentry"])
        c = s["em_candidate"]
        self._candidate = _Candidate(int(c[0]), int(c[1]), _triple(c[2:5]), _triple(c[5:8])) if len(c) else None
        self._divisor_key = None
        self._by_view = {}
        for i, v in enumerate(self.views):
            self._by_view.setdefault(int(v), []).append(i)
        f, t = self._link.view("from"), self._link.view("to")
        self._linked = {(int(min(a, b)), int(max(a, b))) for a, b in zip(f, t)}
        self._neighbours = {}
        for a, b, d in zip(f, t, self._link.view("d")):
            self._add_neighbours(int(a), int(b), float(d))
