"""The yaw-rate bias correction (ratslam/yaw_bias_correction.py; not in the paper), on the map's
arrays: each transition loses the bias's turn, the map is turned along its creating links and
settled, the re-entries' statistics restart; with the search off nothing is taken off."""

import math

import numpy as np
import pytest

from ratslam import RatSLAMConfig
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
    em = _chain()
    assert yb.search is None and yb.bias == 0.0 and yb.get_state() == {}
    assert yb.unbiased(em, 0.1, 0.5, 0.3, 4) == 0.3


def test_an_adopted_bias_is_taken_off_the_yaw_rate_and_the_map():
    """A search that adopts a bias: the tick's yaw rate loses it and the map's links lose its turn
    over their time (the map's span so far is what decides the settling, not checked here)."""
    yb = YawBiasCorrection(RatSLAMConfig())
    assert yb.search is not None
    em = _chain()

    def adopt(dt, v, w, scene):
        yb.search.bias = 0.05
        return 0.05

    yb.search.add = adopt
    assert yb.unbiased(em, 0.1, 0.5, 0.3, 4) == pytest.approx(0.25)
    np.testing.assert_allclose(em.link_column("phi"), -0.1)
    assert yb.bias == 0.05 and math.isclose(yb.unbiased(em, 0.1, 0.5, 0.3, 4), 0.25)
