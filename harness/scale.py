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
    flicker at cell borders weigh little; speeds above SPIKE_FACTOR x the 95th percentile count
    as that bound, so one encoder spike cannot make a run of labels hundreds of metres long).
    Simulated 1 m scene cells: 0.85-0.91 m; the Plaza
    logs' 2 m cells: 1.88-2.00 m.
  odometry noise: per-tick white noise on the speed and the yaw rate, 1.4826 MAD of the
    first differences / sqrt(2) (the simulator's 0.01 m/s and 0.01 rad/s read 0.011). This is
    the rates' tick-to-tick roughness; it equals the noise that integrates into drift only
    for white noise on smooth rates, as in the simulator. A real vehicle's rates are rough
    because it moves so (Plaza 1 and 2: the estimate grows with the averaging window instead
    of staying flat), and its drift is not white: on Plaza 1 (measured against ground truth,
    analysis only) the dead-reckoned heading has no drift at all (0.00 deg rms over 100 m)
    while the position errs 0.52-0.60 m rms over 50-100 m; the roughness reads 0.023 rad/s
    and 0.029 m/s, which as white noise means 5 deg of heading over 100 m and 0.13 m along
    track. The pose graph then let every scene closure (2 m cells) bend the well-known
    heading: keyframe ATE 1.58 / 1.49 / 1.37 m (seeds 0/1/2), worse than the odometry's 1.47.
  revisit noise (:func:`revisit_noise`, only when the roughness is not the reference's): the
    odometry noise that makes the dead-reckoned displacements between repeated scene onsets
    most likely (maximum likelihood over the sqrt(2) ladder, aliased pairs a uniform outlier
    component). A laddered roughness value inside the revisits' profile-likelihood support
    (within 2 log-likelihood units of the maximum) is kept; one outside it is replaced by the
    most likely value. Plaza 1: roughness x2.83 / x2 of 0.01, revisits x11.3 (support
    x5.7-x11.3; seed 1: x0.008-x11.3, roughness kept) / x0.5 (x0.5-x0.7), so odometry.sigma_v_m_s
    0.113 m/s (seed 1: 0.028) and odometry.sigma_w_rad_s 0.005 rad/s;
    Plaza 2: roughness x5.66 / x2.83, revisits x0.008 (support x0.008-x22.6: not resolved, the
    roughness kept) / x8 (x8-x8), so 0.057 m/s and 0.08 rad/s (its heading does drift,
    8.7 deg per 100 m). Pose-graph ATE keyframes / online, seeds 0/1/2, with the roughness
    noise -> with the revisit test: Plaza 1 1.58/1.49/1.37 -> 0.49/0.98/0.50 m and
    1.07/1.85/1.73 -> 0.89/1.04/1.04 m (odometry 1.47 m); Plaza 2 0.50/0.48/0.48 ->
    0.50/0.50/0.49 m and 1.71/1.73/1.69 -> 1.80/1.82/1.71 m (odometry 15.9 m). The revisits
    are not consulted for a log whose roughness reads the reference noise (the simulator's):
    there the pairs' scatter is dominated by the scene cells and the fit reads the yaw noise
    low (small_loop x0.5, office_floor x1), so the simulator keeps exactly the defaults.

Each ratio to the reference is rounded to the ladder of powers of sqrt(2) (:func:`ladder`), so
a log within a factor 2**0.25 (0.84-1.19) of the reference gets the reference value exactly:
the simulator's own streams get exactly the defaults. The rules:

  Pose graph (scene factor s = label length / 0.9 m, laddered):
    keyframes.distance_m = 0.5 m * s     (two keyframes per scene cell)
    closures.sigma_xy_m  = s / sqrt(6) m (a closure is known to within one scene cell,
                                          uniform over a cell of side s: s / sqrt(6) per axis)
    closures.min_travel_m = 4 m * s
    odometry.sigma_v_m_s, odometry.sigma_w_rad_s = 0.01 * laddered noise ratio, each replaced by
                                 the revisits' most likely value if the revisits reject it (see above)
  RatSLAM's yaw-rate bias search: yaw_bias.revisit_min_travel_m and revisit_sigma_xy_m as the
    pose graph's closures.min_travel_m and sigma_xy_m (the same search, the same revisits).
  RatSLAM (cells per tick c = laddered step / pose_cells.cell_size_m):
    pose_cells.trans_gain: the lattice-lag compensation depends on c. Measured packet speed / applied
      shift of the default network (straight runs, headings 0 and 35 deg): 0.96/0.95 at 0.17
      cells per tick, 0.97/0.96 at 0.3, 0.99/0.97 at 0.4, 1.00/0.99 at 0.6, 1.00 at 0.8 and
      1.0, 0.99 at 1.4. Gain 1.05 up to 0.2 cells per tick, 1.0 from 0.6, linear between.
    pose_cells.cell_size_m: 0.25 m while the packet moves at most MAX_CELLS_PER_TICK (0.75) cells per tick;
      above, the cell grows to keep 0.75. On straight runs the packet keeps up to 1.4 cells per
      tick, but on a real drive it does not hold together: Plaza 2 (0.34 m per tick, laddered)
      snaps 247 / 219 / 162 / 87 times in 4090 ticks at 1.37 / 1.0 / 0.75 / 0.6 cells per tick,
      and each snap freezes the map for experience_map.snap_settle_ticks (92 experiences at 1.37, 158 at 0.75).
      Map ATE, seed 0, with the re-entry fusion: 3.01 / 4.06 / 1.60 / 1.63 m (fusion off: 2.41 m
      at 1.37; 1.37 m at 0.75). 0.75 leaves Plaza 1 (0.69 cells per tick) and the simulator
      (0.17) at 0.25 m cells; bigger cells hurt Plaza 1 (below).
    Re-entry fusion (RatSLAMConfig.reentry; on by default with the simulator's noise; rederived
      only when the odometry noise departs from the reference, with the pose graph's
      revisit-tested noise):
      reentry.position_sigma_m = closures.sigma_xy_m (the pose graph's closure noise: one scene
      cell), reentry.heading_sigma_deg = one heading cell / sqrt(12) (2.89 deg; measured pose-cell
      heading error at Plaza re-entries 2.0-3.2 deg rms), reentry.odom_speed_noise_m_s /
      odom_heading_noise_rad_s = odometry.sigma_v_m_s / sigma_w_rad_s. Measured in
      docs/configuration.md (re-entry fusion): Plaza 1 experience map 1.33/1.62/1.77 ->
      1.30/1.33/1.39 m (seeds 0/1/2; odometry 1.47 m).
      reentry.chain_fixes = true: at a re-entry the prediction may carry the latest fix's error
      rather than the odometry's since the place was last visited (ratslam.config), whichever
      explains the innovation better. A vehicle's 2 m scene cells place a re-entry within a metre
      while its odometry between two re-entries errs less; on the simulator's 1 m cells the pose
      cells' re-entries are the better estimate and chaining costs accuracy (its defaults keep it
      off). Measured, derived configurations, label seeds 0-7, online / experience-map ATE, not
      chained -> chained: Plaza 1 (odometry 1.472 m) online 1.523 / 1.482 / 1.512 / 1.437 / 1.495
      / 1.517 / 1.481 / 1.565 -> 1.466 / 1.453 / 1.437 / 1.368 / 1.447 / 1.465 / 1.448 / 1.482
      (better on every seed), map 1.342 / 1.325 / 1.356 / 1.341 / 1.330 / 1.347 / 1.328 / 1.298
      -> 1.328 / 1.330 / 1.342 / 1.329 / 1.319 / 1.335 / 1.321 / 1.281; Plaza 2 (odometry
      15.94 m) online 2.528 / 2.474 / 2.518 / 2.236 / 2.717 / 3.109 / 2.304 / 2.700 -> 2.443 /
      2.402 / 2.321 / 2.208 / 2.585 / 3.040 / 2.199 / 2.541 (better on every seed), map 0.939 /
      1.054 / 1.062 / 0.807 / 1.229 / 0.916 / 0.784 / 0.951 -> 0.877 / 1.183 / 1.058 / 0.894 /
      1.094 / 0.949 / 0.719 / 0.873 (mean 0.968 -> 0.956).
  Everything else keeps its default, also the tick-based windows and the zones of influence,
  because scaling them with the log did not help (measured on Plaza 1, experience-map ATE,
  seeds 0 / 1, odometry 1.47 m; pose_cells.trans_gain 1.0 throughout): defaults 1.33 / 1.62 m;
  local_view.min_age_ticks and experience_map.snap_settle_ticks kept in metres (15 and 11 ticks) 1.47 / 2.40 m; the
  fatigue rates too 2.22 / 1.47 m; r_inf_cells 4 (1 m, half the 2 m scene) - / 5.47 m; pose
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
SPIKE_FACTOR = 4.0
"""Speeds above this multiple of a log's 95th-percentile speed are spikes, not driving
(:func:`measure_log`'s label length)."""
MAX_CELLS_PER_TICK = 0.75
GAIN_SLOW, GAIN_FAST = (0.2, 1.05), (0.6, 1.0)  # (cells per tick, pose_cells.trans_gain)
REENTRY_HEADING_SIGMA_CELLS = 1.0 / math.sqrt(12.0)
"""Heading uncertainty of a re-entry, in heading cells (uniform over one cell)."""


@dataclass(frozen=True)
class LogScale:
    """What :func:`measure_log` reads from a log (no ground truth)."""

    dt: float  # median tick, s
    speed: float  # median moving speed, m/s
    step: float  # speed * dt, m per tick
    label_length: float  # distance-weighted median run of one scene number, m
    sigma_v: float  # per-tick speed noise, m/s
    sigma_w: float  # per-tick yaw-rate noise, rad/s


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
    # "lower": an observed speed, so one encoder spike (a tick at 1000 m/s) is not it even in a
    # log of 20 ticks
    fast = float(np.percentile(v, 95, method="lower")) if v.size else 0.0
    moving = v > 0.1 * fast
    speed = float(np.median(v[moving])) if moving.any() else 0.0
    # ... nor does the spike make one run of labels hundreds of metres long and the
    # distance-weighted median that run: faster than SPIKE_FACTOR x the 95th percentile counts
    # as that
    v_run = np.minimum(v, SPIKE_FACTOR * fast)
    dist = np.concatenate(([0.0], np.cumsum(v_run * dt_all)))
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
    return LogScale(
        dt=dt,
        speed=speed,
        step=speed * dt,
        label_length=label_length,
        sigma_v=_noise(np.asarray(log.v_trans, float)),
        sigma_w=_noise(np.asarray(log.v_rot, float)),
    )


@dataclass(frozen=True)
class RevisitNoise:
    """What :func:`revisit_noise` reads from a log's revisits (no ground truth)."""

    pairs: int  # revisit pairs (scene onset -> nearest earlier onset of that number)
    k_v: float  # maximum-likelihood sigma_v / REFERENCE_NOISE (ladder grid)
    k_w: float  # maximum-likelihood sigma_w / REFERENCE_NOISE
    k_closure: float  # maximum-likelihood revisit scatter / closures.sigma_xy_m
    inlier_fraction: float
    support_v: tuple  # ladder values of k_v (resp. k_w) whose profile log-likelihood is
    support_w: tuple  # within REVISIT_SUPPORT of the maximum: (lowest, highest)


REVISIT_GRID = tuple(2.0 ** (i / 2.0) for i in range(-14, 15))  # 1/128 .. 128
REVISIT_CLOSURE_GRID = tuple(2.0 ** (i / 2.0) for i in range(-6, 3))  # 1/8 .. 2
REVISIT_SUPPORT = 2.0  # log-likelihood units: the usual ~95% profile interval (chi2_1 / 2)
REVISIT_MIN_PAIRS = 30


def revisit_noise(log, min_travel: float, closure_sigma: float, margin: float = 0.0) -> RevisitNoise | None:
    """Odometry noise that explains the log's revisits (maximum likelihood; no ground truth).

    Every onset of a scene number (first tick of a run of it, not -1) is paired with the most
    recent earlier onset of that number at least ``min_travel`` of path before it (not the
    nearest in the dead-reckoned track, as the pose graph picks its closures: over many laps the
    nearest is the one whose drift happened to be smallest, and the fit read the noise low). If both onsets are the same
    place, the dead-reckoned displacement e between them is the odometry error over the ticks in
    between plus the scatter of the two onsets; with per-tick white noise sigma_v on the speed
    and sigma_w on the yaw rate, e ~ N(0, sigma_v^2 A + sigma_w^2 B + s_c^2 I), where
    A = sum_k dt_k^2 u_k u_k^T (u_k the tick's heading) and B = sum_k dt_k^2 J d_k d_k^T J^T
    (d_k the displacement from tick k to the later onset, J the 90-deg rotation): first-order
    propagation, exact sums by prefix sums. Aliased pairs are handled by a mixture with a
    uniform density over the track's bounding box (``margin`` added on each side); the inlier
    fraction is fitted by EM for each grid point. sigma_v, sigma_w and s_c are searched on the
    ladders ``REVISIT_GRID`` x REFERENCE_NOISE and ``REVISIT_CLOSURE_GRID`` x closure_sigma.
    None if fewer than ``REVISIT_MIN_PAIRS`` pairs.
    """
    dt = np.asarray(log.dt, float)
    v = np.asarray(log.v_trans, float)
    dth = np.asarray(log.v_rot, float) * dt
    mid = np.cumsum(dth) - dth / 2.0
    ux, uy = np.cos(mid), np.sin(mid)
    px, py = np.cumsum(v * dt * ux), np.cumsum(v * dt * uy)
    path = np.cumsum(np.abs(v * dt))
    s = np.asarray(log.scene_id)
    if s.size < 2:
        return None
    onsets = np.flatnonzero((s >= 0) & np.r_[True, s[1:] != s[:-1]])

    def pre(a):
        return np.concatenate(([0.0], np.cumsum(a)))

    d2 = dt * dt
    p_uxx, p_uxy, p_uyy = pre(d2 * ux * ux), pre(d2 * ux * uy), pre(d2 * uy * uy)
    p1, p_x, p_y = pre(d2), pre(d2 * px), pre(d2 * py)
    p_xx, p_xy, p_yy = pre(d2 * px * px), pre(d2 * px * py), pre(d2 * py * py)
    seen: dict[int, list[int]] = {}
    e_list, a_list, b_list = [], [], []
    for j in onsets:
        earlier = seen.setdefault(int(s[j]), [])
        eligible = [i for i in earlier if path[i] <= path[j] - min_travel]
        earlier.append(int(j))
        if not eligible:
            continue
        i = eligible[-1]
        a, b = i + 1, j + 1  # ticks i+1..j lead from onset i to onset j
        e_list.append((px[j] - px[i], py[j] - py[i]))
        a_list.append((p_uxx[b] - p_uxx[a], p_uxy[b] - p_uxy[a], p_uyy[b] - p_uyy[a]))
        X, Y, n0 = px[j], py[j], p1[b] - p1[a]
        sx, sy = p_x[b] - p_x[a], p_y[b] - p_y[a]
        cxx = X * X * n0 - 2.0 * X * sx + (p_xx[b] - p_xx[a])
        cyy = Y * Y * n0 - 2.0 * Y * sy + (p_yy[b] - p_yy[a])
        cxy = X * Y * n0 - X * sy - Y * sx + (p_xy[b] - p_xy[a])
        b_list.append((cyy, -cxy, cxx))  # J C J^T
    if len(e_list) < REVISIT_MIN_PAIRS:
        return None
    e, A, B = np.asarray(e_list), np.asarray(a_list), np.asarray(b_list)
    outlier = 1.0 / ((np.ptp(px) + 2 * margin) * (np.ptp(py) + 2 * margin))
    table: dict[tuple[float, float], tuple[float, float, float]] = {}
    for kc in REVISIT_CLOSURE_GRID:
        c2 = (closure_sigma * kc) ** 2
        for kv in REVISIT_GRID:
            for kw in REVISIT_GRID:
                v2, w2 = (REFERENCE_NOISE * kv) ** 2, (REFERENCE_NOISE * kw) ** 2
                cxx = v2 * A[:, 0] + w2 * B[:, 0] + c2
                cxy = v2 * A[:, 1] + w2 * B[:, 1]
                cyy = v2 * A[:, 2] + w2 * B[:, 2] + c2
                det = cxx * cyy - cxy * cxy
                maha = (cyy * e[:, 0] ** 2 - 2.0 * cxy * e[:, 0] * e[:, 1] + cxx * e[:, 1] ** 2) / det
                g = np.exp(-0.5 * maha) / (2.0 * math.pi * np.sqrt(det))
                pi = 0.5
                for _ in range(20):
                    r = pi * g / (pi * g + (1.0 - pi) * outlier)
                    pi = float(np.clip(r.mean(), 1e-3, 1.0 - 1e-3))
                ll = float(np.sum(np.log(pi * g + (1.0 - pi) * outlier)))
                if ll > table.get((kv, kw), (-math.inf,))[0]:
                    table[(kv, kw)] = (ll, kc, pi)
    (kv, kw), (ll, kc, pi) = max(table.items(), key=lambda item: item[1][0])
    near = [key for key, val in table.items() if val[0] >= ll - REVISIT_SUPPORT]
    sv, sw = sorted(k[0] for k in near), sorted(k[1] for k in near)
    return RevisitNoise(
        pairs=len(e),
        k_v=kv,
        k_w=kw,
        k_closure=kc,
        inlier_fraction=pi,
        support_v=(sv[0], sv[-1]),
        support_w=(sw[0], sw[-1]),
    )


def trans_gain(cells_per_tick: float) -> float:
    """pose_cells.trans_gain compensating the lattice lag at this packet speed (see the module doc)."""
    (c0, g0), (c1, g1) = GAIN_SLOW, GAIN_FAST
    if cells_per_tick <= c0:
        return g0
    if cells_per_tick >= c1:
        return g1
    return round(g0 + (g1 - g0) * (cells_per_tick - c0) / (c1 - c0), 3)


def derive_configs(
    log, ratslam: RatSLAMConfig | None = None, gtsam: PoseGraphConfig | None = None
) -> tuple[RatSLAMConfig, PoseGraphConfig, str]:
    """RatSLAM and pose-graph configurations for ``log``: ``ratslam`` / ``gtsam`` (default: the
    defaults) with their distance- and tick-dependent fields scaled to the log (module doc).
    Returns both and a description of what was measured and derived."""
    rs, pg = ratslam or RatSLAMConfig(), gtsam or PoseGraphConfig()
    m = measure_log(log)
    k_step = ladder(m.step / REFERENCE_STEP_M) if m.step > 0 else 1.0
    k_scene = ladder(m.label_length / REFERENCE_LABEL_LENGTH_M)
    k_v, k_w = ladder(m.sigma_v / REFERENCE_NOISE), ladder(m.sigma_w / REFERENCE_NOISE)
    rough_v, rough_w = k_v, k_w
    step = REFERENCE_STEP_M * k_step
    cell = max(rs.pose_cells.cell_size_m, step / MAX_CELLS_PER_TICK)
    cpt = step / cell
    rs_new = rs
    if k_step != 1.0:
        rs_new = rs.replace(pose_cells={"cell_size_m": cell, "trans_gain": trans_gain(cpt)})
    pg_new = pg
    if k_scene != 1.0:
        yb = rs.yaw_bias  # RatSLAM's bias search scores revisits as the pose graph does
        rs_new = rs_new.replace(
            yaw_bias={
                "revisit_min_travel_m": yb.revisit_min_travel_m * k_scene,
                "revisit_sigma_xy_m": yb.revisit_sigma_xy_m * k_scene,
            }
        )
        pg_new = pg_new.replace(
            keyframes={"distance_m": pg.keyframes.distance_m * k_scene},
            closures={
                "sigma_xy_m": pg.closures.sigma_xy_m * k_scene,
                "min_travel_m": pg.closures.min_travel_m * k_scene,
            },
        )
    revisits, revisit_text = None, ""
    if k_v != 1.0 or k_w != 1.0:
        # The rates' roughness is not the simulator's white noise: test it against the revisits.
        closures = pg_new.closures
        revisits = revisit_noise(log, closures.min_travel_m, closures.sigma_xy_m, margin=m.label_length)
        if revisits is not None:
            lo, hi = revisits.support_v
            k_v = k_v if lo <= k_v <= hi else revisits.k_v
            lo, hi = revisits.support_w
            k_w = k_w if lo <= k_w <= hi else revisits.k_w
            revisit_text = (
                f" Revisits ({revisits.pairs} scene-onset pairs, {revisits.inlier_fraction:.0%} inliers): "
                f"most likely noise x{revisits.k_v:g} (x{revisits.support_v[0]:g}-x{revisits.support_v[1]:g}), "
                f"x{revisits.k_w:g} (x{revisits.support_w[0]:g}-x{revisits.support_w[1]:g}), onset scatter "
                f"x{revisits.k_closure:g} of closures.sigma_xy_m; used x{k_v:g}, x{k_w:g}."
            )
        odo = pg.odometry
        pg_new = pg_new.replace(
            odometry={"sigma_v_m_s": odo.sigma_v_m_s * k_v, "sigma_w_rad_s": odo.sigma_w_rad_s * k_w}
        )
        # RatSLAM's re-entry fusion, with the pose graph's noise model (module doc)
        rs_new = rs_new.replace(
            reentry=dataclasses.replace(
                rs.reentry,
                position_sigma_m=pg_new.closures.sigma_xy_m,
                heading_sigma_deg=REENTRY_HEADING_SIGMA_CELLS * 360.0 / rs.pose_cells.n_theta,
                odom_speed_noise_m_s=pg_new.odometry.sigma_v_m_s,
                odom_heading_noise_rad_s=pg_new.odometry.sigma_w_rad_s,
                chain_fixes=True,
            )
        )
    pc, fusion, kf, lc, odo = rs_new.pose_cells, rs_new.reentry, pg_new.keyframes, pg_new.closures, pg_new.odometry
    text = (
        f"Measured from the log (no ground truth): tick {m.dt:.3f} s, moving speed {m.speed:.3f} m/s, "
        f"{m.step:.4f} m per tick (x{k_step:g} of the reference 0.3 m/s at 7 Hz), label length {m.label_length:.2f} m "
        f"(x{k_scene:g} of {REFERENCE_LABEL_LENGTH_M} m), odometry noise {m.sigma_v:.4f} m/s, {m.sigma_w:.4f} rad/s "
        f"(x{rough_v:g}, x{rough_w:g} of {REFERENCE_NOISE})." + revisit_text + "\n"
        f"Derived: RatSLAM pose_cells.cell_size_m {pc.cell_size_m:g} ({cpt:.2f} cells per tick), "
        f"pose_cells.trans_gain {pc.trans_gain:g}"
        + (
            f", re-entry fusion (reentry.position_sigma_m {fusion.position_sigma_m:.3f}, "
            f"reentry.heading_sigma_deg {fusion.heading_sigma_deg:.2f}, reentry.odom_speed_noise_m_s "
            f"{fusion.odom_speed_noise_m_s:g}, reentry.odom_heading_noise_rad_s {fusion.odom_heading_noise_rad_s:g}, "
            f"reentry.chain_fixes {str(fusion.chain_fixes).lower()})"
            if fusion.enabled
            else ""
        )
        + f"; GTSAM keyframes.distance_m {kf.distance_m:g} m, closures.sigma_xy_m {lc.sigma_xy_m:.3f} m, "
        f"closures.min_travel_m {lc.min_travel_m:g} m, odometry.sigma_v_m_s {odo.sigma_v_m_s:g}, "
        f"odometry.sigma_w_rad_s {odo.sigma_w_rad_s:g}"
        + (" (the defaults)" if rs_new == rs and pg_new == pg else "")
        + "."
    )
    return rs_new, pg_new, text
