"""Systematic wheel-odometry errors (worlds.odometry_model): scale, turn and slip errors do what
their documentation says on a known motion, and are off by default.

The paper's simulator adds only a constant yaw bias (Figs 8-10); real wheel odometry also has
scale and turn errors and slips (calibrated here against the CMU Plaza logs, see the module)."""

import dataclasses
import math

import numpy as np

from worlds import load_world, simulate
from worlds.odometry_model import measured_odometry, slip_per_tick
from worlds.world import OdometrySpec

DT = 1.0 / 7.0
QUIET = OdometrySpec(noise_trans=0.0, noise_rot=0.0)


def _measure(spec, v, w, seed=0):
    rngs = [np.random.default_rng([seed, k]) for k in (1, 3)]
    return measured_odometry(v, w, spec, DT, 0.4, *rngs)


def test_scale_error_lengthens_every_distance_by_its_fraction():
    v = np.full(700, 0.3)
    vm, wm = _measure(dataclasses.replace(QUIET, scale_error=0.02), v, np.zeros(700))
    assert math.isclose(vm.sum() * DT, 1.02 * v.sum() * DT, rel_tol=1e-12)
    assert np.all(wm == 0.0)


def test_turn_error_is_a_heading_error_per_turn():
    """0.5% turn error: one full turn in place is reported 1.8 deg too large."""
    n = 140
    w = np.full(n, 2 * math.pi / (n * DT))
    _, wm = _measure(dataclasses.replace(QUIET, turn_scale_error=0.005), np.zeros(n), w)
    assert math.isclose(math.degrees(wm.sum() * DT - 2 * math.pi), 1.8, rel_tol=1e-9)


def test_drift_is_a_heading_error_per_metre_driven():
    """Unequal wheel radii: 0.1 deg/m over 30 m of straight driving is 3 deg of heading."""
    n = 700
    v = np.full(n, 30.0 / (n * DT))
    _, wm = _measure(dataclasses.replace(QUIET, drift_deg_per_m=0.1), v, np.zeros(n))
    assert math.isclose(math.degrees(wm.sum() * DT), 3.0, rel_tol=1e-9)


def test_slip_episodes_add_distance_and_a_spurious_turn_only_while_slipping():
    spec = dataclasses.replace(QUIET, slip_rate=0.05, slip_duration=2.0, slip_fraction=0.2)
    n = 7 * 600
    v = np.full(n, 0.3)
    vm, wm = _measure(spec, v, np.zeros(n))
    slip = slip_per_tick(n, DT, spec, np.random.default_rng([0, 3]))
    slipping = slip != 0
    assert 0.02 < slipping.mean() < 0.3  # ~0.05/s x 2 s of episodes
    np.testing.assert_allclose(vm[slipping], 0.3 + 0.2 * 0.3 / 2)
    np.testing.assert_allclose(np.abs(wm[slipping]), 0.2 * 0.3 / 0.4)
    assert np.all(vm[~slipping] == 0.3) and np.all(wm[~slipping] == 0.0)


def test_defaults_leave_a_stream_unchanged_and_errors_change_only_odometry():
    """Off by default (the figures' streams are the same with or without the model); turned on,
    ground truth and scene numbers stay the same and only the odometry changes."""
    world = load_world("small_loop")
    assert world.odometry.scale_error == world.odometry.turn_scale_error == world.odometry.slip_rate == 0.0
    base = simulate(world, duration=60.0, seed=4)
    odometry = dataclasses.replace(world.odometry, scale_error=0.01, turn_scale_error=0.005, slip_rate=0.1)
    errs = simulate(dataclasses.replace(world, odometry=odometry), duration=60.0, seed=4)
    np.testing.assert_array_equal(base.ground_truth(), errs.ground_truth())
    np.testing.assert_array_equal(base.scene_id, errs.scene_id)
    assert not np.array_equal(base.v_trans, errs.v_trans) and not np.array_equal(base.v_rot, errs.v_rot)
