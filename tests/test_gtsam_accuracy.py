"""Accuracy of the pose-graph baseline on simulator streams (the same streams RatSLAM gets).

Thresholds come from measured runs (seed 0 is tested; seeds 1 and 2 were measured
too and the margins cover them); the measured values are in the comments.
ATE: keyframe positions vs ground truth at the keyframe ticks after SE(2) alignment.
Closure truth rule: keyframes within 1.5 m in ground truth (tests/test_gtsam_support.py).
"""

import numpy as np
import pytest

from baselines import PoseGraphConfig

from .test_gtsam_support import closure_truth, keyframe_ate, precision_recall, run_slam, sim_log

pytestmark = pytest.mark.slow  # 15-minute streams or real logs end to end

BACKENDS = ("gaussian", "robust", "gnc")
LOOP = ("small_loop", 900.0)  # Fig 7: 15 minutes on the 7 m x 7 m corridor loop
FLOOR = ("office_floor", 300.0)  # Fig 4's office floor, the first 5 minutes

_runs: dict = {}


def result(world, duration, fp, backend, bias=0.0, estimate_bias=False):
    """Cached (slam, log) of one online run with defaults except the back-end."""
    key = (world, duration, fp, backend, bias, estimate_bias)
    if key not in _runs:
        log = sim_log(world, duration, fp, bias)
        cfg = PoseGraphConfig().replace(backend={"kind": backend}, yaw_bias={"estimate": estimate_bias})
        _runs[key] = (run_slam(log, cfg), log)
    return _runs[key]


def ate(world, duration, fp, backend, **kw):
    slam, log = result(world, duration, fp, backend, **kw)
    return keyframe_ate(slam, log)


def odometry_ate(world, duration, bias=0.0):
    log = sim_log(world, duration, 0.0, bias)
    return keyframe_ate(run_slam(log, PoseGraphConfig().replace(optimisation={"online": False}), scenes=False), log)


@pytest.mark.parametrize("backend", BACKENDS)
def test_small_loop_clean_every_backend_closes_the_loop(backend):
    """Fig 7 setting, no false positives: every back-end closes the loop.

    Measured ATE (seeds 0/1/2): odometry 0.152/0.177/0.220 m; gaussian 0.088/0.105/0.102,
    robust 0.087/0.106/0.103, gnc 0.088/0.105/0.104 m.
    """
    odo = odometry_ate(*LOOP)
    closed = ate(*LOOP, 0.0, backend)
    assert closed < 0.12  # measured 0.087-0.088 (seed 0)
    assert closed < 0.7 * odo  # measured ratio 0.58 (seed 0), 0.60/0.47 (seeds 1/2)


@pytest.mark.parametrize("backend", BACKENDS)
def test_office_floor_clean_no_worse_than_odometry(backend):
    """Fig 4's floor, 5 minutes, no false positives: closures improve on odometry.

    The floor has few revisits in 5 minutes (25 closures, seed 0) and the
    odometry noise is small, so the gain is modest: odometry 0.240 m; gaussian
    0.198, robust 0.186, gnc 0.198 m.  (Seeds 1/2 contain the look-alike rooms'
    aliased closures and there gaussian fails even without false positives:
    0.69/5.2 m, robust 0.091/0.146, gnc 0.082/0.149 vs odometry 0.108/0.140.)
    """
    assert ate(*FLOOR, 0.0, backend) < 0.9 * odometry_ate(*FLOOR)  # measured ratios 0.77-0.83


def test_false_positives_degrade_gaussian_but_not_robust_or_gnc_on_the_loop():
    """10% false-positive ticks on the Fig 7 loop: gaussian visibly degrades, robust/gnc stay.

    Measured ATE clean -> 10% fp (seed 0): gaussian 0.088 -> 0.514 (5.8x), robust
    0.087 -> 0.088 (1.01x), gnc 0.088 -> 0.093 (1.06x).  Seeds 1/2: gaussian 4.8x/6.2x,
    robust 0.98x/1.26x, gnc 1.44x/1.68x.  Stated bounds: robust within 1.5x and gnc
    within 2x of their clean result; gaussian at least 3x worse.
    """
    clean = {b: ate(*LOOP, 0.0, b) for b in BACKENDS}
    noisy = {b: ate(*LOOP, 0.1, b) for b in BACKENDS}
    assert noisy["gaussian"] > 3.0 * clean["gaussian"]
    assert noisy["robust"] < 1.5 * clean["robust"]
    assert noisy["gnc"] < 2.0 * clean["gnc"]


def test_false_positives_on_the_office_floor():
    """10% false-positive ticks on the office floor (5 min): gaussian collapses, robust/gnc hold.

    Measured ATE clean -> 10% fp (seed 0): gaussian 0.198 -> 5.11 m, robust 0.186 -> 0.191,
    gnc 0.198 -> 0.189.
    """
    assert ate(*FLOOR, 0.1, "gaussian") > 2.0
    for backend in ("robust", "gnc"):
        assert ate(*FLOOR, 0.1, backend) < 1.5 * ate(*FLOOR, 0.0, backend)  # measured 1.03x, 0.96x


@pytest.mark.parametrize(
    "backend, min_precision, min_recall",
    [
        # measured seed 0: precision 1.000, recall 0.882 (seeds 1/2: 1.000/0.858, 1.000/0.874)
        ("robust", 0.98, 0.80),
        # measured seed 0: precision 1.000, recall 0.974 (seeds 1/2: 1.000/0.969, 0.997/0.979)
        ("gnc", 0.98, 0.92),
    ],
)
def test_inlier_flags_against_ground_truth(backend, min_precision, min_recall):
    """Accepted closures vs ground truth on the loop with 10% false-positive ticks.

    A closure is true when its keyframes' ground-truth positions are within 1.5 m.
    Against the simulator's false_positive labels: of the closures proposed on a
    labelled tick (412, seed 0) most still join keyframes within 1.5 m (339: the
    reported number is often that of a nearby cell, or the keyframe fell on the
    tick by distance); the rest are false and the back-end rejects them
    (measured: all of them for robust and gnc, seeds 0/1; gnc 0.975 on seed 2).
    """
    slam, log = result(*LOOP, 0.1, backend)
    truth = closure_truth(slam, log)
    accepted = slam.closure_accepted
    precision, recall = precision_recall(accepted, truth)
    assert precision >= min_precision
    assert recall >= min_recall
    fp_label = log.false_positive[slam.closure_ticks]
    assert fp_label.sum() > 300  # measured 412
    false_on_fp = fp_label & ~truth
    assert false_on_fp.sum() > 50  # measured 73
    assert (~accepted[false_on_fp]).mean() >= 0.95  # measured 1.00


def test_gaussian_accepts_everything_and_so_admits_false_closures():
    """The naive baseline trusts every closure: its precision is the raw candidate precision."""
    slam, log = result(*LOOP, 0.1, "gaussian")
    precision, recall = precision_recall(slam.closure_accepted, closure_truth(slam, log))
    assert recall == 1.0
    assert precision < 0.95  # measured 0.875


def test_yaw_bias_3deg_needs_the_bias_variable():
    """Figs 8-10 bias, reading (b) (bias in the odometry every consumer sees), 3 deg/s.

    Without a bias variable every back-end stays near raw odometry (a lap takes
    ~72 s, so 216 deg of heading error per lap, past what a wrapped angle residual
    resolves); with the bias estimated in the graph the robust back-end closes the
    loop and recovers the bias.  Measured (seed 0): odometry 3.10 m; gaussian 3.09,
    robust 3.12, gnc 3.12 m; robust + bias 0.091 m with b = 2.995 deg/s
    (seeds 1/2: 0.104/0.114 m, 3.001/3.013 deg/s).  With the default searched bias
    (issue 13; +-3 deg/s, ratslam/yaw_bias.py) gaussian and robust adopt the lap's alias
    -2.75 deg/s (3 - 360/63) and stay near odometry: 2.96 m each.
    """
    odo = odometry_ate(*LOOP, bias=3.0)
    for backend in ("gaussian", "robust"):
        assert ate(*LOOP, 0.0, backend, bias=3.0) > 0.8 * odo  # measured ratios 0.96, 0.96
    slam, log = result(*LOOP, 0.0, "robust", bias=3.0, estimate_bias=True)
    assert keyframe_ate(slam, log) < 0.15  # measured 0.091
    assert np.degrees(slam.yaw_bias) == pytest.approx(3.0, abs=0.05)  # measured 2.995


@pytest.mark.parametrize("backend", BACKENDS)
def test_deterministic_on_a_simulator_stream(backend):
    """Same stream and config -> bit-identical keyframe poses, closures and weights."""
    log = sim_log(*FLOOR, 0.1)
    a, b = (run_slam(log, PoseGraphConfig().replace(backend={"kind": backend})) for _ in range(2))
    assert np.array_equal(a.keyframe_poses, b.keyframe_poses)
    assert np.array_equal(a.loop_closures, b.loop_closures)
    assert np.array_equal(a.closure_weights, b.closure_weights)
