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
the previous one if they are not linked yet).

Map correction (eqs 12-14), every tick, all experiences at once (Jacobi)::

    Δθ_i = α_θ [ Σ_j (θ_j - θ_i - φ_ij) + Σ_k (θ_k - θ_i + φ_ki) ]
    Δx_i = α_d [ Σ_j (x_j - d_ij cos(θ_i + θ_ij) - x_i) + Σ_k (x_k + d_ki cos(θ_k + θ_ki) - x_i) ]
    Δy_i = α_d [ Σ_j (y_j - d_ij sin(θ_i + θ_ij) - y_i) + Σ_k (y_k + d_ki sin(θ_k + θ_ki) - y_i) ]

over links ``i -> j`` (from i) and ``k -> i`` (to i). Eq 14 as printed ends its second sum with
``- y_k``; that is a typo for ``- y_i`` (compare eq 13). ``correction="printed"`` uses the sums
as printed (overshoots and diverges where an experience has more than two links);
``correction="stable"`` divides each sum by the experience's number of links (α times the mean
residual), which converges.

The departures from the paper are layers outside this module, each behind its own switch:

- where the robot stands in a re-entered experience (``offset_transitions``):
  :class:`ratslam.entry_offset.EntryOffset`, asked at each re-entry;
- whether and where a re-entry is taken (the path bound, the odometry gate, the loop-closure
  sequence, the re-entry fusion): :class:`ratslam.reentry_policy.ReentryPolicy`, asked at each
  re-entry and told of each tick, experience created and experience entered;
- the yaw-rate bias taken out of the transitions and the map settled:
  :mod:`ratslam.yaw_bias_correction`, acting on the map's arrays;
- which scenes reach the map at all (view confirmation, snap settling):
  :class:`ratslam.view_gate.ViewGate`, in the pipeline.

With every switch off the layers answer as the paper does: the robot on the experience, every
re-entry accepted where the pose cells say. :class:`ratslam.map_layers.MapLayers` keeps the
layers reachable by the names they had on the map.
"""

from __future__ import annotations

import math

import numpy as np

from slamkit.poses import compose, wrap_angle, wrap_scalar

from . import map_kernels
from .columns import Growable
from .config import RatSLAMConfig
from .entry_offset import ON_THE_EXPERIENCE, EntryOffset
from .map_layers import MapLayers
from .reentry_policy import ReentryPolicy, Verdict

__all__ = ["ExperienceMap", "wrap_angle"]

_NO_DIVISOR = np.zeros(0)


class ExperienceMap(MapLayers):
    """Experiences, transitions, their energy (eqs 2-9), creation (eqs 10-11) and the map
    correction (eqs 12-14)."""

    def __init__(self, config: RatSLAMConfig):
        self.config = config
        # map poses as separate x, y, θ columns: contiguous arrays for the per-tick correction
        self._exp = Growable(
            {
                "x": ((), float),
                "y": ((), float),
                "th": ((), float),
                "cell": ((3,), float),
                "view": ((), np.int64),
                "first": ((), np.int64),
                "last": ((), np.int64),
                "degree": ((), float),
            }
        )
        self._link = Growable(
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
        self._grid = np.array(config.shape, dtype=float)
        self._divisor_key: tuple | None = None
        # the layers the map asks at a re-entry (module doc)
        self.entry_offset = EntryOffset(config)
        self.reentry = ReentryPolicy(config, self)

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

    def experience_column(self, key: str) -> np.ndarray:
        """One experience attribute, "x", "y", "th", "cell", "view", "first", "last" or "degree",
        as a view of the map's array: layers that move the map (the yaw-rate correction) write
        through it."""
        return self._exp.view(key)

    def experience_pose(self, j: int):
        """Experience ``j``'s map pose (x, y, θ)."""
        c = self._exp.cols
        return (c["x"][j], c["y"][j], c["th"][j])

    def robot_at(self, j: int, offset) -> tuple[float, float, float]:
        """The map pose of a robot at ``offset`` (forward, left, heading) in ``j``'s frame."""
        return compose(self.experience_pose(j), offset)

    @property
    def links(self) -> np.ndarray:
        return np.stack((self._link.view("from"), self._link.view("to")), axis=1)

    def link_column(self, key: str) -> np.ndarray:
        """One link attribute: "d", "theta", "phi", "dt" (or "from", "to"), as a view of the
        map's array."""
        return self._link.view(key)

    @property
    def offset(self) -> tuple[float, float, float]:
        """The odometry accumulated since the current experience was entered, in its frame."""
        ax, ay, aphi, _ = self._acc
        return (float(ax), float(ay), float(aphi))

    @property
    def pose(self) -> tuple[float, float, float]:
        """Current pose: the current experience's map pose composed with the odometry
        accumulated since it was entered (the origin before the first experience)."""
        ax, ay, aphi, _ = self._acc
        if self.current < 0:
            return (float(ax), float(ay), float(wrap_scalar(aphi)))
        cols = self._exp.cols
        x, y, th = cols["x"][self.current], cols["y"][self.current], cols["th"][self.current]
        c, s = math.cos(th), math.sin(th)
        return (float(x + c * ax - s * ay), float(y + s * ax + c * ay), float(wrap_scalar(th + aphi)))

    # ------------------------------------------------------------------ odometry
    def integrate(self, dt: float, v_trans: float, v_rot: float) -> None:
        """Accumulate wheel odometry since the current experience was entered."""
        acc = self._acc
        acc[2] += v_rot * dt
        acc[0] += v_trans * dt * math.cos(acc[2])
        acc[1] += v_trans * dt * math.sin(acc[2])
        acc[3] += dt
        self.reentry.integrate(dt, v_trans, v_rot)

    # ------------------------------------------------------------------ eqs 2-9
    def energy(self, peak_cell: np.ndarray, view: int, ids: np.ndarray | None = None) -> np.ndarray:
        """Energy E_i (eqs 2-9) of experiences ``ids`` (default: all) for a peak and a view
        (compiled: :func:`ratslam.map_kernels.energy`)."""
        cfg = self.config.experience_map
        if ids is None:
            ids = np.arange(self._exp.n)
        cols = self._exp.cols
        return map_kernels.energy(
            cols["cell"],
            cols["view"],
            np.asarray(ids, dtype=np.int64),
            np.asarray(peak_cell, dtype=float),
            self._grid,
            int(view),
            float(cfg.r_inf_cells),
            float(cfg.theta_inf_cells),
            cfg.energy != "sum",
        )

    # ------------------------------------------------------------------ eqs 10-11
    def update(self, tick: int, peak_cell: np.ndarray, view: int) -> str:
        """Experience selection for this tick. ``view`` is the scene number (-1: no view, which
        never switches or creates experiences). The most energetic experience becomes current
        (the re-entry policy may refuse or hold it: the next one is asked); none with positive
        energy: a new one (eqs 10-11). Returns "none", "create" or "switch"."""
        if view < 0:
            return "none"
        ids = self._by_view.get(int(view))
        if ids:
            ids_arr = np.asarray(ids)
            e = self.energy(peak_cell, view, ids_arr)
            for k in np.argsort(-e, kind="stable"):  # most energetic first (eq 9)
                if e[k] <= 0.0:
                    break
                j = int(ids_arr[k])
                if j == self.current:
                    self.reentry.declined(view)
                    return "none"
                offset = self.entry_offset(self._exp.cols["cell"][j], peak_cell)
                if self.reentry.judge(j, offset, view) is Verdict.ACCEPT:
                    self._switch(j, tick, offset)
                    return "switch"
            self.reentry.declined(view)
        # eqs 10-11: no experience with positive energy (or none the re-entry policy accepts)
        j = self._new_experience(tick, peak_cell, view)
        if self.current >= 0:
            self._add_link(self.current, j)
        self._enter(j, tick)
        return "create"

    def add_experience(self, pose, cell, view: int, tick: int) -> int:
        """Append an experience with a given map pose, pose-cell coordinates and view; returns
        its index (eqs 10-11 call this with the current pose)."""
        x, y, th = (float(v) for v in pose)
        j = self._exp.append(x=x, y=y, th=th, cell=cell, view=view, first=tick, last=tick)
        self.reentry.created(j)
        self._by_view.setdefault(int(view), []).append(j)
        return j

    def _new_experience(self, tick: int, peak_cell: np.ndarray, view: int) -> int:
        return self.add_experience(self.pose, peak_cell, view, tick)

    def _switch(self, j: int, tick: int, offset) -> None:
        """Re-enter ``j``, the robot at ``offset`` in its frame (where the re-entry policy puts
        it)."""
        offset = self.reentry.accept(j, offset)
        if self.current >= 0:
            self._add_link(self.current, j, offset)
        self._enter(j, tick, offset)

    def _enter(self, j: int, tick: int, offset=ON_THE_EXPERIENCE) -> None:
        """Make ``j`` current; the robot is at ``offset`` in its frame."""
        self.current = j
        self._exp.cols["last"][j] = tick
        self._acc[:3] = offset
        self._acc[3] = 0.0
        self.reentry.entered(j)

    # ------------------------------------------------------------------ transitions
    def _add_link(self, i: int, j: int, offset=ON_THE_EXPERIENCE) -> None:
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
                "phi": wrap_scalar(aphi),
                "dt": at,
            }
        )
        self._linked.add(key)
        deg = self._exp.cols["degree"]
        deg[i] += 1.0
        deg[j] += 1.0
        return True

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

    # ------------------------------------------------------------------ state i/o
    def get_state(self) -> dict:
        """Arrays that fully describe the map and its re-entry policy (for save/load)."""
        s = {**self._exp.state("em_"), **self._link.state("lk_")}
        s["em_current"] = np.array([self.current], dtype=np.int64)
        s["em_acc"] = self._acc.copy()
        s.update(self.reentry.get_state())
        return s

    def set_state(self, s: dict) -> None:
        """Restore a state produced by :meth:`get_state`."""
        self._exp.load_state(s, "em_")
        self._link.load_state(s, "lk_")
        self.current = int(s["em_current"][0])
        self._acc = np.asarray(s["em_acc"], dtype=float).copy()
        self.reentry.set_state(s)
        self._divisor_key = None
        self._by_view = {}
        for i, v in enumerate(self.views):
            self._by_view.setdefault(int(v), []).append(i)
        f, t = self._link.view("from"), self._link.view("to")
        self._linked = {(int(min(a, b)), int(max(a, b))) for a, b in zip(f, t)}
