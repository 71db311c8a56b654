"""Localisation on a fixed experience map (ratslam/localisation.py; not in the paper): the pose is
tracked from the odometry and scene onsets alone, on a copy of the map that navigating never
changes. Issue claim it serves: a saved RatSLAM map can be loaded and navigated on."""

import math

import numpy as np
import pytest

from ratslam import RatSLAM
from ratslam.localisation import LocaliserConfig, MapLocaliser
from ratslam.navigation import LocalisingNavigator

DT = 0.1
SPEED = 0.5


def _corridor_map(n: int = 21) -> RatSLAM:
    """A straight corridor: experience k at (k, 0) facing +x, seeing scene k, joined to k + 1 by a
    transition of 2 s; the robot at experience 0."""
    slam = RatSLAM()
    em = slam.experience_map
    for k in range(n):
        em.add_experience((float(k), 0.0, 0.0), np.zeros(3), k, 0)
    for k in range(n - 1):
        em.add_transition(k, k + 1, 1.0, 0.0, 0.0, 2.0)
    em.current = 0
    return slam


def _drive(loc, metres: float, scale: float = 1.0, scenes: bool = True):
    """Drive along the corridor: the true position advances SPEED per second, the odometry reports
    ``scale`` times that; scene k is seen within 0.2 m after x = k (blank elsewhere)."""
    true_x = 0.0
    for _ in range(int(round(metres / (SPEED * DT)))):
        true_x += SPEED * DT
        k = int(math.floor(true_x))
        scene = k if scenes and true_x - k < 0.2 else -1
        loc.step(DT, SPEED * scale, 0.0, scene)
    return true_x


def test_scene_onsets_hold_the_pose_against_an_odometry_scale_error():
    """The wheels read 10% fast: dead reckoning is 1.5 m ahead after 15 m, the localiser within
    0.3 m (each onset places the robot within its 1 m cell, sigma 0.41 m), given a noise model
    that allows for such an odometry (0.05 m per tick: 0.1 m per metre is 0.22 m over 20 ticks)."""
    slam = _corridor_map()
    model = LocaliserConfig(odom_speed_noise_m_s=0.5)
    dead = MapLocaliser(slam, model)
    true_x = _drive(dead, 15.0, scale=1.1, scenes=False)
    assert dead.pose[0] - true_x == pytest.approx(1.5, abs=0.05)
    trusting = MapLocaliser(slam)  # the simulator's 0.01 m/s: the scenes that would correct it are gated out
    _drive(trusting, 15.0, scale=1.1)
    assert abs(trusting.pose[0] - true_x) > 1.0
    loc = MapLocaliser(slam, model)
    true_x = _drive(loc, 15.0, scale=1.1)
    assert loc.updates >= 14
    assert abs(loc.pose[0] - true_x) < 0.3 and abs(loc.pose[1]) < 0.05


def test_a_scene_whose_experiences_lie_beyond_the_gate_is_ignored():
    """A look-alike: scene 20's only experience is 20 m away; the prediction is kept."""
    slam = _corridor_map()
    loc, dead = MapLocaliser(slam), MapLocaliser(slam)
    for k in range(10):
        loc.step(DT, SPEED, 0.0, 20 if k == 5 else -1)
        dead.step(DT, SPEED, 0.0, -1)
    assert loc.updates == 0 and loc.pose == dead.pose


def test_navigating_never_changes_the_map_and_plans_from_the_nearest_experience():
    slam = _corridor_map()
    before = slam.experience_poses.copy(), slam.links.copy()
    nav = LocalisingNavigator(slam, LocaliserConfig())
    _drive(nav, 4.0)
    np.testing.assert_array_equal(slam.experience_poses, before[0])
    np.testing.assert_array_equal(slam.links, before[1])
    assert nav.current_node == 4
    route = nav.plan((10.0, 0.0))
    assert route.found and route.nodes.tolist() == list(range(4, 11)) and route.time_s == pytest.approx(12.0)
    assert nav.plan((5.0, 30.0)).status == "no experience near goal"


def test_the_localiser_is_given_only_the_map_and_the_robots_own_readings():
    """No world, no ground truth: the constructor takes the SLAM object (its map is copied), the
    step the odometry and the scene number."""
    import inspect

    assert list(inspect.signature(MapLocaliser.__init__).parameters) == ["self", "slam", "config"]
    assert list(inspect.signature(MapLocaliser.step).parameters) == ["self", "dt", "v_trans", "v_rot", "scene_id"]
