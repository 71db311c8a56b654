"""Configurations derived from the scale of an observation log (speed, tick rate, labels).

The defaults of :class:`~ratslam.RatSLAMConfig` and :class:`~baselines.PoseGraphConfig` are
tuned to the simulated indoor robot: 0.3 m/s at 7 Hz (0.043 m per tick), scene numbers that
persist over about 1 m, odometry noise 0.01 m/s and 0.01 rad/s per tick. A replayed log may come
from a vehicle at another speed, tick rate and label granularity. :func:`derive_configs` measures
the log -- from ``dt``, ``v_trans``, ``v_rot`` and ``scene_id`` only, never the ground truth --
and scales the distance- and tick-dependent parameters (:func:`measure_log`: metres per tick,
label length, odometry roughness; :func:`revisit_noise`: the noise the revisits make most likely).
Each ratio to the reference is rounded to the ladder of powers of sqrt(2) (:func:`ladder`), so
the simulator's own streams get exactly the defaults. The rules and the measurements behind them
are in docs/derived-configurations.md.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from baselines import PoseGraphConfig
from ratslam import RatSLAMConfig
from ratslam.yaw_bias_correction import bias_search

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
REVISIT_CHUNK = 1 << 20  # grid rows x revisit pairs evaluated at once (8 MB per array)


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
    # every (k_v, k_w) of the grid at once, one row each (k_v major, as the table is filled)
    grid = [(kv, kw) for kv in REVISIT_GRID for kw in REVISIT_GRID]
    v2 = np.array([(REFERENCE_NOISE * kv) ** 2 for kv, _ in grid])[:, None]
    w2 = np.array([(REFERENCE_NOISE * kw) ** 2 for _, kw in grid])[:, None]
    rows = max(1, REVISIT_CHUNK // len(e))  # grid rows per pass: memory bounded on long logs
    for kc in REVISIT_CLOSURE_GRID:
        c2 = (closure_sigma * kc) ** 2
        for lo in range(0, len(grid), rows):
            v2_, w2_ = v2[lo : lo + rows], w2[lo : lo + rows]
            cxx = v2_ * A[:, 0] + w2_ * B[:, 0] + c2
            cxy = v2_ * A[:, 1] + w2_ * B[:, 1]
            cyy = v2_ * A[:, 2] + w2_ * B[:, 2] + c2
            det = cxx * cyy - cxy * cxy
            maha = (cyy * e[:, 0] ** 2 - 2.0 * cxy * e[:, 0] * e[:, 1] + cxx * e[:, 1] ** 2) / det
            g = np.exp(-0.5 * maha) / (2.0 * math.pi * np.sqrt(det))
            frac = np.full((len(v2_), 1), 0.5)
            for _ in range(20):  # EM for the inlier fraction, each row on its own
                r = frac * g / (frac * g + (1.0 - frac) * outlier)
                frac = np.clip(r.mean(axis=1, keepdims=True), 1e-3, 1.0 - 1e-3)
            rows_ll = np.sum(np.log(frac * g + (1.0 - frac) * outlier), axis=1)
            for key, ll_k, pi_k in zip(grid[lo : lo + rows], rows_ll.tolist(), frac[:, 0].tolist()):
                if ll_k > table.get(key, (-math.inf,))[0]:
                    table[key] = (ll_k, kc, pi_k)
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


def log_yaw_bias(log, config: RatSLAMConfig) -> float:
    """The yaw-rate bias (rad/s) the bias search of ``config.yaw_bias`` holds at the end of
    ``log`` (:mod:`slamkit.yaw_bias`, as RatSLAM and the pose graph run it; 0 if it adopts none)."""
    search = bias_search(config)
    for row in zip(log.dt.tolist(), log.v_trans.tolist(), log.v_rot.tolist(), log.scene_id.tolist()):
        search.add(*row)
    return search.bias


@dataclass(frozen=True)
class _Rates:
    """A log's columns with the yaw rate replaced (what :func:`revisit_noise` reads)."""

    dt: np.ndarray
    v_trans: np.ndarray
    v_rot: np.ndarray
    scene_id: np.ndarray


def _without_yaw_bias(log, bias: float):
    return log if bias == 0.0 else _Rates(log.dt, log.v_trans, np.asarray(log.v_rot, float) - bias, log.scene_id)


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
        # The rates' roughness is not the simulator's white noise: test it against the revisits,
        # dead-reckoned without the yaw-rate bias the systems' search finds in the log (they take
        # it off the odometry; left in, the revisits read it as noise).
        rs_new = rs_new.replace(yaw_bias={"search_still_m_s": rs.yaw_bias.search_still_m_s * rough_v})
        bias = log_yaw_bias(log, rs_new) if rs_new.yaw_bias.search else 0.0
        closures = pg_new.closures
        revisits = revisit_noise(
            _without_yaw_bias(log, bias), closures.min_travel_m, closures.sigma_xy_m, margin=m.label_length
        )
        if revisits is not None:
            lo, hi = revisits.support_v
            k_v = k_v if lo <= k_v <= hi else revisits.k_v
            lo, hi = revisits.support_w
            k_w = k_w if lo <= k_w <= hi else revisits.k_w
            if revisits.k_closure > 1.0:
                # The revisits scatter more than one scene cell: closures (and the bias search's
                # revisits) get the measured scatter.
                # Of that scatter, one cell's is the labels' own (independent from closure to
                # closure); the excess is the offset between two nearby passages, which every
                # closure of a chain between them shares (ClosureChains): its share of the variance.
                k_c = revisits.k_closure
                pg_new = pg_new.replace(
                    closures={"sigma_xy_m": closures.sigma_xy_m * k_c, "chain_correlation": 1.0 - 1.0 / k_c**2}
                )
                rs_new = rs_new.replace(yaw_bias={"revisit_sigma_xy_m": rs_new.yaw_bias.revisit_sigma_xy_m * k_c})
            revisit_text = (
                f" Revisits ({revisits.pairs} scene-onset pairs, {revisits.inlier_fraction:.0%} inliers"
                + (f"; yaw-rate bias {math.degrees(bias):g} deg/s taken off" if bias else "")
                + "): "
                f"most likely noise x{revisits.k_v:g} (x{revisits.support_v[0]:g}-x{revisits.support_v[1]:g}), "
                f"x{revisits.k_w:g} (x{revisits.support_w[0]:g}-x{revisits.support_w[1]:g}), onset scatter "
                f"x{revisits.k_closure:g} of closures.sigma_xy_m; "
                f"used x{k_v:g}, x{k_w:g}, x{max(1.0, revisits.k_closure):g}."
            )
        odo = pg.odometry
        pg_new = pg_new.replace(
            odometry={"sigma_v_m_s": odo.sigma_v_m_s * k_v, "sigma_w_rad_s": odo.sigma_w_rad_s * k_w}
        )
        # A standstill reads the speed's tick-to-tick noise: its bound scales with the roughness.
        pg_new = pg_new.replace(yaw_bias={"search_still_m_s": pg.yaw_bias.search_still_m_s * rough_v})
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
        + f"; both yaw_bias.search_still_m_s {rs_new.yaw_bias.search_still_m_s:g}"
        + f"; GTSAM keyframes.distance_m {kf.distance_m:g} m, closures.sigma_xy_m {lc.sigma_xy_m:.3f} m, "
        f"closures.min_travel_m {lc.min_travel_m:g} m, "
        + (f"closures.chain_correlation {lc.chain_correlation:g}, " if lc.chain_correlation else "")
        + f"odometry.sigma_v_m_s {odo.sigma_v_m_s:g}, "
        f"odometry.sigma_w_rad_s {odo.sigma_w_rad_s:g}"
        + (" (the defaults)" if rs_new == rs and pg_new == pg else "")
        + "."
    )
    return rs_new, pg_new, text
