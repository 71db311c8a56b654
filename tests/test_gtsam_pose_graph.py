"""PoseGraphSLAM step contract, read-access API, keyframes, closures, determinism (synthetic streams)."""

import math

import numpy as np
import pytest

from baselines import BackendConfig, KeyframeConfig, OptimisationConfig, PoseGraphConfig, PoseGraphSLAM
from baselines.closures import ClosureChains, SceneIndex
from tests.helpers import DT


def square_stream(laps=2, side=4.0, speed=0.3, cell=1.0, seed=0, fp_ticks=()):
    """A noiseless square driven counter-clockwise; scene = 1 m cell x 90 deg sector.

    Returns (dt, v, w, scene, gt_xy) arrays; ``fp_ticks`` get the scene number of the
    starting cell (a false positive far from it).
    """
    rng = np.random.default_rng(seed)
    n_side = int(round(side / (speed * DT)))
    n_turn = 14  # 90 deg in 2 s
    dt, v, w = [], [], []
    for _ in range(4 * laps):
        dt += [DT] * n_side
        v += [speed] * n_side
        w += [0.0] * n_side
        dt += [DT] * n_turn
        v += [0.0] * n_turn
        w += [math.pi / 2 / (n_turn * DT)] * n_turn
    dt, v, w = np.array(dt), np.array(v), np.array(w)
    x = y = th = 0.0
    gt = np.zeros((len(dt), 3))
    for k in range(len(dt)):
        x += v[k] * dt[k] * math.cos(th)
        y += v[k] * dt[k] * math.sin(th)
        th += w[k] * dt[k]
        gt[k] = x, y, th
    sector = np.floor(np.mod(gt[:, 2] + math.pi / 4, 2 * math.pi) / (math.pi / 2)).astype(int)
    cx = np.floor(gt[:, 0] / cell).astype(int)
    cy = np.floor(gt[:, 1] / cell).astype(int)
    scene = (cx + 10) * 1000 + (cy + 10) * 10 + sector
    scene[rng.random(len(scene)) < 0.05] = -1
    for k in fp_ticks:
        scene[k] = scene[5]
    v_noisy = v + 0.01 * rng.normal(size=len(v))
    w_noisy = w + 0.01 * rng.normal(size=len(w))
    return dt, v_noisy, w_noisy, scene, gt


def run(config, stream, finalize=False):
    slam = PoseGraphSLAM(config)
    dt, v, w, scene, _ = stream
    for a, b, c, s in zip(dt, v, w, scene):
        slam.step(a, b, c, s)
    if finalize:
        slam.finalize()
    return slam


@pytest.fixture(scope="module")
def stream():
    return square_stream()


def test_step_accepts_python_and_numpy_scalars():
    """Same inputs as RatSLAM: python floats, numpy scalars, int scene ids (incl. numpy ints)."""
    a, b = PoseGraphSLAM(), PoseGraphSLAM()
    a.step(DT, 0.3, 0.01, 5)
    b.step(np.float64(DT), np.float32(0.3).item(), np.float64(0.01), np.int64(5))
    a.step(DT, 0.3, 0.01, -1)
    b.step(np.float32(DT).item(), np.float64(0.3), np.float64(0.01), np.int32(-1))
    assert a.tick == b.tick == 2
    assert a.pose == pytest.approx(b.pose, abs=1e-7)
    assert all(isinstance(c, float) for c in a.pose)


@pytest.mark.parametrize(
    "bad",
    [(DT, float("nan"), 0.0, 1), (-DT, 0.3, 0.0, 1), (DT, 0.3, 0.0, 1.5), (DT, 0.3, 0.0, "a"), (DT, 0.3, 0.0, True)],
)
def test_step_rejects_bad_input(bad):
    with pytest.raises(ValueError, match="^step:"):
        PoseGraphSLAM().step(*bad)


def test_pose_before_any_step_and_tick_counting():
    slam = PoseGraphSLAM()
    assert slam.pose == (0.0, 0.0, 0.0) and slam.tick == 0 and slam.num_keyframes == 0
    assert slam.keyframe_poses.shape == (0, 3) and slam.loop_closures.shape == (0, 2)
    slam.step(DT, 0.3, 0.0, -1)
    assert slam.tick == 1 and slam.num_keyframes == 1
    assert slam.keyframe_ticks.tolist() == [0]
    assert slam.pose == pytest.approx((0.3 * DT, 0.0, 0.0))


def test_keyframes_by_distance_and_heading():
    cfg = PoseGraphConfig(keyframes=KeyframeConfig(distance_m=0.5, angle_rad=math.radians(30), on_scene_change=False))
    slam = PoseGraphSLAM(cfg)
    for _ in range(70):  # 3 m straight
        slam.step(DT, 0.3, 0.0, -1)
    straight = slam.num_keyframes
    assert straight == 1 + 5  # first tick, then every 0.5 m of the remaining 2.96 m
    for _ in range(14):  # turn 90 deg on the spot
        slam.step(DT, 0.0, math.pi / 2 / (14 * DT), -1)
    assert slam.num_keyframes - straight == 2  # 6.43 deg per tick: a keyframe every 5 ticks (32 deg)
    assert np.all(np.diff(slam.keyframe_ticks) > 0)
    assert slam.keyframe_times == pytest.approx((slam.keyframe_ticks + 1) * DT)


def test_scene_onset_takes_a_keyframe():
    slam = PoseGraphSLAM(PoseGraphConfig(keyframes=KeyframeConfig(distance_m=10.0)))
    for k in range(10):
        slam.step(DT, 0.3, 0.0, 7 if k >= 5 else -1)
    assert slam.keyframe_ticks.tolist() == [0, 5]
    assert slam.keyframe_scenes.tolist() == [-1, 7]


def test_read_access_shapes_and_pose_follows_keyframe(stream):
    slam = run(PoseGraphConfig(), stream)
    k, L = slam.num_keyframes, len(slam.loop_closures)
    assert slam.keyframe_poses.shape == (k, 3)
    assert slam.keyframe_ticks.shape == slam.keyframe_times.shape == (k,)
    assert L > 0
    lc = slam.loop_closures
    assert np.all(lc[:, 0] < lc[:, 1])
    assert slam.closure_ticks.shape == slam.closure_weights.shape == slam.closure_accepted.shape == (L,)
    assert np.array_equal(slam.closure_ticks, slam.keyframe_ticks[lc[:, 1]])
    assert slam.closure_accepted.dtype == bool
    assert np.all((slam.closure_weights >= 0) & (slam.closure_weights <= 1))
    # pose = latest keyframe estimate composed with odometry since (less than one keyframe apart).
    assert np.hypot(*(np.array(slam.pose[:2]) - slam.keyframe_poses[-1, :2])) < slam.config.keyframes.distance_m + 0.05


def test_no_scene_means_no_closure(stream):
    dt, v, w, scene, gt = stream
    slam = run(PoseGraphConfig(), (dt, v, w, np.full_like(scene, -1), gt))
    assert len(slam.loop_closures) == 0


def test_closures_link_only_distant_earlier_sightings(stream):
    slam = run(PoseGraphConfig(backend=BackendConfig(kind="gaussian")), stream)
    lc = slam.loop_closures
    scenes = slam.keyframe_scenes
    assert np.all(scenes[lc[:, 0]] == scenes[lc[:, 1]]) and np.all(scenes[lc[:, 0]] != -1)
    gt = stream[4]
    gi, gj = gt[slam.keyframe_ticks[lc[:, 0]]], gt[slam.keyframe_ticks[lc[:, 1]]]
    assert np.all(np.hypot(gi[:, 0] - gj[:, 0], gi[:, 1] - gj[:, 1]) < 1.5)  # noiseless labels: all true
    # Odometric path between the two keyframes is at least closures.min_travel_m: they are laps apart.
    assert np.all(slam.keyframe_times[lc[:, 1]] - slam.keyframe_times[lc[:, 0]] > 4.0 / 0.3)


def test_closure_tie_break_nearest_recent_or_earliest():
    """Sightings of one scene at x = 0.10, 0.00, 0.05, 0.30 m (keyframes 0-3); the new keyframe at 0."""
    xs = [0.10, 0.00, 0.05, 0.30]
    path = [0.0, 10.0, 20.0, 30.0]

    def pick(window=64, **kw):
        index = SceneIndex(min_travel=4.0, max_candidates=1, window=window, **kw)
        for i in range(len(xs)):
            index.add(7, i)
        return index.candidates(7, path, 40.0, (0.0, 0.0), lambda i: (xs[i], 0.0))

    assert pick() == [1]  # nearest
    assert pick(tolerance=0.12) == [2]  # most recent within 0.12 m of the nearest
    assert pick(early_tolerance=0.12) == [0]  # earliest within 0.12 m of the nearest
    assert pick(early_tolerance=0.04) == [1]  # only the nearest is that near
    assert pick(tolerance=0.12, early_tolerance=0.12) == [2]  # recent takes precedence
    # Earliest-preferring keeps the earliest half of a full window: keyframe 0 is still ranked.
    assert pick(window=2, early_tolerance=0.5) == [0]
    assert pick(window=2) == [2]  # the plain window holds the two most recent only


def test_closure_chains_weigh_a_chain_like_its_mean():
    """The k-th closure of a chain gets sigma x sqrt(1 + (k - 1) rho); a closure whose passages
    did not both move on by a few keyframes starts a chain of its own; rho = 0: always 1."""
    chains = ClosureChains(correlation=0.5, gap=3)
    # one chain: both passages advance a keyframe or two at a time
    assert [chains.scale(i, j) for i, j in [(10, 100), (11, 101), (13, 103), (14, 104)]] == pytest.approx(
        [1.0, math.sqrt(1.5), math.sqrt(2.0), math.sqrt(2.5)]
    )
    assert chains.scale(40, 105) == 1.0  # another passage: a new chain
    assert chains.scale(16, 106) == pytest.approx(math.sqrt(3.0))  # the first chain goes on
    assert chains.scale(17, 111) == 1.0  # five keyframes later: that chain has ended
    independent = ClosureChains(correlation=0.0, gap=3)
    assert {independent.scale(10 + k, 100 + k) for k in range(5)} == {1.0}


def test_chain_correlation_off_leaves_the_graph_unchanged(stream):
    """closures.chain_correlation 0 (the default) is the independent-closure graph, bit for bit;
    positive, the chained closures weigh less (and the graph differs)."""
    base = run(PoseGraphConfig(), stream)
    off = run(PoseGraphConfig().replace(closures={"chain_correlation": 0.0, "chain_gap_keyframes": 7}), stream)
    on = run(PoseGraphConfig().replace(closures={"chain_correlation": 0.9}), stream)
    assert np.array_equal(base.keyframe_poses, off.keyframe_poses)
    assert len(on.loop_closures) == len(base.loop_closures) > 0
    assert not np.array_equal(base.keyframe_poses, on.keyframe_poses)


def test_gaussian_weights_are_one(stream):
    slam = run(PoseGraphConfig(backend=BackendConfig(kind="gaussian")), stream)
    assert np.all(slam.closure_weights == 1.0) and slam.closure_accepted.all()


def test_robust_rejects_a_planted_false_positive():
    """A far-away scene match gets a small weight from the robust kernel and GNC."""
    dt, v, w, scene, gt = square_stream(laps=2, fp_ticks=(705,))
    for backend in ("robust", "gnc"):
        slam = run(PoseGraphConfig(backend=BackendConfig(kind=backend)), (dt, v, w, scene, gt), finalize=True)
        lc = slam.loop_closures
        k = slam.keyframe_ticks
        far = np.hypot(*(gt[k[lc[:, 0]], :2] - gt[k[lc[:, 1]], :2]).T) > 1.5
        assert far.sum() == 1, backend
        assert not slam.closure_accepted[far].any(), backend
        assert slam.closure_weights[far][0] < 0.1, backend
        assert slam.closure_accepted[~far].mean() > 0.9, backend


def test_offline_mode_chains_odometry_until_finalize(stream):
    slam = run(PoseGraphConfig(optimisation=OptimisationConfig(online=False, final_batch=True)), stream)
    before = slam.keyframe_poses.copy()
    slam.finalize()
    after = slam.keyframe_poses
    assert before.shape == after.shape
    assert not np.allclose(before, after)  # the batch optimisation moved the chain
    assert slam.pose == pytest.approx(tuple(after[-1]), abs=0.6)


def test_final_batch_agrees_with_isam2(stream):
    online = run(PoseGraphConfig(), stream, finalize=True)
    batch = run(PoseGraphConfig(optimisation=OptimisationConfig(final_batch=True)), stream, finalize=True)
    assert np.allclose(online.keyframe_poses[:, :2], batch.keyframe_poses[:, :2], atol=0.05)


def test_step_after_finalize_continues_online(stream):
    slam = run(PoseGraphConfig(optimisation=OptimisationConfig(final_batch=True)), stream, finalize=True)
    k = slam.num_keyframes
    for _ in range(30):
        slam.step(DT, 0.3, 0.0, -1)
    assert slam.num_keyframes > k and slam.keyframe_poses.shape == (slam.num_keyframes, 3)


@pytest.mark.parametrize("backend", ["gaussian", "robust", "gnc"])
def test_deterministic(stream, backend):
    """Same input -> bit-identical keyframe poses and closure weights."""
    cfg = PoseGraphConfig(backend=BackendConfig(kind=backend), optimisation=OptimisationConfig(final_batch=True))
    a, b = run(cfg, stream, finalize=True), run(cfg, stream, finalize=True)
    assert np.array_equal(a.keyframe_poses, b.keyframe_poses)
    assert np.array_equal(a.closure_weights, b.closure_weights)
    assert a.pose == b.pose


def test_gnc_holds_each_closure_once_with_batched_closures():
    """Closures wait for their batch while GNC re-judges the graph: iSAM2 must end up holding
    every closure it is said to hold exactly once (no copy added by GNC and again at the flush)."""
    import gtsam

    from worlds import simulate

    log = simulate("small_loop", duration=300.0, seed=0, fp_rate=0.02)
    pg = PoseGraphSLAM(PoseGraphConfig(backend=BackendConfig(kind="gnc", gnc_interval_keyframes=10)))
    for row in zip(log.dt.tolist(), log.v_trans.tolist(), log.v_rot.tolist(), log.scene_id.tolist()):
        pg.step(*row)
    pg.finalize()
    held = pg._isam.getFactorsUnsafe()
    closure_factors = 0
    for i in range(held.size()):
        f = held.at(i)
        if f is not None and len(f.keys()) == 2:
            a, b = (gtsam.Symbol(k).index() for k in f.keys())  # noqa: SIM118 (a gtsam factor)
            closure_factors += abs(a - b) != 1  # odometry joins consecutive keyframes
    present = sum(1 for idx in pg._lc_isam_index if idx >= 0)
    assert present > 50 and closure_factors == present  # measured before the fix: 173 vs 151


def _isam_keyframes(slam):
    """Keyframe variables iSAM2 holds (the yaw-bias variable, if any, is not one)."""
    import gtsam

    values = slam._isam.calculateEstimate()
    return sum(1 for k in values.keys() if gtsam.Symbol(k).chr() == ord("x"))  # noqa: SIM118 (gtsam Values)


@pytest.mark.parametrize("backend", ["robust", "gnc"])
def test_odometry_batch_gives_the_estimate_of_per_keyframe_updates(stream, backend):
    """Odometry-only keyframes waiting for the next iSAM2 update (``optimisation.odometry_batch_keyframes``)
    change no estimate beyond linearisation noise: same closures, same keyframe poses and
    online pose to 1 mm, against an update on every keyframe."""
    each = PoseGraphSLAM(
        PoseGraphConfig(
            backend=BackendConfig(kind=backend), optimisation=OptimisationConfig(odometry_batch_keyframes=1)
        )
    )
    batched = PoseGraphSLAM(
        PoseGraphConfig(
            backend=BackendConfig(kind=backend), optimisation=OptimisationConfig(odometry_batch_keyframes=8)
        )
    )
    dt, v, w, scene, _ = stream
    deferred_seen = 0
    for k, row in enumerate(zip(dt, v, w, scene)):
        each.step(*row)
        batched.step(*row)
        assert batched.pose == pytest.approx(each.pose, abs=1e-3)
        if k % 50 == 0:
            # Reads mid-run cover every keyframe, including those not yet handed to iSAM2.
            deferred_seen += _isam_keyframes(batched) < batched.num_keyframes
            assert np.allclose(batched.keyframe_poses, each.keyframe_poses, atol=1e-3)
    assert deferred_seen > 0  # the batching was exercised
    assert np.array_equal(batched.loop_closures, each.loop_closures)
    each.finalize()
    batched.finalize()
    assert _isam_keyframes(batched) == batched.num_keyframes  # finalize hands the rest over
    assert np.allclose(batched.keyframe_poses, each.keyframe_poses, atol=1e-3)
    assert np.allclose(batched.closure_weights, each.closure_weights, atol=1e-3)


def test_odometry_batch_bounds_the_wait_and_spares_updates(stream):
    """Without closures (a first lap), a keyframe waits for at most ``optimisation.odometry_batch_keyframes``-1
    others; iSAM2 gets one update per batch instead of one per keyframe."""
    slam = PoseGraphSLAM(
        PoseGraphConfig().replace(optimisation={"odometry_batch_keyframes": 5}, closures={"min_travel_m": 1e6})
    )
    dt, v, w, scene, _ = stream
    updates = 0
    real = slam._isam.update

    class Counting:
        def update(self, *args):
            nonlocal updates
            updates += 1
            return real(*args)

        def __getattr__(self, name):
            return getattr(slam._isam_real, name)

    slam._isam_real = slam._isam
    slam._isam = Counting()
    for row in zip(dt, v, w, scene):
        slam.step(*row)
        held = slam._isam_keyframes
        assert 0 <= slam.num_keyframes - held < 5
    assert len(slam.loop_closures) == 0
    assert updates == 1 + (slam.num_keyframes - 1) // 5


def test_odometry_batch_leaves_the_yaw_bias_variant_unchanged(stream):
    """With the yaw-bias variable every odometry update refines the bias, so keyframes are never
    held back: bit-identical to per-keyframe updates."""
    a = run(
        PoseGraphConfig().replace(yaw_bias={"estimate": True}, optimisation={"odometry_batch_keyframes": 1}),
        stream,
        finalize=True,
    )
    b = run(
        PoseGraphConfig().replace(yaw_bias={"estimate": True}, optimisation={"odometry_batch_keyframes": 8}),
        stream,
        finalize=True,
    )
    assert np.array_equal(a.keyframe_poses, b.keyframe_poses)
    assert a.pose == b.pose and a.yaw_bias == b.yaw_bias
