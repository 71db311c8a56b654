"""Simulator-driven accuracy on the paper's square corridor loop (Figs 7-10), 15 simulated minutes.

ATE: each experience's map pose against the ground-truth pose at the step it last became the
current experience (or was created), after a least-squares SE(2) alignment (no scale).
"""

import functools
import math

import numpy as np
import pytest

from ratslam import PAPER_REENTRIES, RatSLAM, RatSLAMConfig

worlds = pytest.importorskip("worlds")

DURATION = 900.0


def umeyama_se2(est: np.ndarray, gt: np.ndarray) -> np.ndarray:
    """Least-squares rigid (rotation + translation, no scale) alignment of est onto gt; returns
    the aligned est (Umeyama 1991 without scale)."""
    mu_e, mu_g = est.mean(axis=0), gt.mean(axis=0)
    cov = (gt - mu_g).T @ (est - mu_e)
    u, _, vt = np.linalg.svd(cov)
    d = np.diag([1.0, np.sign(np.linalg.det(u @ vt))])
    r = u @ d @ vt
    return (est - mu_e) @ r.T + mu_g


def ate(est: np.ndarray, gt: np.ndarray) -> float:
    """RMSE of the SE(2)-aligned positions."""
    return float(np.sqrt(np.mean(np.sum((umeyama_se2(est, gt) - gt) ** 2, axis=1))))


def experience_ate(slam: RatSLAM, log) -> float:
    k = slam.experience_first_tick
    return ate(slam.experience_poses[:, :2], np.stack((log.gt_x[k], log.gt_y[k]), axis=1))


def odometry_ate(log) -> float:
    """ATE of dead-reckoned wheel odometry over every tick (same integration as the map)."""
    th = np.cumsum(log.v_rot * log.dt)
    x = np.cumsum(log.v_trans * log.dt * np.cos(th))
    y = np.cumsum(log.v_trans * log.dt * np.sin(th))
    return ate(np.stack((x, y), axis=1), np.stack((log.gt_x, log.gt_y), axis=1))


def test_umeyama_recovers_a_rigid_motion():
    rng = np.random.default_rng(0)
    gt = rng.normal(size=(50, 2))
    a = 0.7
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    est = gt @ rot.T + [3.0, -2.0]
    assert ate(est, gt) < 1e-12
    assert ate(est + rng.normal(0, 0.1, est.shape), gt) == pytest.approx(0.1 * math.sqrt(2), rel=0.2)


@functools.cache
def simulate(bias_deg_s: float, fp_rate: float):
    return worlds.simulate("small_loop", duration=DURATION, seed=0, bias_deg_s=bias_deg_s, fp_rate=fp_rate)


@functools.cache
def run(
    bias_deg_s: float,
    fp_rate: float,
    path_integration_bias_deg_s: float = 0.0,
    paper_reentries: bool = False,
    unfused: bool = False,
    rebuild: bool = True,
    **experience_map,
):
    """Run RatSLAM over a simulated log (``experience_map``: changes to that sub-config;
    ``paper_reentries``: ratslam.PAPER_REENTRIES first; ``unfused``: only its re-entry fusion
    off, as Figs 8-10's odometric variants; ``rebuild``: ``yaw_bias.rebuild``); returns (slam,
    log, per-tick peaks (cells), snap count)."""
    log = simulate(bias_deg_s, fp_rate)
    pose_cells = {"path_integration_bias_deg_s": path_integration_bias_deg_s}
    config = RatSLAMConfig().replace(**PAPER_REENTRIES) if paper_reentries else RatSLAMConfig()
    if unfused:
        config = config.replace(reentry=PAPER_REENTRIES["reentry"])
    config = config.replace(yaw_bias={"rebuild": rebuild})
    slam = RatSLAM(config.replace(pose_cells=pose_cells, experience_map=experience_map))
    peaks = np.empty((len(log), 3))
    snaps = 0
    for k in range(len(log)):
        slam.step(log.dt[k], log.v_trans[k], log.v_rot[k], log.scene_id[k])
        peaks[k] = slam.peak
        snaps += slam.snapped
    return slam, log, peaks, snaps


def heading_drift_deg(slam: RatSLAM, log, peaks: np.ndarray) -> float:
    """Spread (max - min, degrees) of the pose-cell heading minus the true heading: 0 for a
    pose-cell path that is only rotated, large when path integration bends it."""
    th = peaks[:, 2] * slam.config.pose_cells.theta_cell_rad
    err = np.unwrap(th - log.gt_theta)
    return float(np.degrees(err.max() - err.min()))


@pytest.mark.slow
@pytest.mark.parametrize("fp_rate", [0.0, 0.01])
def test_fig8_path_integration_bias_experience_map_stays_true(fp_rate):
    """Paper Figs 8-10 (reading (a)): a 3 deg/s bias in the pose cells' path integration bends
    the pose-cell path, which snaps back on familiar views, while the experience map stays
    consistent (ATE <= 0.3 m), also with default aliasing and 1% per-tick false positives."""
    slam, log, peaks, snaps = run(0.0, fp_rate, path_integration_bias_deg_s=3.0)
    err = experience_ate(slam, log)
    # measured (seed 0): ATE 0.154 m / 0.144 m (fp 0 / 0.01), seeds 1-2 <= 0.18 m; 48 / 28 snaps;
    # pose-cell heading error spread 178 / 264 degrees
    assert err <= 0.3, err
    assert snaps >= 10, snaps
    assert heading_drift_deg(slam, log, peaks) > 90.0


@pytest.mark.slow
@pytest.mark.parametrize("fp_rate", [0.0, 0.01])
def test_odometric_bias_experience_map_beats_odometry(fp_rate):
    """Paper Fig 8 with the bias in the odometry itself (reading (b), 1.5 deg/s, seen by every
    consumer): the experience map with the re-entries of Figs 8-10's odometric variants (not fused
    with the odometry) stays within 0.5 m ATE while raw odometry is >= 5x worse, also with default
    aliasing and 1% per-tick false positives. (The default re-entry fusion trusts this odometry
    until its innovations show the bias: docs/configuration.md, re-entry fusion.)"""
    slam, log, _, snaps = run(1.5, fp_rate, unfused=True)
    err = experience_ate(slam, log)
    odo = odometry_ate(log)
    # measured (seed 0): ATE 0.059 m / 0.105 m (fp 0 / 0.01; 0.138 / 0.177 m with the map corrected
    # in place instead of rebuilt, yaw_bias.rebuild); odometry 3.20 m
    assert err <= 0.5, err
    assert odo >= 5.0 * err, (odo, err)
    assert snaps >= 10


@pytest.mark.slow
def test_aliased_scene_closes_a_false_loop_on_one_view():
    """Aliasing on the lap (scene 134 at seed 0 shows at two places 4.4 m apart): under 1.5 deg/s
    of odometric bias the pose cells and the odometry have both drifted by a lap's end so that the
    second place lies where the first was learnt, and one view of 134 re-enters the first place.
    Closing loops on one view (the paper's, ``loop_closure_sequence`` off) bends the map
    (measured 0.79 m); waiting for the next scene to agree keeps it (0.14 m). The map is corrected
    in place when the bias is found (``yaw_bias.rebuild`` off), so that the pose cells keep the
    lap's drift; rebuilt, they lose it and the one view is not taken (0.06 m either way)."""
    one_view, log, _, _ = run(1.5, 0.0, unfused=True, rebuild=False, loop_closure_sequence=False)
    sequence, _, _, _ = run(1.5, 0.0, unfused=True, rebuild=False)
    assert experience_ate(one_view, log) > 0.5
    assert experience_ate(sequence, log) < 0.3


@pytest.mark.slow
def test_printed_correction_diverges_on_the_loop():
    """ARCHITECTURE.md trap: eqs 12-14 as printed (sums, α = 0.5) overshoot where an experience has more
    than two links; on the loop the map blows up within the run (measured: non-finite poses)."""
    with np.errstate(all="ignore"):
        slam, _, _, _ = run(1.5, 0.0, correction="printed")
    poses = slam.experience_poses
    assert not np.all(np.isfinite(poses)) or np.abs(poses).max() > 1e3


@pytest.mark.slow
def test_sum_energy_without_view_confirmation_collapses_under_false_positives():
    """ARCHITECTURE.md trap: eq 9's sum lets a one-tick false positive switch to an experience metres
    away on heading alone. With the paper's behaviour (sum energy, views act on their first
    tick) 1% per-tick false positives collapse the map (measured 2.20 m ATE under the 3 deg/s
    path-integration bias); the default (product energy, views confirmed on a second tick)
    holds it (0.144 m). Product energy alone is not enough here (measured 1.20 m)."""
    naive, log, _, _ = run(
        0.0, 0.01, path_integration_bias_deg_s=3.0, paper_reentries=True, energy="sum", view_confirm_ticks=1
    )
    default, _, _, _ = run(0.0, 0.01, path_integration_bias_deg_s=3.0)
    assert experience_ate(naive, log) > 1.0
    assert experience_ate(default, log) < 0.3
