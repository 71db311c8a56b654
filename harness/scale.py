"""Configurations derived from the scale of an observation log (speed, tick rate, labels).

The defaults of :class:`~ratslam.RatSLAMConfig` and :class:`~baselines.PoseGraphConfig` are
tuned to the simulated indoor robot: 0.3 m/s at 7 Hz (0.043 m per tick), scene numbers that
persist over about 1 m, odometry noise 0.01 m/s and 0.01 rad/s per tick. A replayed log may come
from a vehicle at another speed, tick rate and label granularity. :func:`derive_configs` measures
the log -- from ``dt``, ``v_trans``, ``v_rot`` and ``scene_id`` only, never the ground truth --
and scales the distance- and tick-dependent parameters.

Measured quantities (:func:`measure_log`):
  step: median moving speed (ticks faster than 10% of the 95th-percentile speed) times the
    median ``dt``: metres per tick.
  label length: distance-weighted median of the distance driven while one scene number is
    reported on consecutive ticks (each run weighted by its length, so the short runs that
    flicker at cell borders weigh little). Simulated 1 m scene cells: 0.85-0.91 m; the Plaza
    logs' 2 m cells: 1.88-2.00 m.
  odometry noise: per-tick white noise on the speed and the yaw rate, 1.4826 MAD of the
    first differences / sqrt(2) (the simulator's 0.01 m/s and 0.01 rad/s read 0.011).

Each ratio to the reference is rounded to the ladder of powers of sqrt(2) (:func:`ladder`), so
a log within a factor 2**0.25 (0.84-1.19) of the reference gets the reference value exactly:
the simulator's own streams get exactly the defaults. The rules:

  Pose graph (scene factor s = label length / 0.9 m, laddered):
    keyframe_distance = 0.5 m * s        (two keyframes per scene cell)
    closure_sigma_xy  = s / sqrt(6) m    (a closure is known to within one scene cell,
                                          uniform over a cell of side s: s / sqrt(6) per axis)
    closure_min_travel = 4 m * s
    odom_sigma_v, odom_sigma_w = 0.01 * laddered noise ratio
  RatSLAM (cells per tick c = laddered step / cell_size_m):
    pc_trans_gain: the lattice-lag compensation depends on c. Measured packet speed / applied
      shift of the default network (straight runs, headings 0 and 35 deg): 0.96/0.95 at 0.17
      cells per tick, 0.97/0.96 at 0.3, 0.99/0.97 at 0.4, 1.00/0.99 at 0.6, 1.00 at 0.8 and
      1.0, 0.99 at 1.4. Gain 1.05 up to 0.2 cells per tick, 1.0 from 0.6, linear between.
    cell_size_m: 0.25 m while the packet moves at most MAX_CELLS_PER_TICK (1.5) cells per tick
      (its speed is still within 1% of the shift at 1.4); above, the cell grows to keep 1.5.
  Everything else keeps its default, also the tick-based windows and the zones of influence,
  because scaling them with the log did not help (measured on Plaza 1, experience-map ATE,
  seeds 0 / 1, odometry 1.47 m; pc_trans_gain 1.0 throughout): defaults 1.33 / 1.62 m;
  view_min_age_ticks and snap_settle_ticks kept in metres (15 and 11 ticks) 1.47 / 2.40 m; the
  fatigue rates too 2.22 / 1.47 m; r_inf 4 cells (1 m, half the 2 m scene) - / 5.47 m; pose
  cells of 1.0 m (0.2 cells per tick, r_inf 2 m) 6.50 / - m, of 1.17 m 8.21 / - m (re-entries
  within a 2 m zone carry heading offsets up to 20 deg, which rotate the map behind them).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from baselines import PoseGraphConfig
from ratslam import RatSLAMConfig

REFERENCE_STEP_M = 0.3 / 7.0
"""Metres per tick of the simulated robot (0.3 m/s at 7 Hz)."""
REFERENCE_LABEL_LENGTH_M = 0.9
"""Label length (see :func:`measure_log`) of the simulator's 1 m scene cells."""
REFERENCE_NOISE = 0.01
"""Per-tick odometry noise of the simulator, m/s and rad/s."""
MAX_CELLS_PER_TICK = 1.5
GAIN_SLOW, GAIN_FAST = (0.2, 1.05), (0.6, 1.0)   # (cells per tick, pc_trans_gain)


@dataclass(frozen=True)
class LogScale:
    """What :func:`measure_log` reads from a log (no ground truth)."""

    dt: float                 # median tick, s
    speed: float              # median moving speed, m/s
    step: float               # speed * dt, m per tick
    label_length: float       # distance-weighted median run of one scene number, m
    sigma_v: float            # per-tick speed noise, m/s
    sigma_w: float            # per-tick yaw-rate noise, rad/s


def ladder(ratio: float) -> float:
    """``ratio`` rounded to the nearest power of sqrt(2) (in log scale); 1 for 0.84-1.19."""
    if not (math.isfinite(ratio) and ratio > 0):
        return 1.0
    return 2.0 ** (round(2.0 * math.log2(ratio)) / 2.0)


def _noise(x: np.ndarray) -> float:
    d = np.diff(x)
    if d.size < 2:
        return float("nan")
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2.0))


def measure_log(log) -> LogScale:
    """Speed, tick, label length and odometry noise of an observation log, from ``dt``,
    ``v_trans``, ``v_rot`` and ``scene_id`` only."""
    dt_all = np.asarray(log.dt, float)
    v = np.abs(np.asarray(log.v_trans, float))
    dt = float(np.median(dt_all))
    moving = v > 0.1 * np.percentile(v, 95) if v.size else np.zeros(0, bool)
    speed = float(np.median(v[moving])) if moving.any() else 0.0
    dist = np.concatenate(([0.0], np.cumsum(v * dt_all)))
    s = np.asarray(log.scene_id)
    label_length = float("nan")
    if s.size:
        start = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
        end = np.r_[start[1:], s.size]
        runs = (dist[end] - dist[start])[s[start] >= 0]
        runs = np.sort(runs[runs > 0])
        if runs.size:
            cum = np.cumsum(runs)
            label_length = float(runs[np.searchsorted(cum, 0.5 * cum[-1])])
    return LogScale(dt=dt, speed=speed, step=speed * dt, label_length=label_length,
                    sigma_v=_noise(np.asarray(log.v_trans, float)), sigma_w=_noise(np.asarray(log.v_rot, float)))


def trans_gain(cells_per_tick: float) -> float:
    """pc_trans_gain compensating the lattice lag at this packet speed (see the module doc)."""
    (c0, g0), (c1, g1) = GAIN_SLOW, GAIN_FAST
    if cells_per_tick <= c0:
        return g0
    if cells_per_tick >= c1:
        return g1
    return round(g0 + (g1 - g0) * (cells_per_tick - c0) / (c1 - c0), 3)


def derive_configs(log, ratslam: RatSLAMConfig | None = None, gtsam: PoseGraphConfig | None = None
                   ) -> tuple[RatSLAMConfig, PoseGraphConfig, str]:
    """RatSLAM and pose-graph configurations for ``log``: ``ratslam`` / ``gtsam`` (default: the
    defaults) with their distance- and tick-dependent fields scaled to the log (module doc).
    Returns both and a description of what was measured and derived."""
    rs, pg = ratslam or RatSLAMConfig(), gtsam or PoseGraphConfig()
    m = measure_log(log)
    k_step = ladder(m.step / REFERENCE_STEP_M) if m.step > 0 else 1.0
    k_scene = ladder(m.label_length / REFERENCE_LABEL_LENGTH_M)
    k_v, k_w = ladder(m.sigma_v / REFERENCE_NOISE), ladder(m.sigma_w / REFERENCE_NOISE)
    step = REFERENCE_STEP_M * k_step
    cell = max(rs.cell_size_m, step / MAX_CELLS_PER_TICK)
    cpt = step / cell
    rs_new = rs
    if k_step != 1.0:
        rs_new = rs.replace(cell_size_m=cell, pc_trans_gain=trans_gain(cpt))
    pg_new = pg
    if k_scene != 1.0:
        pg_new = dataclasses.replace(pg_new, keyframe_distance=pg.keyframe_distance * k_scene,
                                     closure_sigma_xy=pg.closure_sigma_xy * k_scene,
                                     closure_min_travel=pg.closure_min_travel * k_scene)
    if k_v != 1.0 or k_w != 1.0:
        pg_new = dataclasses.replace(pg_new, odom_sigma_v=pg.odom_sigma_v * k_v, odom_sigma_w=pg.odom_sigma_w * k_w)
    text = (f"Measured from the log (no ground truth): tick {m.dt:.3f} s, moving speed {m.speed:.3f} m/s, "
            f"{m.step:.4f} m per tick (x{k_step:g} of the reference 0.3 m/s at 7 Hz), label length {m.label_length:.2f} m "
            f"(x{k_scene:g} of {REFERENCE_LABEL_LENGTH_M} m), odometry noise {m.sigma_v:.4f} m/s, {m.sigma_w:.4f} rad/s "
            f"(x{k_v:g}, x{k_w:g} of {REFERENCE_NOISE}).\n"
            f"Derived: RatSLAM cell_size_m {rs_new.cell_size_m:g} ({cpt:.2f} cells per tick), pc_trans_gain "
            f"{rs_new.pc_trans_gain:g}; GTSAM keyframe_distance {pg_new.keyframe_distance:g} m, closure_sigma_xy "
            f"{pg_new.closure_sigma_xy:.3f} m, closure_min_travel {pg_new.closure_min_travel:g} m, odom_sigma_v "
            f"{pg_new.odom_sigma_v:g}, odom_sigma_w {pg_new.odom_sigma_w:g}"
            + (" (the defaults)" if rs_new == rs and pg_new == pg else "") + ".")
    return rs_new, pg_new, text
