"""The pose graph's searched yaw-rate bias (ratslam/yaw_bias.py), the default since issue 13.

Synthetic streams: the noiseless-route square of tests/test_gtsam_pose_graph.py (4 m sides,
1 m x 90 deg scene cells, 0.01 rad/s yaw-rate noise), a lap every 61 s, with a constant bias
added to the measured yaw rate.  Thresholds are measured values with the margin stated.
"""

import math

import gtsam
import numpy as np
import pytest

from baselines import PoseGraphConfig, PoseGraphSLAM
from baselines.pose_graph import _fit_se2, bias_search
from slamkit.yaw_bias import _two_apart
from tests.helpers import DT

from .test_gtsam_pose_graph import square_stream
from .test_gtsam_support import keyframe_ate, run_slam, sim_log


def biased(stream, bias_deg_s):
    dt, v, w, scene, gt = stream
    return dt, v, w + math.radians(bias_deg_s), scene, gt


def with_false_positives(stream, rate, seed=1):
    """Scene numbers of other places reported at random ticks (a familiar scene in a novel place)."""
    dt, v, w, scene, gt = stream
    rng = np.random.default_rng(seed)
    scene = scene.copy()
    fp = rng.random(len(scene)) < rate
    scene[fp] = rng.choice(np.unique(scene[scene != -1]), size=int(fp.sum()))
    return dt, v, w, scene, gt


def search(stream, **changes):
    s = bias_search(PoseGraphConfig().replace(yaw_bias=changes))
    adopted = []
    dt, v, w, scene, _ = stream
    for k, (a, b, c, d) in enumerate(zip(dt, v, w, scene)):
        got = s.add(float(a), float(b), float(c), int(d))
        if got is not None:
            adopted.append((k, got))
    return s, adopted


def gt_ate(slam, stream):
    gt = stream[4]
    k = slam.keyframe_ticks
    from harness.report.metrics import ate_rmse

    return ate_rmse(slam.keyframe_poses[:, :2], gt[k, :2])


def run(stream, config=None):
    slam = PoseGraphSLAM(config)
    dt, v, w, scene, _ = stream
    for a, b, c, d in zip(dt, v, w, scene):
        slam.step(a, b, c, d)
    return slam


@pytest.mark.parametrize("bias", [-1.5, 0.7, 1.5, 2.5])
def test_search_recovers_a_known_bias(bias):
    """Five laps with a constant bias: adopted after about 1.5 laps (two revisits that overlap by
    less than half; measured tick 664, 95 s, laps of 61 s) within 0.1 deg/s of it (measured
    -0.016 deg/s for every bias), refined once (measured +0.010 deg/s at tick 1946)."""
    s, adopted = search(biased(square_stream(laps=5), bias))
    assert 1 <= len(adopted) <= 2
    assert math.degrees(s.bias) == pytest.approx(bias, abs=0.05)
    assert math.degrees(adopted[0][1]) == pytest.approx(bias, abs=0.1)
    assert 1.2 * 61.0 / DT < adopted[0][0] < 2.0 * 61.0 / DT


def test_no_bias_adopts_none():
    s, adopted = search(square_stream(laps=5))
    assert adopted == [] and s.bias == 0.0
    assert s.revisits > 400  # it did score revisits (measured 800)


def test_one_loop_is_not_enough():
    """A lap and a third: every revisit spans the same loop, so however well a bias closes it,
    nothing is adopted (the agreement rule: two revisits overlapping by less than half)."""
    dt, v, w, scene, gt = biased(square_stream(laps=2), 1.5)
    n = int(1.3 * len(dt) / 2)
    s, adopted = search((dt[:n], v[:n], w[:n], scene[:n], gt[:n]))
    assert s.revisits > 0
    assert adopted == []


@pytest.mark.parametrize("bias", [0.0, 1.5])
def test_false_positive_scenes_do_not_mislead_it(bias):
    """2% of ticks (the issue's rate) report the scene number of another place: no bias adopted
    without one, the right one, once, with one (measured 1.498 deg/s)."""
    s, adopted = search(with_false_positives(biased(square_stream(laps=5), bias), 0.02))
    assert math.degrees(s.bias) == pytest.approx(bias, abs=0.1)
    assert len(adopted) == (0 if bias == 0.0 else 1)


def test_a_search_range_that_holds_the_loop_alias_picks_it():
    """Why the range is +-3 deg/s: a loop driven in T seconds closes about as well at b as at
    b - 360/T deg/s (a square lap turned by one extra turn still closes), and false scenes then
    tip the balance to the alias.  Measured here (T = 61.3 s): with false positives a 10 deg/s
    range adopts -4.38 deg/s (the alias of 1.5, -4.37), the default range 1.498; small_loop at
    1.5 deg/s and 2% false positives likewise ends at -4.24 (lap ~63 s) with 10 deg/s, keyframe
    ATE 2.95 m, and at 1.486 with 3 deg/s, 0.103 m."""
    stream = with_false_positives(biased(square_stream(laps=5), 1.5), 0.02)
    lap = 4 * (93 + 14) * DT
    wide, _ = search(stream, search_max_deg_s=10.0)
    assert math.degrees(wide.bias) == pytest.approx(1.5 - 360.0 / lap, abs=0.1)
    narrow, _ = search(stream)
    assert math.degrees(narrow.bias) == pytest.approx(1.5, abs=0.1)


def test_pose_graph_closes_a_biased_loop_by_default():
    """The default pose graph adopts the bias, rebuilds once, and its map fits the square."""
    stream = biased(square_stream(laps=5), 1.5)
    slam = run(stream)
    off = run(stream, PoseGraphConfig().replace(yaw_bias={"search": False}))
    assert slam.yaw_bias_rebuilds >= 1
    assert math.degrees(slam.yaw_bias) == pytest.approx(1.5, abs=0.05)  # measured 1.510
    assert gt_ate(slam, stream) < 0.12  # measured 0.059
    assert gt_ate(off, stream) > 1.0  # measured 2.81
    assert off.yaw_bias == 0.0 and off.yaw_bias_rebuilds == 0


def test_without_bias_the_default_is_the_search_off_graph_bit_for_bit():
    """No adoption, no change: the search only watches."""
    stream = square_stream(laps=3)
    a = run(stream)
    b = run(stream, PoseGraphConfig().replace(yaw_bias={"search": False}))
    assert a.yaw_bias_rebuilds == 0
    assert np.array_equal(a.keyframe_poses, b.keyframe_poses) and a.pose == b.pose


def test_deterministic_with_a_rebuild():
    stream = with_false_positives(biased(square_stream(laps=4), 1.5), 0.02)
    a, b = run(stream), run(stream)
    assert a.yaw_bias_rebuilds >= 1
    assert np.array_equal(a.keyframe_poses, b.keyframe_poses)
    assert a.pose == b.pose and a.yaw_bias == b.yaw_bias
    assert np.array_equal(a.loop_closures, b.loop_closures)


def test_estimate_takes_precedence_over_search():
    stream = biased(square_stream(laps=2), 1.5)
    slam = run(stream, PoseGraphConfig().replace(yaw_bias={"estimate": True}))
    assert slam.yaw_bias_rebuilds == 0


def test_fit_se2_recovers_a_rigid_motion():
    rng = np.random.default_rng(0)
    src = rng.normal(size=(30, 2)) * 3.0
    a = 0.4
    r = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    dst = src @ r.T + np.array([1.0, -2.0])
    f = _fit_se2(src, dst)
    assert f.equals(gtsam.Pose2(1.0, -2.0, a), 1e-9)


def test_two_apart():
    assert not _two_apart([(0.0, 60.0)])
    assert not _two_apart([(0.0, 60.0), (10.0, 70.0)])  # overlap 50 s of 60
    assert _two_apart([(0.0, 60.0), (35.0, 95.0)])  # overlap 25 s of 60
    assert _two_apart([(0.0, 60.0), (60.0, 120.0)])


@pytest.mark.slow
@pytest.mark.parametrize(("bias", "fp"), [(1.5, 0.02), (0.0, 0.02)])
def test_small_loop_15_min(bias, fp):
    """Fig 8's odometric reading at 2% false positives (the issue's target, ATE <= 0.5 m).
    Measured, seed 0: 1.5 deg/s keyframe ATE 0.103 m, bias 1.486 deg/s (seeds 1/2: 0.130/0.118 m,
    1.492/1.504 deg/s); no bias: 0.087 m, nothing adopted."""
    log = sim_log("small_loop", 900.0, fp, bias)
    slam = run_slam(log, PoseGraphConfig())
    assert keyframe_ate(slam, log) < 0.16
    assert math.degrees(slam.yaw_bias) == pytest.approx(bias, abs=0.05)
    if bias == 0.0:
        assert slam.yaw_bias_rebuilds == 0
