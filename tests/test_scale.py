"""Configurations derived from a log's speed, tick rate and labels (harness/run/scale.py): the
simulator's own streams get exactly the defaults; other scales get scaled fields; ground truth
never enters."""

import dataclasses

import numpy as np
import pytest

from baselines import PoseGraphConfig
from harness.run import scale
from harness.run.scale import RevisitNoise, derive_configs, ladder, measure_log, revisit_noise, trans_gain
from ratslam import RatSLAMConfig, YawBiasConfig
from worlds import ObservationLog, simulate


@pytest.fixture(scope="module")
def small_loop_log():
    return simulate("small_loop", duration=120.0, seed=0)


@pytest.mark.parametrize("world", ["small_loop", "open_plan"])
def test_a_simulated_log_at_0p3_m_s_and_7_hz_gets_exactly_the_defaults(world):
    log = simulate(world, duration=120.0, seed=1)
    rs, pg, text = derive_configs(log)
    assert rs == RatSLAMConfig()
    assert pg == PoseGraphConfig()
    assert "(the defaults)" in text


def test_measured_scale_of_the_simulated_log(small_loop_log):
    m = measure_log(small_loop_log)
    assert m.dt == pytest.approx(1 / 7, rel=1e-3)
    assert m.speed == pytest.approx(0.3, rel=0.05)
    assert 0.8 < m.label_length < 1.05  # 1 m scene cells
    assert 0.009 < m.sigma_v < 0.013 and 0.009 < m.sigma_w < 0.013  # simulated 0.01


def _drive(step_m, hz, label_m, n=6000, seed=0):
    """A synthetic log: ticks at ``hz``, ``step_m`` metres per tick, a gentle turn, odometry
    noise 0.01 m/s and rad/s, a new scene number every ``label_m`` metres (10% blank)."""
    rng = np.random.default_rng(seed)
    dt = np.full(n, 1.0 / hz)
    v = step_m * hz + rng.normal(0, 0.01, n)
    dist = np.cumsum(np.abs(v) * dt)
    cell = (dist // label_m).astype(int)
    scene = np.where(cell % 10 == 9, -1, cell % 500)
    return ObservationLog(t=np.cumsum(dt), dt=dt, v_trans=v, v_rot=0.05 + rng.normal(0, 0.01, n), scene_id=scene)


def test_the_synthetic_drive_at_the_reference_scale_gets_the_defaults():
    assert derive_configs(_drive(0.3 / 7, 7.0, 1.0))[:2] == (RatSLAMConfig(), PoseGraphConfig())


def test_a_faster_vehicle_gets_scaled_fields():
    # 1.2 m/s at 7 Hz (4x the metres per tick), labels twice as long
    log = _drive(4 * 0.3 / 7, 7.0, 2.0)
    m = measure_log(log)
    assert m.step == pytest.approx(4 * 0.3 / 7, rel=0.02)
    assert m.label_length == pytest.approx(2.0, rel=0.1)
    rs, pg, _ = derive_configs(log)
    assert rs.pose_cells.cell_size_m == 0.25 and rs.pose_cells.trans_gain == pytest.approx(
        trans_gain(4 * 0.3 / 7 / 0.25)
    )
    assert 1.0 <= rs.pose_cells.trans_gain < 1.05
    assert pg.keyframes.distance_m == pytest.approx(1.0)
    assert pg.closures.sigma_xy_m == pytest.approx(2.0 / np.sqrt(6.0))
    assert pg.odometry.sigma_v_m_s == 0.01 and pg.odometry.sigma_w_rad_s == 0.01
    # RatSLAM's bias search scores revisits as the pose graph's closures do
    assert rs.yaw_bias.revisit_min_travel_m == pytest.approx(pg.closures.min_travel_m)
    assert rs.yaw_bias.revisit_sigma_xy_m == pytest.approx(pg.closures.sigma_xy_m)
    # untouched fields keep their defaults
    assert rs.replace(pose_cells={"trans_gain": 1.05}, yaw_bias=YawBiasConfig()) == RatSLAMConfig()


def test_packet_speed_is_capped_by_larger_cells():
    rs, _, _ = derive_configs(_drive(16 * 0.3 / 7, 10.0, 4.0))  # 0.69 m per tick
    assert rs.pose_cells.cell_size_m == pytest.approx(16 * 0.3 / 7 / 0.75)
    assert rs.pose_cells.trans_gain == 1.0
    assert rs.reentry == RatSLAMConfig().reentry  # reference odometry noise: the default fusion


def test_ground_truth_never_enters_the_derivation():
    log = _drive(4 * 0.3 / 7, 7.0, 2.0)
    with_gt = dataclasses.replace(
        log,
        gt_x=np.full(len(log), 1e6),
        gt_y=np.zeros(len(log)),
        gt_theta=np.zeros(len(log)),
        false_positive=np.zeros(len(log), int),
    )
    assert derive_configs(with_gt) == derive_configs(log)


def test_ladder_and_gain():
    assert ladder(0.85) == 1.0 and ladder(1.18) == 1.0
    assert ladder(4.7) == 4.0 and ladder(2.1) == 2.0 and ladder(2.9) == pytest.approx(2**1.5)
    assert trans_gain(0.17) == 1.05 and trans_gain(0.8) == 1.0
    assert 1.0 < trans_gain(0.4) < 1.05


def _revisiting_drive(
    heading_drift: float, along_noise: float, jitter_w: float = 0.02, weave: float = 0.1, n=9000, seed=0
):
    """A vehicle driving a 40 m x 20 m rectangle at 1 m/s and 5 Hz (0.2 m per tick, labels in
    2 m cells and four heading sectors), its yaw rate rough (a weaving +-``weave`` rad/s signal plus
    ``jitter_w`` rad/s per tick of noise that does not integrate: each tick's error is undone on the
    next; neither drifts) with ``heading_drift`` rad/s of white noise that does, and ``along_noise`` m/s of
    per-tick white noise on the speed. Scene numbers come from the true track (ground truth
    is not in the log)."""
    rng = np.random.default_rng(seed)
    dt = np.full(n, 0.2)
    corners = np.array([[0, 0], [40, 0], [40, 20], [0, 20], [0, 0]], float)
    seg = np.diff(corners, axis=0)
    lap = np.hypot(*seg.T).sum()
    s = (np.arange(n) * 0.2) % lap
    bounds = np.r_[0, np.cumsum(np.hypot(*seg.T))]
    k = np.searchsorted(bounds, s, side="right") - 1
    frac = (s - bounds[k]) / np.hypot(*seg[k].T)
    x, y = corners[k, 0] + frac * seg[k, 0], corners[k, 1] + frac * seg[k, 1]
    theta = np.unwrap(np.arctan2(seg[k, 1], seg[k, 0]))
    true_w = np.r_[np.diff(theta), 0.0] / 0.2
    jitter = rng.normal(0, jitter_w, n + 1)
    wobble = weave * np.sin(np.arange(n) * 1.3)  # integrates to a bounded +-0.02 rad wobble
    w = true_w + wobble + jitter[1:] - jitter[:-1] + rng.normal(0, heading_drift, n)
    v = 1.0 + rng.normal(0, along_noise, n)
    cell = np.floor(x / 2.0).astype(int) * 1000 + np.floor(y / 2.0).astype(int) * 10
    sector = np.round(theta / (np.pi / 2)).astype(int) % 4
    scene = (cell + sector) % 100_000
    return ObservationLog(t=np.cumsum(dt), dt=dt, v_trans=v, v_rot=w, scene_id=scene)


def test_revisits_replace_a_roughness_reading_that_they_reject():
    # rough yaw rate (weave and jitter: reads x8 of 0.01) but no heading drift; along-track
    # noise 0.1 m/s, far above the speed's own roughness reading
    log = _revisiting_drive(heading_drift=0.0, along_noise=0.1)
    m = measure_log(log)
    assert ladder(m.sigma_w / 0.01) >= 2.0  # the roughness says: noisy yaw rate
    r = revisit_noise(log, min_travel=8.0, closure_sigma=2.0 / np.sqrt(6.0), margin=2.0)
    assert r is not None and r.pairs > 100
    assert r.k_w <= 0.5  # the revisits: no heading drift
    assert r.support_v[0] >= 4.0  # and more than 0.04 m/s along track
    rs, pg, text = derive_configs(log)
    assert pg.odometry.sigma_w_rad_s <= 0.005 and pg.odometry.sigma_v_m_s >= 0.04
    assert "Revisits" in text
    # RatSLAM's re-entry fusion takes the same noise model
    assert rs.reentry.position_sigma_m == pg.closures.sigma_xy_m
    assert rs.reentry.heading_sigma_deg == pytest.approx(10.0 / np.sqrt(12.0))
    assert (rs.reentry.odom_speed_noise_m_s, rs.reentry.odom_heading_noise_rad_s) == (
        pg.odometry.sigma_v_m_s,
        pg.odometry.sigma_w_rad_s,
    )
    assert "re-entry fusion" in text


def test_revisits_keep_a_roughness_reading_within_their_support():
    # white yaw-rate noise that does integrate: the roughness reading is the drift, and kept
    log = _revisiting_drive(heading_drift=0.03, along_noise=0.0, jitter_w=0.0, weave=0.0)
    m = measure_log(log)
    k_w = ladder(m.sigma_w / 0.01)
    r = revisit_noise(log, min_travel=8.0, closure_sigma=2.0 / np.sqrt(6.0), margin=2.0)
    assert r.support_w[0] <= k_w <= r.support_w[1]
    _, pg, _ = derive_configs(log)
    assert pg.odometry.sigma_w_rad_s == pytest.approx(0.01 * k_w)


@pytest.mark.parametrize("n, tolerance", [(6000, 0.05), (20, 0.5)])  # 20 ticks: about two runs of labels
def test_one_encoder_spike_does_not_rescale_the_log(n, tolerance):
    """One tick at 1000 m/s (an encoder glitch) used to make one run of labels ~100 m long, the
    distance-weighted median label length that run, and the pose graph's keyframes 90 m apart."""
    log = _drive(4 * 0.3 / 7, 7.0, 2.0, n=n)
    clean = measure_log(log)
    log.v_trans[n // 2] = 1000.0
    spiked = measure_log(log)
    assert spiked.step == pytest.approx(clean.step, rel=0.01)
    assert spiked.label_length == pytest.approx(clean.label_length, rel=tolerance)


@pytest.mark.parametrize("k_closure", [0.5, 1.0, 2.0**0.5, 2.0])
def test_revisits_scattered_beyond_one_cell_widen_the_closure_sigma(monkeypatch, k_closure):
    """Claim: the pose graph's and RatSLAM's derived defaults are never worse than the odometry
    at the median of a Plaza label condition. With cells wider than Plaza 1's lane spacing a
    closure may join neighbouring lanes, and the revisits scatter more than one cell (Plaza 1:
    x1.41): closures, re-entries and the bias search take that scatter; a scatter within one
    cell leaves the label's sigma (docs/sweeps.md, docs/derived-configurations.md)."""
    log = _revisiting_drive(heading_drift=0.0, along_noise=0.1, n=1500)
    cell_sigma = ladder(measure_log(log).label_length / 0.9) / np.sqrt(6.0)
    revisits = RevisitNoise(200, 1.0, 1.0, k_closure, 0.9, (0.5, 2.0), (0.5, 2.0))
    monkeypatch.setattr(scale, "revisit_noise", lambda *args, **kwargs: revisits)
    rs, pg, text = derive_configs(log)
    widened = cell_sigma * max(1.0, k_closure)
    assert pg.closures.sigma_xy_m == pytest.approx(widened)
    assert rs.reentry.position_sigma_m == pytest.approx(widened)
    assert rs.yaw_bias.revisit_sigma_xy_m == pytest.approx(widened)
    assert f"x{max(1.0, k_closure):g}." in text


def test_the_revisit_fit_does_not_depend_on_how_its_grid_is_cut(monkeypatch):
    """The grid of noise levels is evaluated in passes bounded in memory (``REVISIT_CHUNK`` grid
    rows x revisit pairs): passes of a handful of rows give the very same fit as one pass."""
    from harness.run import scale

    log = _revisiting_drive(heading_drift=0.03, along_noise=0.05)
    whole = revisit_noise(log, min_travel=8.0, closure_sigma=2.0 / np.sqrt(6.0), margin=2.0)
    assert whole is not None and whole.pairs * 29 * 29 < scale.REVISIT_CHUNK  # one pass per k_c
    monkeypatch.setattr(scale, "REVISIT_CHUNK", 7 * whole.pairs)  # 7 rows a pass, the last shorter
    assert revisit_noise(log, min_travel=8.0, closure_sigma=2.0 / np.sqrt(6.0), margin=2.0) == whole


@pytest.mark.parametrize("seed, bias_deg_s", [(1, 2.0), (2, 1.0)])
def test_the_revisits_are_read_without_the_logs_yaw_rate_bias(seed, bias_deg_s):
    """The odometry noise the revisits make most likely is fitted on the dead reckoning with the
    yaw-rate bias the systems' search finds taken off (they take it off too): a 15-minute tour with
    twice the reference noise derives the same noise and closures with a gyro bias as without.
    Read with the bias left in (measured): speed noise x128 (1.28 m/s) and closures twice as wide,
    the revisits' inliers 8-9 %."""
    from tests.tour_stream import waypoint_tour

    clean = derive_configs(waypoint_tour(seed, 0.0, 900.0, noise=0.02))[1]
    rs, biased, text = derive_configs(waypoint_tour(seed, bias_deg_s, 900.0, noise=0.02))
    assert "deg/s taken off" in text
    assert biased.odometry == clean.odometry
    assert biased.closures == clean.closures
    assert rs.reentry.odom_speed_noise_m_s == clean.odometry.sigma_v_m_s
