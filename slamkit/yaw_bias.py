"""A constant yaw-rate (gyro) bias searched from the odometry of repeated scene numbers.

Used by both systems: the pose graph (``PoseGraphConfig.yaw_bias``) and RatSLAM
(``RatSLAMConfig.yaw_bias``; see :mod:`ratslam.yaw_bias_correction`). Both configure it with the
fields of :class:`YawBiasSearchConfig` (deg/s, as a user writes them), converted to rad/s here.

The search runs outside any graph, on the odometry and scene numbers alone:

* The stream is cut into short chunks (at every scene onset, and at most ``CHUNK_MAX_S``
  seconds long).  For every candidate bias b on a grid (``-search_max_deg_s ..
  +search_max_deg_s`` in steps of ``search_step_deg_s``) the raw odometry re-integrated with
  ``(w - b)`` is kept as a prefix sum of complex chord vectors, so the relative pose between any
  two chunk ends is O(1) per candidate: the chord of chunk m, measured in its start frame, is
  turned by the corrected heading ``Theta_m - b (t_m + tau_m / 2)`` (the bias bends a chunk of
  duration tau_m by b tau_m; its chord turns by half of that to first order).
* A *revisit* is a scene onset (the first tick of a scene number, -1 excluded) whose scene
  number had an onset at least ``min_travel_m`` of path and at most ``search_max_span_s``
  seconds earlier.  Re-integrated with b, the loop between the two sightings should close: its
  residual ``r^2(b) = |dp|^2 / s_xy^2 + wrap(dtheta)^2 / s_th^2`` uses the caller's sigmas (one
  scene cell, one heading sector).
* Each revisit (a pair of sightings: an onset with several earlier sightings in range makes
  several) scores ``rho(b) = r^2 / (k^2 + r^2)`` (Geman-McClure, capped at 1), so a
  false-positive or aliased scene costs at most 1 whatever b is, and the cost ``C(b)`` summed
  over revisits is minimised.
* A bias b* is adopted (replacing the current b_c, 0 at first) only when it is an interior
  minimum of the grid, lowers C by at least ``search_min_gain`` and by ``NOISE_GAIN``
  sqrt(revisits), and at least two revisits that are inliers at b* (r < k) but outliers at
  b_c, and whose time spans overlap by less than half the shorter, agree on it.  Once a bias is
  adopted, the cost's minimum moving by half a grid step or more (at most ``REFINE_RAD_S``)
  refines it when that gains ``search_min_gain``.
* The search range must stay below the alias of the loops driven: a loop of T seconds closes
  about as well at b and at b - 360 / T deg/s.
* A *standstill* (at least ``STILL_MIN_S`` seconds of consecutive ticks with speed at most
  ``search_still_m_s``; 0 = off) whose mean yaw rate m lies within the search range measures the
  bias directly, before any place is revisited: the robot is not turning, so the gyro reads its
  bias plus noise. It adds ``(b - m)^2 / (k^2 s_m^2)`` to C(b) (the small-residual form of a
  revisit's cost, with s_m the standard error of the mean, at least half a grid step), and a
  bias it moves the minimum to is adopted when that gains ``search_min_gain`` (a measurement,
  not a chance agreement of revisits: no noise gain, no two revisits needed). A turn on the
  spot (the simulator's 60 deg/s) lies outside the range and is ignored.

Why each rule and default is what it is, with the measurements, is in docs/configuration.md
(pose graph: yaw-rate bias). Only odometry and scene numbers are used, never ground truth;
everything is a deterministic function of the stream.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .arcs import integrate
from .config_fields import check_fields, param

CHUNK_MAX_S = 1.0
"""Longest chunk (s): keeps the bias's bend of a chunk small (10 deg/s bends 1 s by 10 deg)."""
NOISE_GAIN = 0.5
"""The gain must also reach this times sqrt(revisits): what N chance (false-positive or aliased)
revisits can do to the cost difference of two biases (measured in docs/configuration.md)."""
REFINE_RAD_S = math.radians(0.25)
"""An adopted bias moves by at most this with only ``search_min_gain`` (a refinement)."""
MAX_PAIR_RECORDS = 2000
"""Most recent revisits whose residual curves are kept for the agreement check."""
STILL_MIN_S = 2.0
"""Shortest standstill (s) whose mean yaw rate is taken as a measurement of the bias."""
STILL_MODEL_RAD_S = math.radians(0.1)
"""Least standard error of a standstill's bias: at rest the odometry's yaw rate holds the gyro's
bias alone, moving also what the wheels or the gyro's scale add (Plaza 2 at rest reads
-0.397 +- 0.003 deg/s, its revisits -0.29)."""


@dataclass(frozen=True)
class _Onset:
    scene: int
    time: float
    path: float
    row: int  # index of the chunk end (prefix row) at the onset


class YawBiasSearch:
    """Grid search of a constant yaw-rate bias from revisited scene numbers.

    Feed every tick with :meth:`add`; it returns a bias (rad/s) when one is adopted, else
    None.  ``bias`` is the adopted bias (0 until one is).
    """

    def __init__(
        self,
        max_rad_s: float,
        step_rad_s: float,
        max_span_s: float,
        min_travel_m: float,
        sigma_xy_m: float,
        sigma_theta_rad: float,
        kernel: float,
        min_gain: float,
        still_m_s: float = 0.0,
    ) -> None:
        n = int(math.floor(max_rad_s / step_rad_s + 1e-9))
        self.grid = step_rad_s * np.arange(-n, n + 1, dtype=float)
        self._step = step_rad_s
        self._max_span = max_span_s
        self._min_travel = min_travel_m
        self._inv_sxy2 = 1.0 / sigma_xy_m**2
        self._inv_sth2 = 1.0 / sigma_theta_rad**2
        self._k2 = kernel**2
        self._min_gain = min_gain
        self._still_speed = still_m_s
        self._still = [0.0, 0.0, 0.0, 0.0]  # current standstill: ticks, seconds, sum w, sum w^2
        self.standstills = 0  # standstills that added to the cost
        self.cost = np.zeros_like(self.grid)  # C(b) over the grid
        self.revisits = 0  # onsets that scored (had an earlier sighting in range)
        self.bias = 0.0
        self._time = 0.0
        self._path = 0.0
        self._theta = 0.0  # raw (uncorrected) integrated heading
        self._prev_scene = -1
        self._chunk: tuple[list[float], list[float], list[float]] = ([], [], [])
        self._chunk_start = 0.0
        self._prefix = np.zeros(len(self.grid), dtype=complex)
        # prefix rows kept only as far back as a revisit can reach: row -> (sum, theta, time)
        self._rows: deque[tuple[int, np.ndarray, float, float]] = deque()
        self._rows.append((0, self._prefix.copy(), 0.0, 0.0))
        self._row = 0
        self._onsets: dict[int, deque[_Onset]] = {}
        self._pairs: deque[tuple[float, float, np.ndarray]] = deque(maxlen=MAX_PAIR_RECORDS)

    @property
    def time(self) -> float:
        """Seconds of odometry fed so far."""
        return self._time

    # ---------------------------------------------------------------- feeding
    def add(self, dt: float, v: float, w: float, scene: int) -> float | None:
        """One tick (raw odometry, scene number after it); a newly adopted bias or None."""
        dts, vs, ws = self._chunk
        dts.append(dt)
        vs.append(v)
        ws.append(w)
        self._time += dt
        self._path += abs(v * dt)
        adopted = None
        if abs(v) <= self._still_speed:
            st = self._still
            st[0] += 1.0
            st[1] += dt
            st[2] += w
            st[3] += w * w
        elif self._still[0]:
            adopted = self._close_standstill()
        onset = scene != -1 and scene != self._prev_scene
        self._prev_scene = scene
        if onset or self._time - self._chunk_start >= CHUNK_MAX_S:
            self._close_chunk()
        if not onset:
            return adopted
        found = self._onset(scene)
        return found if found is not None else adopted

    def _close_standstill(self) -> float | None:
        """Score the standstill that just ended (module doc); a bias it makes adopted, or None."""
        n, seconds, sw, sww = self._still
        self._still = [0.0, 0.0, 0.0, 0.0]
        if seconds < STILL_MIN_S or n < 3:
            return None
        m = sw / n
        if abs(m) > self.grid[-1]:
            return None  # a turn on the spot, not a bias
        var = max(0.0, (sww - n * m * m) / (n - 1.0))
        se2 = max(var / n, STILL_MODEL_RAD_S**2)
        self.cost += (self.grid - m) ** 2 / (self._k2 * se2)
        self.standstills += 1
        b, interior = self.best()
        if not interior or abs(b - self.bias) < 0.5 * self._step:
            return None
        if self._at(self.cost, self.bias) - self._at(self.cost, b) < self._min_gain:
            return None
        self.bias = b
        return b

    def _close_chunk(self) -> None:
        dts, vs, ws = self._chunk
        dx, dy, dth = integrate(np.asarray(dts), np.asarray(vs), np.asarray(ws))
        tau = self._time - self._chunk_start
        # chord in the chunk's start frame, turned by the corrected heading at the chunk's middle
        phase = self._theta - self.grid * (self._chunk_start + 0.5 * tau)
        self._prefix = self._prefix + complex(dx, dy) * np.exp(1j * phase)
        self._theta += float(dth)
        self._row += 1
        self._rows.append((self._row, self._prefix, self._theta, self._time))
        while self._rows and self._rows[0][3] < self._time - self._max_span:
            self._rows.popleft()
        self._chunk = ([], [], [])
        self._chunk_start = self._time

    def _onset(self, scene: int) -> float | None:
        here = _Onset(scene, self._time, self._path, self._row)
        earlier = self._onsets.setdefault(scene, deque())
        while earlier and earlier[0].time < self._time - self._max_span:
            earlier.popleft()
        first_row = self._rows[0][0]
        scored = 0
        for prev in earlier:
            if self._path - prev.path < self._min_travel or prev.row < first_row:
                continue
            r2 = self._residual2(prev)
            self._pairs.append((prev.time, self._time, r2))
            self.cost += r2 / (self._k2 + r2)
            scored += 1
        earlier.append(here)
        if not scored:
            return None
        self.revisits += scored
        return self._decide()

    def _residual2(self, prev: _Onset) -> np.ndarray:
        """r^2(b) over the grid for the loop from ``prev`` to the current chunk end."""
        _, p0, th0, t0 = self._rows[prev.row - self._rows[0][0]]
        rel = (self._prefix - p0) * np.exp(-1j * (th0 - self.grid * t0))
        dth = (self._theta - th0) - self.grid * (self._time - t0)
        dth = (dth + math.pi) % (2.0 * math.pi) - math.pi
        return (rel.real**2 + rel.imag**2) * self._inv_sxy2 + dth**2 * self._inv_sth2

    # ---------------------------------------------------------------- state i/o
    def get_state(self) -> dict[str, np.ndarray]:
        """Arrays that fully describe the search (keys ``yb_*``), for a saved RatSLAM state."""
        g = len(self.grid)
        onsets = [o for q in self._onsets.values() for o in q]
        pairs = list(self._pairs)
        return {
            "yb_scalars": np.array(
                [
                    self.revisits,
                    self.bias,
                    self._time,
                    self._path,
                    self._theta,
                    self._prev_scene,
                    self._chunk_start,
                    self._row,
                    self.standstills,
                    *self._still,
                ],
                dtype=float,
            ),
            "yb_cost": self.cost.copy(),
            "yb_prefix": self._prefix.copy(),
            "yb_chunk": np.array(self._chunk, dtype=float).reshape(3, -1),
            "yb_rows_index": np.array([r[0] for r in self._rows], dtype=np.int64),
            "yb_rows_prefix": np.array([r[1] for r in self._rows], dtype=complex).reshape(-1, g),
            "yb_rows_theta_time": np.array([(r[2], r[3]) for r in self._rows], dtype=float).reshape(-1, 2),
            "yb_onsets": np.array([(o.scene, o.time, o.path, o.row) for o in onsets], dtype=float).reshape(-1, 4),
            "yb_pairs_span": np.array([(p[0], p[1]) for p in pairs], dtype=float).reshape(-1, 2),
            "yb_pairs_r2": np.array([p[2] for p in pairs], dtype=float).reshape(-1, g),
        }

    def set_state(self, s: dict) -> None:
        """Restore a state produced by :meth:`get_state` (same configuration)."""
        sc = s["yb_scalars"]
        self.revisits, self.bias, self._time, self._path, self._theta = int(sc[0]), *(float(v) for v in sc[1:5])
        self._prev_scene, self._chunk_start, self._row = int(sc[5]), float(sc[6]), int(sc[7])
        # a state saved before standstills were scored has none
        self.standstills = int(sc[8]) if len(sc) > 8 else 0
        self._still = [float(x) for x in sc[9:13]] if len(sc) >= 13 else [0.0, 0.0, 0.0, 0.0]
        self.cost = np.array(s["yb_cost"], dtype=float)
        self._prefix = np.array(s["yb_prefix"], dtype=complex)
        chunk = s["yb_chunk"]
        self._chunk = (chunk[0].tolist(), chunk[1].tolist(), chunk[2].tolist())
        tt = s["yb_rows_theta_time"]
        self._rows = deque(
            (int(i), np.array(p, dtype=complex), float(th), float(t))
            for i, p, (th, t) in zip(s["yb_rows_index"], s["yb_rows_prefix"], tt)
        )
        self._onsets = {}
        for scene, t, path, row in s["yb_onsets"]:
            self._onsets.setdefault(int(scene), deque()).append(_Onset(int(scene), float(t), float(path), int(row)))
        self._pairs = deque(
            (
                (float(a), float(b), np.array(r2, dtype=float))
                for (a, b), r2 in zip(s["yb_pairs_span"], s["yb_pairs_r2"])
            ),
            maxlen=MAX_PAIR_RECORDS,
        )

    # ---------------------------------------------------------------- deciding
    def best(self) -> tuple[float, bool]:
        """The grid bias of least cost (ties to the smaller |b|), refined by a parabola, and
        whether it is an interior minimum (one at the edge of the range may lie beyond it)."""
        c = self.cost
        i = int(np.lexsort((np.abs(self.grid), c))[0])
        if 0 < i < len(c) - 1:
            den = c[i - 1] - 2.0 * c[i] + c[i + 1]
            if den > 0.0:
                return float(self.grid[i] + 0.5 * self._step * (c[i - 1] - c[i + 1]) / den), True
            return float(self.grid[i]), True
        return float(self.grid[i]), False

    def _at(self, curve: np.ndarray, b: float) -> float:
        return float(np.interp(b, self.grid, curve))

    def _decide(self) -> float | None:
        b, interior = self.best()
        if not interior or abs(b - self.bias) < 0.5 * self._step:
            return None
        gain = self._at(self.cost, self.bias) - self._at(self.cost, b)
        if self.bias != 0.0 and abs(b - self.bias) <= REFINE_RAD_S:
            # Refining an adopted bias within its basin: the evidence that there is a bias is
            # in; the least cost of all revisits so far says where it is.
            if gain < self._min_gain:
                return None
            self.bias = b
            return b
        if gain < max(self._min_gain, NOISE_GAIN * math.sqrt(self.revisits)):
            return None
        support = [(t0, t1) for t0, t1, r2 in self._pairs if self._at(r2, b) < self._k2 <= self._at(r2, self.bias)]
        if not _two_apart(support):
            return None
        self.bias = b
        return b


def _two_apart(spans: list[tuple[float, float]]) -> bool:
    """Whether two of the time spans overlap by less than half the shorter of the two."""
    if len(spans) < 2:
        return False
    a = np.asarray(spans, dtype=float)
    s, e = a[:, 0], a[:, 1]
    overlap = np.maximum(0.0, np.minimum(e[:, None], e[None, :]) - np.maximum(s[:, None], s[None, :]))
    shorter = np.minimum((e - s)[:, None], (e - s)[None, :])
    apart = overlap < 0.5 * shorter
    np.fill_diagonal(apart, False)
    return bool(apart.any())


@dataclass(frozen=True)
class YawBiasSearchConfig:
    """The search's fields, in one unit system (deg/s, as users write them): the base of both
    systems' ``yaw_bias`` configurations (``ratslam.YawBiasConfig``, ``baselines.YawBiasConfig``),
    which add what the search needs from their own models (how far apart and how well a scene
    places the robot) and their own fields."""

    SECTION: ClassVar[str] = "yaw_bias"

    search: bool = True
    """Search the bias and, once one is adopted, take it off the odometry."""
    search_max_deg_s: float = param(3.0, gt=0)
    """Largest |bias| searched (below the alias 360 / lap time of the loops driven)."""
    search_step_deg_s: float = param(0.05, gt=0)
    """Grid step of the search (the minimum is refined by a parabola)."""
    search_max_span_s: float = param(300.0, gt=0)
    """Longest time between two sightings of a scene that still scores a revisit."""
    search_kernel: float = param(3.0, gt=0)
    """Geman-McClure width (Mahalanobis units) of a revisit's cost; r < this is an inlier."""
    search_min_gain: float = param(4.0, gt=0)
    """A bias is adopted only if it lowers the summed revisit cost by at least this."""
    search_still_m_s: float = param(0.04, ge=0)
    """Speeds at or below this are a standstill, whose mean yaw rate measures the bias (four
    times the simulator's speed noise; 0 = standstills not used)."""

    def __post_init__(self) -> None:
        check_fields(self)

    def bias_search(self, min_travel_m: float, sigma_xy_m: float, sigma_theta_rad: float) -> YawBiasSearch:
        """The search these fields configure (degrees converted to radians), scoring revisits at
        least ``min_travel_m`` of path apart with a scene's sigmas ``sigma_xy_m`` (per axis) and
        ``sigma_theta_rad``."""
        return YawBiasSearch(
            max_rad_s=math.radians(self.search_max_deg_s),
            step_rad_s=math.radians(self.search_step_deg_s),
            max_span_s=self.search_max_span_s,
            min_travel_m=min_travel_m,
            sigma_xy_m=sigma_xy_m,
            sigma_theta_rad=sigma_theta_rad,
            kernel=self.search_kernel,
            min_gain=self.search_min_gain,
            still_m_s=self.search_still_m_s,
        )
