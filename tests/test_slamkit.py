"""What both SLAM packages share (slamkit): poses in the plane, the route planner over a graph of
places, and the yaw-rate search's fields read from a file by their earlier (rad/s) names."""

import math
import time

import numpy as np
import pytest

from baselines import PoseGraphConfig, PoseGraphSLAM
from harness.run.config_file import read_config_file
from ratslam import RatSLAMConfig
from slamkit import routes
from slamkit.poses import between, compose, range_bearing, wrap_angle, wrap_scalar
from worlds import simulate

# A hand-made map: a square 0-1-2-3 (1 m sides) plus a diagonal 0-2 that is short but slow.
SQUARE_XY = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
SQUARE_EDGES = np.array([[0, 1], [2, 1], [2, 3], [3, 0], [0, 2]])  # 2 -> 1 stored "backwards"
SQUARE_SECONDS = np.array([3.0, 3.0, 1.0, 1.0, 10.0])


def test_compose_and_between_are_inverse():
    """between(a, compose(a, b)) is b, and compose(a, between(a, c)) is c, for poses all round."""
    rng = np.random.default_rng(3)
    for _ in range(50):
        a, b = rng.uniform(-5, 5, 3), rng.uniform(-5, 5, 3)
        assert np.allclose(between(a, compose(a, b)), b, atol=1e-12)
        assert np.allclose(compose(a, between(a, b)), b, atol=1e-12)
    # a quarter turn: one metre ahead of a robot facing +y is one metre up
    assert np.allclose(compose((1.0, 2.0, math.pi / 2), (1.0, 0.0, 0.0)), (1.0, 3.0, math.pi / 2))


def test_wrap_into_minus_pi_pi():
    angles = np.array([0.0, 3.5, -3.5, 7 * math.pi + 0.25, -100.0])
    wrapped = wrap_angle(angles)
    assert np.all(np.abs(wrapped) <= math.pi)
    assert np.allclose(np.cos(wrapped), np.cos(angles)) and np.allclose(np.sin(wrapped), np.sin(angles))
    assert wrap_scalar(math.pi) == -math.pi  # half-open: [-π, π)
    assert wrap_scalar(3.5) == pytest.approx(3.5 - 2 * math.pi)


def test_range_bearing():
    r, b = range_bearing((1.0, 1.0, math.pi / 2), (0.0, 1.0))
    assert r == pytest.approx(1.0) and b == pytest.approx(math.pi / 2)
    assert range_bearing((0.0, 0.0, 0.0), (-1.0, 0.0))[1] == -math.pi  # behind: -π, not +π


def test_quickest_route_weighs_time_not_hops():
    """0 -> 2: the one-hop diagonal takes 10 s, 0-1-2 takes 6 s, 0-3-2 takes 2 s: the quickest wins."""
    route = routes.quickest_route(SQUARE_XY, SQUARE_EDGES, SQUARE_SECONDS, 0, (1.0, 1.0), 0.5)
    assert route.found and route.status == routes.OK
    assert route.nodes.tolist() == [0, 3, 2]
    assert route.time_s == pytest.approx(2.0)
    assert np.allclose(route.waypoints, SQUARE_XY[[0, 3, 2]])


def test_joins_are_driven_both_ways():
    """Edges are stored i -> j; a route may drive them j -> i (here 2 -> 1 forwards and 1 -> 2 back)."""
    slow_left = np.array([3.0, 3.0, 10.0, 10.0, 20.0])
    there = routes.quickest_route(SQUARE_XY, SQUARE_EDGES, slow_left, 0, (1.0, 1.0), 0.5)
    back = routes.quickest_route(SQUARE_XY, SQUARE_EDGES, slow_left, 2, (0.0, 0.0), 0.5)
    assert there.nodes.tolist() == [0, 1, 2]
    assert back.nodes.tolist() == [2, 1, 0]
    assert there.time_s == back.time_s == pytest.approx(6.0)


def test_unreachable_goal_is_reported_quickly():
    """Two separate chains of 20 000 nodes: a goal on the other chain is 'unreachable', at once."""
    n = 20_000
    xy = np.stack((np.arange(2 * n, dtype=float), np.zeros(2 * n)), axis=1)
    chain = np.stack((np.arange(n - 1), np.arange(1, n)), axis=1)
    edges = np.concatenate((chain, chain + n))
    t0 = time.perf_counter()
    route = routes.quickest_route(xy, edges, np.ones(len(edges)), 0, (n + 5.0, 0.0), 0.5)
    assert time.perf_counter() - t0 < 2.0
    assert not route.found and route.status == routes.UNREACHABLE == "unreachable"
    assert route.nodes.size == 0 and math.isinf(route.time_s)
    assert route.goal_node == n + 5


def test_no_node_near_goal_and_not_localised():
    """A goal 2 m from the nearest place, with a 1 m radius, has no goal node; no start node: none."""
    route = routes.quickest_route(SQUARE_XY, SQUARE_EDGES, SQUARE_SECONDS, 0, (3.0, 1.0), 1.0)
    assert not route.found and route.status == "no experience near goal"
    assert routes.quickest_route(SQUARE_XY, SQUARE_EDGES, SQUARE_SECONDS, 0, (3.0, 1.0), 2.5).found
    lost = routes.quickest_route(SQUARE_XY, SQUARE_EDGES, SQUARE_SECONDS, -1, (1.0, 1.0), 0.5)
    assert lost.status == routes.NOT_LOCALISED


def test_yaw_bias_search_keys_in_rad_s_still_read(tmp_path, capsys):
    """The pose graph's search range and step were rad/s (search_max_rad_s, search_step_rad_s) and
    are deg/s now: a file with the earlier keys is read, converted, with one line per key on
    stderr naming the new key, and gives the same run as the new keys, bit for bit (on a small
    loop whose odometry carries a 1.5 deg/s yaw-rate bias, which the search adopts)."""
    old = tmp_path / "old.toml"
    old.write_text(
        f"[gtsam.yaw_bias]\nsearch_max_rad_s = {math.radians(3.0)!r}\nsearch_step_rad_s = {math.radians(0.05)!r}\n"
    )
    new = tmp_path / "new.toml"
    new.write_text("[gtsam.yaw_bias]\nsearch_max_deg_s = 3.0\nsearch_step_deg_s = 0.05\n")
    _, old_config = read_config_file(old).apply(RatSLAMConfig(), PoseGraphConfig())
    notes = capsys.readouterr().err.strip().splitlines()
    assert len(notes) == 2
    assert notes[0].startswith(f"note: {old}: [gtsam.yaw_bias] search_max_rad_s: now search_max_deg_s (deg/s)")
    assert "search_step_rad_s: now search_step_deg_s (deg/s); read as search_step_deg_s = 0.05" in notes[1]
    _, new_config = read_config_file(new).apply(RatSLAMConfig(), PoseGraphConfig())
    assert capsys.readouterr().err == ""

    log = simulate("small_loop", duration=150.0, seed=2)
    v_rot = log.v_rot + math.radians(1.5)
    runs = []
    for config in (old_config, new_config):
        pg = PoseGraphSLAM(config)
        poses = [pg.step(dt, v, w, int(s)) or pg.pose for dt, v, w, s in zip(log.dt, log.v_trans, v_rot, log.scene_id)]
        runs.append((np.array(poses), pg.yaw_bias, pg.yaw_bias_rebuilds))
    assert runs[0][2] >= 1  # the search adopted a bias: its range and step mattered
    assert np.array_equal(runs[0][0], runs[1][0]) and runs[0][1:] == runs[1][1:]


def test_earlier_and_new_key_together_are_refused(tmp_path):
    both = tmp_path / "both.toml"
    both.write_text("[gtsam.yaw_bias]\nsearch_max_rad_s = 0.05\nsearch_max_deg_s = 3.0\n")
    with pytest.raises(Exception, match=r"search_max_rad_s: an earlier name of search_max_deg_s"):
        read_config_file(both)


def test_tick_increments_without_small_turns_equal_the_general_form():
    """The arcs of ticks that all turn (no series needed) are the general form's values bit for
    bit, the general form being the per-tick choice between the series and the closed forms."""
    from slamkit.arcs import SMALL_TURN, tick_increments

    rng = np.random.default_rng(3)
    dt = rng.uniform(0.05, 0.2, 40)
    v = rng.uniform(-1.0, 2.0, 40)
    w = rng.normal(0.0, 0.5, 40)
    bias = 0.01
    a, phi = v * dt, (w - bias) * dt
    assert np.all(np.abs(phi) >= SMALL_TURN)
    small = np.abs(phi) < SMALL_TURN
    safe = np.where(small, 1.0, phi)
    general = (
        a * np.where(small, 1.0 - phi * phi / 6.0, np.sin(safe) / safe),
        a * np.where(small, phi / 2.0 - phi**3 / 24.0, (1.0 - np.cos(safe)) / safe),
        phi,
    )
    for got, want in zip(tick_increments(dt, v, w, bias), general):
        assert np.array_equal(got, want)
    # a tick that does not turn takes the series, its neighbours the closed forms
    w[7] = bias
    dx, dy, dth = tick_increments(dt, v, w, bias)
    assert dth[7] == 0.0 and dx[7] == v[7] * dt[7] and dy[7] == 0.0
    assert np.array_equal(dx[8:], general[0][8:]) and np.array_equal(dy[:7], general[1][:7])
