"""The yaw-rate bias correction (ratslam/yaw_bias_correction.py; not in the paper), on the map's
arrays: each transition loses the bias's turn, the map is turned along its creating links and
settled, the re-entries' statistics restart; with the search off nothing is taken off."""

import math

import numpy as np
import pytest

from ratslam import RatSLAM, RatSLAMConfig
from ratslam.experience_map import ExperienceMap
from ratslam.yaw_bias_correction import YawBiasCorrection, remove_yaw_bias, settle, turn_along_creation


def _chain(n: int = 4) -> ExperienceMap:
    """Experiences 0..n-1 one metre apart along x, linked in order, each link 2 s long."""
    em = ExperienceMap(RatSLAMConfig())
    for k in range(n):
        em.add_experience((float(k), 0.0, 0.0), (0.0, 0.0, 0.0), k, k)
    for k in range(n - 1):
        em.add_transition(k, k + 1, 1.0, 0.0, 0.0, 2.0)
    return em


def test_every_transition_loses_the_turn_the_bias_made_over_its_time():
    """0.1 rad/s over 2 s: φ_ij by 0.2 rad, θ_ij by half that; without settling the map's poses
    stay; the re-entries' innovation statistics start afresh."""
    em = _chain()
    em.reentry.fusion.innovations.add(np.zeros(3), np.eye(3), np.eye(3))
    before = em.poses.copy()
    remove_yaw_bias(em, 0.1, settle_map=False)
    np.testing.assert_allclose(em.link_column("phi"), -0.2)
    np.testing.assert_allclose(em.link_column("theta"), -0.1)
    np.testing.assert_array_equal(em.poses, before)
    assert em.reentry.fusion.innovations.count == 0


def test_turning_along_the_creating_links_holds_the_current_experience():
    """Each link turns by -0.2 rad: experience k's heading by -0.2 k, relative to the current
    experience (2), which keeps its heading."""
    em = _chain()
    em.current = 2
    turn_along_creation(em, np.full(3, 0.2))
    np.testing.assert_allclose(em.poses[:, 2], [0.4, 0.2, 0.0, -0.2])


def test_settle_solves_the_correction_to_its_fixed_point_the_current_experience_held():
    em = _chain()
    em.current = 1
    em.set_poses(em.poses + np.array([[0.3, -0.2, 0.1], [0.0, 0.0, 0.0], [-0.1, 0.4, -0.2], [0.2, 0.1, 0.3]]))
    keep = em.poses[1].copy()
    settle(em)
    np.testing.assert_allclose(em.link_residuals(), 0.0, atol=1e-9)
    np.testing.assert_allclose(em.poses[1], keep, atol=1e-12)


def test_the_search_off_takes_nothing_off():
    yb = YawBiasCorrection(RatSLAMConfig().replace(yaw_bias={"search": False}))
    assert yb.search is None and yb.bias == 0.0 and yb.get_state() == {}
    assert yb.adopt(0.1, 0.5, 0.3, 4) is None and yb.bias == 0.0
    slam = RatSLAM(RatSLAMConfig().replace(yaw_bias={"search": False}))
    slam.step(0.1, 0.5, 0.3, 4)
    assert slam.front_end.output is not None and slam.front_end.output.v_rot == 0.3


def test_an_adopted_bias_is_taken_off_the_yaw_rate_and_the_map():
    """A search that adopts a bias: the tick's yaw rate loses it and, without a rebuild, the map's
    links lose its turn over their time (the map's span so far is what decides the settling,
    not checked here); a later tick loses it too, the map untouched."""
    slam = RatSLAM(RatSLAMConfig().replace(yaw_bias={"rebuild": False}))
    slam.experience_map = _chain()
    search = slam.front_end.yaw_bias.search
    assert search is not None
    adopted = [0.05]

    def adopt(dt, v, w, scene):
        if not adopted:
            return None
        search.bias = adopted.pop()
        return search.bias

    search.add = adopt
    slam.step(0.1, 0.5, 0.3, -1)
    assert slam.front_end.output is not None and slam.front_end.output.v_rot == pytest.approx(0.25)
    np.testing.assert_allclose(slam.experience_map.link_column("phi"), -0.1)
    assert slam.yaw_bias == 0.05 and slam.rebuilds == 0
    slam.step(0.1, 0.5, 0.3, -1)
    assert math.isclose(slam.front_end.output.v_rot, 0.25)
    np.testing.assert_allclose(slam.experience_map.link_column("phi"), -0.1)
