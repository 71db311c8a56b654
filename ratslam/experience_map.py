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
"""

from __future__ import annotations

import math

import numpy as np

from .config import RatSLAMConfig

_PI = math.pi


def wrap_angle(a):
    """Wrap radians into [-π, π)."""
    return (np.asarray(a) + _PI) % (2.0 * _PI) - _PI


def _wrap_scalar(a: float) -> float:
    return (a + _PI) % (2.0 * _PI) - _PI


class _Growable:
    """Column arrays with amortised O(1) append."""

    def __init__(self, spec: dict[str, tuple[tuple, type]]):
        self._spec = spec
        self.n = 0
        self._cap = 64
        self.cols = {k: np.zeros((self._cap,) + shape, dtype=dt) for k, (shape, dt) in spec.items()}

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
        self._exp = _Growable({"pose": ((3,), float), "cell": ((3,), float), "view": ((), np.int64),
                               "first": ((), np.int64), "last": ((), np.int64), "degree": ((), float)})
        self._link = _Growable({"from": ((), np.int64), "to": ((), np.int64), "d": ((), float),
                                "theta": ((), float), "phi": ((), float), "dt": ((), float)})
        self._by_view: dict[int, list[int]] = {}
        self._linked: set[tuple[int, int]] = set()
        self.current = -1
        # odometry accumulated since the current experience was entered, in its frame
        self._acc = np.zeros(4)  # x, y, phi, t
        self._grid = np.array(config.shape, dtype=float)

    # ------------------------------------------------------------------ read access
    @property
    def size(self) -> int:
        return self._exp.n

    @property
    def poses(self) -> np.ndarray:
        return self._exp.view("pose")

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
        x, y, th = self._exp.cols["pose"][self.current]
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

    # ------------------------------------------------------------------ eqs 2-9
    def energy(self, peak_cell: np.ndarray, view: int, ids: np.ndarray | None = None) -> np.ndarray:
        """Energy E_i (eqs 2-9) of experiences ``ids`` (default: all) for a peak and a view."""
        cfg = self.config
        if ids is None:
            ids = np.arange(self._exp.n)
        cells = self._exp.cols["cell"][ids]
        d = np.abs(cells - peak_cell)
        d = np.minimum(d, self._grid - d)                                  # wrap-aware
        r = np.sqrt(d[:, 0] ** 2 + d[:, 1] ** 2)                           # eq 3
        e_xy = np.maximum(1.0 - r / cfg.r_inf, 0.0)                        # eq 2
        e_th = np.maximum(1.0 - d[:, 2] / cfg.theta_inf, 0.0)              # eqs 4-5
        e_v = (self._exp.cols["view"][ids] == view).astype(float)          # eqs 6-8
        if cfg.energy == "sum":
            return e_v * (e_xy + e_th)                                     # eq 9
        return e_v * e_xy * e_th

    # ------------------------------------------------------------------ eqs 10-11
    def _new_experience(self, tick: int, peak_cell: np.ndarray, view: int) -> int:
        pose = self.pose
        j = self._exp.append(pose=pose, cell=peak_cell, view=view, first=tick, last=tick)
        self._by_view.setdefault(int(view), []).append(j)
        return j

    def _add_link(self, i: int, j: int) -> None:
        key = (min(i, j), max(i, j))
        if i == j or key in self._linked:
            return
        ax, ay, aphi, at = self._acc
        self._link.append(**{"from": i, "to": j, "d": math.hypot(ax, ay), "theta": math.atan2(ay, ax),
                             "phi": _wrap_scalar(aphi), "dt": at})
        self._linked.add(key)
        deg = self._exp.cols["degree"]
        deg[i] += 1.0
        deg[j] += 1.0

    def update(self, tick: int, peak_cell: np.ndarray, view: int) -> str:
        """Experience selection for this tick. ``view`` is the scene number (-1: no view, which
        never switches or creates experiences). Returns "none", "create" or "switch"."""
        if view < 0:
            return "none"
        ids = self._by_view.get(int(view))
        best, best_e = -1, 0.0
        if ids:
            ids_arr = np.asarray(ids)
            e = self.energy(peak_cell, view, ids_arr)
            k = int(np.argmax(e))
            best, best_e = int(ids_arr[k]), float(e[k])
        if best_e <= 0.0:                                                   # eqs 10-11
            j = self._new_experience(tick, peak_cell, view)
            if self.current >= 0:
                self._add_link(self.current, j)
            self._enter(j, tick)
            return "create"
        if best != self.current:
            if self.current >= 0:
                self._add_link(self.current, best)
            self._enter(best, tick)
            return "switch"
        return "none"

    def _enter(self, j: int, tick: int) -> None:
        self.current = j
        self._exp.cols["last"][j] = tick
        self._acc[:] = 0.0

    # ------------------------------------------------------------------ eqs 12-14
    def link_residuals(self) -> np.ndarray:
        """Per link i -> j: (x_j - x̂_j, y_j - ŷ_j, wrap(θ_j - θ_i - φ_ij)), where x̂_j, ŷ_j is
        where i's map pose and the link put j."""
        lk = self._link
        m = lk.n
        if m == 0:
            return np.zeros((0, 3))
        pose = self._exp.cols["pose"]
        fi, tj = lk.cols["from"][:m], lk.cols["to"][:m]
        pi, pj = pose[fi], pose[tj]
        ang = pi[:, 2] + lk.cols["theta"][:m]
        rx = pj[:, 0] - pi[:, 0] - lk.cols["d"][:m] * np.cos(ang)
        ry = pj[:, 1] - pi[:, 1] - lk.cols["d"][:m] * np.sin(ang)
        rt = wrap_angle(pj[:, 2] - pi[:, 2] - lk.cols["phi"][:m])
        return np.stack((rx, ry, rt), axis=1)

    def correct(self) -> None:
        """One pass of eqs 12-14 over all links (vectorised, simultaneous update)."""
        n, m = self._exp.n, self._link.n
        if m == 0:
            return
        cfg = self.config
        res = self.link_residuals()
        fi = self._link.cols["from"][:m]
        tj = self._link.cols["to"][:m]
        delta = np.empty((n, 3))
        for c in range(3):
            # a link i -> j adds +residual to i (eq term over j) and -residual to j (term over k)
            delta[:, c] = np.bincount(fi, res[:, c], minlength=n) - np.bincount(tj, res[:, c], minlength=n)
        if cfg.correction == "stable":
            deg = self._exp.cols["degree"][:n]
            delta /= np.maximum(deg, 1.0)[:, None]
        pose = self._exp.cols["pose"]
        pose[:n, 0] += cfg.alpha_d * delta[:, 0]
        pose[:n, 1] += cfg.alpha_d * delta[:, 1]
        pose[:n, 2] = wrap_angle(pose[:n, 2] + cfg.alpha_theta * delta[:, 2])

    # ------------------------------------------------------------------ state i/o
    def get_state(self) -> dict:
        """Arrays that fully describe the map (for save/load)."""
        s = {f"em_{k}": self._exp.view(k).copy() for k in self._exp.cols}
        s.update({f"lk_{k}": self._link.view(k).copy() for k in self._link.cols})
        s["em_current"] = np.array([self.current], dtype=np.int64)
        s["em_acc"] = self._acc.copy()
        return s

    def set_state(self, s: dict) -> None:
        """Restore a state produced by :meth:`get_state`."""
        self._exp.load({k: s[f"em_{k}"] for k in self._exp.cols})
        self._link.load({k: s[f"lk_{k}"] for k in self._link.cols})
        self.current = int(s["em_current"][0])
        self._acc = np.asarray(s["em_acc"], dtype=float).copy()
        self._by_view = {}
        for i, v in enumerate(self.views):
            self._by_view.setdefault(int(v), []).append(i)
        f, t = self._link.view("from"), self._link.view("to")
        self._linked = {(int(min(a, b)), int(max(a, b))) for a, b in zip(f, t)}
