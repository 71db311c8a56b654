"""Configurations derived from a log's speed, tick rate and labels (harness/scale.py): the
simulator's own streams get exactly the defaults; other scales get scaled fields; ground truth
never enters."""

import dataclasses

import numpy as np
import pytest

from baselines import PoseGraphConfig
from harness.scale import derive_configs, ladder, measure_log, trans_gain
from ratslam import RatSLAMConfig
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
    assert 0.8 < m.label_length < 1.05                # 1 m scene cells
    assert 0.009 < m.sigma_v < 0.013 and 0.009 < m.sigma_w < 0.013   # simulated 0.01


def _drive(step_m, hz, label_m, n=6000, seed=0):
    """A synthetic log: ticks at ``hz``, ``step_m`` metres per tick, a gentle turn, odometry
    noise 0.01 m/s and rad/s, a new scene number every ``label_m`` metres (10% blank)."""
    rng = np.random.default_rng(seed)
    dt = np.full(n, 1.0 / hz)
    v = step_m * hz + rng.normal(0, 0.01, n)
    dist = np.cumsum(np.abs(v) * dt)
    cell = (dist // label_m).astype(int)
    scene = np.where(cell % 10 == 9, -1, cell % 500)
    return ObservationLog(t=np.cumsum(dt), dt=dt, v_trans=v, v_rot=0.05 + rng.normal(0, 0.01, n),
                          scene_id=scene)


def test_the_synthetic_drive_at_the_reference_scale_gets_the_defaults():
    assert derive_configs(_drive(0.3 / 7, 7.0, 1.0))[:2] == (RatSLAMConfig(), PoseGraphConfig())


def test_a_faster_vehicle_gets_scaled_fields():
    # 1.2 m/s at 7 Hz (4x the metres per tick), labels twice as long
    log = _drive(4 * 0.3 / 7, 7.0, 2.0)
    m = measure_log(log)
    assert m.step == pytest.approx(4 * 0.3 / 7, rel=0.02)
    assert m.label_length == pytest.approx(2.0, rel=0.1)
    rs, pg, _ = derive_configs(log)
    assert rs.cell_size_m == 0.25 and rs.pc_trans_gain == pytest.approx(trans_gain(4 * 0.3 / 7 / 0.25))
    assert 1.0 <= rs.pc_trans_gain < 1.05
    assert pg.keyframe_distance == pytest.approx(1.0)
    assert pg.closure_sigma_xy == pytest.approx(2.0 / np.sqrt(6.0))
    assert pg.odom_sigma_v == 0.01 and pg.odom_sigma_w == 0.01
    # untouched fields keep their defaults
    assert rs.replace(pc_trans_gain=1.05) == RatSLAMConfig()


def test_packet_speed_is_capped_by_larger_cells():
    rs, _, _ = derive_configs(_drive(16 * 0.3 / 7, 10.0, 4.0))     # 0.69 m per tick
    assert rs.cell_size_m == pytest.approx(16 * 0.3 / 7 / 1.5)
    assert rs.pc_trans_gain == 1.0


def test_ground_truth_never_enters_the_derivation():
    log = _drive(4 * 0.3 / 7, 7.0, 2.0)
    with_gt = dataclasses.replace(log, gt_x=np.full(len(log), 1e6), gt_y=np.zeros(len(log)),
                                  gt_theta=np.zeros(len(log)), false_positive=np.zeros(len(log), int))
    assert derive_configs(with_gt) == derive_configs(log)


def test_ladder_and_gain():
    assert ladder(0.85) == 1.0 and ladder(1.18) == 1.0
    assert ladder(4.7) == 4.0 and ladder(2.1) == 2.0 and ladder(2.9) == pytest.approx(2 ** 1.5)
    assert trans_gain(0.17) == 1.05 and trans_gain(0.8) == 1.0
    assert 1.0 < trans_gain(0.4) < 1.05
