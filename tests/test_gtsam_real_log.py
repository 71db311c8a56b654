"""The pose graph on a real vehicle's odometry (CMU Plaza 1, shipped with gtsam): it never
crashes on valid input. On this log gtsam refuses an iSAM2 update as an indeterminate system
(Cholesky, near keyframe 204, while driving at 1.5 m/s: one-tick keyframes at scene onsets
have a lateral sigma of 0.2 mm beside millimetres along track); the pose graph rebuilds iSAM2
with QR factorisation and goes on."""

import numpy as np
import pytest

from baselines import PoseGraphConfig, PoseGraphSLAM
from harness.report import metrics as M
from harness.run.runner import dead_reckon
from worlds.real_data import load_plaza

pytestmark = pytest.mark.slow  # 15-minute streams or real logs end to end


@pytest.fixture(scope="module")
def plaza1_start():
    return load_plaza("plaza1", duration=300.0)


def test_real_log_that_gtsam_refuses_is_recovered_not_crashed(plaza1_start):
    log = plaza1_start
    pg = PoseGraphSLAM(PoseGraphConfig())
    online = np.zeros((len(log), 3))
    for k, row in enumerate(zip(log.dt.tolist(), log.v_trans.tolist(), log.v_rot.tolist(), log.scene_id.tolist())):
        pg.step(*row)
        online[k] = pg.pose
    pg.finalize()
    assert pg.isam2_recoveries >= 1  # gtsam did refuse an update on this log (measured: 1)
    assert pg.closures_dropped == 0
    assert np.all(np.isfinite(pg.keyframe_poses))
    gt = log.ground_truth()
    # the recovered estimate is a real estimate: no worse than dead reckoning plus a margin
    # (measured over these 5 minutes: online 0.45 m, odometry 0.40 m)
    assert M.ate_rmse(online, gt) <= 1.5 * M.ate_rmse(dead_reckon(log), gt) + 0.2


def test_plaza_import_follows_the_observation_log_contract(plaza1_start):
    log = plaza1_start
    assert len(log) == len(log.dt) == len(log.scene_id) and log.has_ground_truth
    assert np.all(log.dt > 0) and np.all(np.diff(log.t) > 0)
    seen = log.scene_id[log.scene_id >= 0]
    assert len(np.unique(seen)) > 50 and (log.scene_id == -1).any()
    # odometry and ground truth agree on the heading convention: integrating the vehicle's own
    # odometry from the ground-truth start stays near the ground truth over the first minute
    gt = log.ground_truth()
    n = int(60 / np.median(log.dt))
    dr = dead_reckon(log, start=(gt[0, 0], gt[0, 1], gt[0, 2]))
    assert np.hypot(*(dr[:n, :2] - gt[:n, :2]).T).max() < 2.0  # measured 0.81 m


def test_derived_pose_graph_beats_plaza1_odometry():
    """The whole of Plaza 1 (32 min, 1.9 km) with the configuration derive_configs gives: the
    odometry's heading does not drift, and the revisit test (harness/run/scale.py) makes the pose
    graph trust it (odometry.sigma_w_rad_s 0.005 instead of the rates' roughness 0.02), so scene
    closures no longer bend it. Measured (seed 0): keyframes 0.49 m, online 0.89 m, odometry
    1.47 m; with the roughness noise 1.58 / 1.07 m."""
    from harness.run.scale import derive_configs

    log = load_plaza("plaza1", seed=0)
    _, cfg, _ = derive_configs(log)
    assert cfg.odometry.sigma_w_rad_s < 0.01
    pg = PoseGraphSLAM(cfg)
    online = np.zeros((len(log), 3))
    for k, row in enumerate(zip(log.dt.tolist(), log.v_trans.tolist(), log.v_rot.tolist(), log.scene_id.tolist())):
        pg.step(*row)
        online[k] = pg.pose
    pg.finalize()
    gt = log.ground_truth()
    odometry = M.ate_rmse(dead_reckon(log), gt)
    assert M.ate_rmse(pg.keyframe_poses, gt[pg.keyframe_ticks]) < 0.5 * odometry
    assert M.ate_rmse(online, gt) < odometry


def _map_ate(log, cfg) -> float:
    pg = PoseGraphSLAM(cfg)
    for row in zip(log.dt.tolist(), log.v_trans.tolist(), log.v_rot.tolist(), log.scene_id.tolist()):
        pg.step(*row)
    pg.finalize()
    return M.ate_rmse(pg.keyframe_poses, log.ground_truth()[pg.keyframe_ticks])


def test_closure_chains_keep_coarse_labels_from_folding_plaza1_lanes():
    """Claim of the Plaza robustness study (docs/sweeps.md): with 4 m scene cells on Plaza 1, whose
    lanes lie 2.6 m apart, most closures join a neighbouring lane, each closure of a chain pulling
    the same way. derive_configs reads the revisits' scatter (x1.41 of one cell) and counts the
    excess as shared along a chain (closures.chain_correlation 0.5): the pose-graph map is then no
    worse than the odometry (measured map ATE, label seeds 0/1/2: 1.41 / 1.30 / 1.24 m against
    1.47 m); with every closure independent the lanes fold (seed 0: 2.81 m)."""
    from harness.run.scale import derive_configs
    from harness.sweeps.task import condition_log

    ates, odometry = [], []
    for seed in (0, 1, 2):
        log = condition_log({"log": "plaza1", "duration": None, "condition": {"cell_size": 4.0}, "seed": seed})
        _, cfg, _ = derive_configs(log)
        assert cfg.closures.chain_correlation == pytest.approx(0.5)
        ates.append(_map_ate(log, cfg))
        odometry.append(M.ate_rmse(dead_reckon(log), log.ground_truth()))
        if seed == 0:
            independent = _map_ate(log, cfg.replace(closures={"chain_correlation": 0.0}))
    assert np.median(ates) < np.median(odometry)  # 1.30 < 1.47
    assert independent > odometry[0]  # the cause: 2.81 > 1.47
