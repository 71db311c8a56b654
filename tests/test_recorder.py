"""Rerun recorder: a small recording read back with rerun's own reader and ``rerun rrd verify``.

The SLAM systems are stood in for by small fakes exposing the read-access attributes the
recorder uses (``RatSLAM``: peak, snapped, pose_cell_activity, experience_poses, links,
experience_first_tick; ``PoseGraphSLAM``: keyframe_poses, keyframe_ticks, loop_closures,
closure_accepted), so the expected content of the file is known exactly.
"""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

from harness.record.recorder import C_SNAP, Recorder

GRID = (20, 20, 8)
N_TICKS = 300
EVERY_ACTIVITY, EVERY_MAP, FLUSH = 10, 50, 32
SNAP_TICK = 150
FP_TICKS = (37, 211)
MAP_ROT, MAP_SHIFT = 0.3, np.array([2.0, -1.0])  # experience map frame vs ground truth
KF_ROT, KF_SHIFT = -0.5, np.array([-3.0, 0.5])  # GTSAM frame vs ground truth


def ground_truth(k):
    a = 2 * math.pi * k / 200.0
    return np.array([3 * math.cos(a), 3 * math.sin(a), a + math.pi / 2])


def into(frame_rot, frame_shift, xyt):
    """Pose of ``xyt`` (ground-truth frame) expressed in a frame rotated/shifted from it."""
    c, s = math.cos(frame_rot), math.sin(frame_rot)
    R = np.array([[c, -s], [s, c]])
    return np.array([*(R @ xyt[:2] + frame_shift), xyt[2] + frame_rot])


class FakeRatSLAM:
    def __init__(self):
        self.peak = np.zeros(3)
        self.snapped = False
        self.pose_cell_activity = np.zeros(GRID)
        self._poses, self._last, self._links = [], [], []

    def step(self, k, gt):
        cells = gt[:2] / 0.25 + 10.0 + (6.0 if k >= SNAP_TICK else 0.0)  # wraps around 20 cells
        new = np.array([*np.mod(cells, GRID[:2]), 0.0])
        self.snapped = k == SNAP_TICK
        self.peak = new
        act = np.zeros(GRID)
        act[int(new[0]) % GRID[0], int(new[1]) % GRID[1], 0] = 1.0
        self.pose_cell_activity = act
        if k % 10 == 0:
            self._poses.append(into(MAP_ROT, MAP_SHIFT, gt))
            self._last.append(k)
            if len(self._poses) > 1:
                self._links.append([len(self._poses) - 2, len(self._poses) - 1])

    @property
    def experience_poses(self):
        return np.array(self._poses).reshape(-1, 3)

    @property
    def experience_first_tick(self):
        return np.array(self._last, dtype=int)

    @property
    def links(self):
        return np.array(self._links, dtype=int).reshape(-1, 2)


class FakePoseGraph:
    def __init__(self):
        self._kf, self._ticks = [], []

    def step(self, k, gt):
        if k % 20 == 0:
            self._kf.append(into(KF_ROT, KF_SHIFT, gt))
            self._ticks.append(k)

    keyframe_poses = property(lambda self: np.array(self._kf).reshape(-1, 3))
    keyframe_ticks = property(lambda self: np.array(self._ticks, dtype=int))
    loop_closures = property(lambda self: np.array([[0, 10], [1, 12]]) if len(self._kf) > 12 else np.zeros((0, 2)))
    closure_accepted = property(lambda self: np.array([True, False]) if len(self._kf) > 12 else np.zeros(0, bool))


def make_recording(path: Path, with_gt: bool = True, **options) -> dict:
    walls = np.array([[[-4, -4], [4, -4]], [[4, -4], [4, 4]], [[4, 4], [-4, 4]], [[-4, 4], [-4, -4]]], float)
    rs, pg = FakeRatSLAM(), FakePoseGraph()
    peaks = []
    options = dict(every_activity=EVERY_ACTIVITY, every_map=EVERY_MAP, flush_every=FLUSH) | options
    with Recorder(path, walls, GRID, **options) as rec:
        assert not path.exists()  # written under a temporary name until closed
        for k in range(N_TICKS):
            gt = ground_truth(k)
            rs.step(k, gt)
            pg.step(k, gt)
            peaks.append(rs.peak.copy())
            odom = into(0.0, np.zeros(2), gt) + [0.01 * k, 0.0, 0.0]  # drifting odometry
            rec.log_tick(k, (k + 1) / 7.0, gt if with_gt else None, odom, rs, pg, k in FP_TICKS)
        rec.log_metrics(N_TICKS - 1, {"custom": {"value": 1.5}, "skipped": "text"})
    return {"peaks": np.array(peaks), "rs": rs, "pg": pg}


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "recording.rrd"
    info = make_recording(path)
    store = RrdReader(path).store()
    chunks = store.stream().to_chunks()
    by_entity = {}
    for c in chunks:
        by_entity.setdefault(c.entity_path, []).append(c)
    return path, info, store, by_entity


def rows(by_entity, entity):
    """Rows of an entity on the timelines (a static chunk, e.g. an image's drawing settings, aside)."""
    return sum(c.num_rows for c in by_entity.get(entity, []) if "tick" in c.to_record_batch().schema.names)


def column(by_entity, entity, name):
    """Concatenated column ``name`` of an entity's chunks, ordered by tick."""
    parts = []
    for c in by_entity[entity]:
        rb = c.to_record_batch()
        ticks = rb.column("tick").cast(pa.int64()).to_numpy()
        parts += list(zip(ticks, rb.column(name).to_pylist()))
    parts.sort(key=lambda p: p[0])
    return np.array([p[0] for p in parts]), [p[1] for p in parts]


def test_file_has_recording_and_blueprint(recording):
    path, *_ = recording
    reader = RrdReader(path)
    assert len(reader.recordings()) == 1
    assert len(reader.blueprints()) == 1
    assert not list(path.parent.glob(".*partial*"))  # temporary file moved into place


def test_entity_paths_and_timelines(recording):
    _, _, store, by_entity = recording
    expected = {
        "/world",
        "/world/walls",
        "/world/ground_truth",
        "/world/odometry",
        "/world/false_positives",
        "/world/ratslam/experiences",
        "/world/ratslam/links",
        "/world/gtsam/estimate",
        "/world/gtsam/closures",
        "/pose_cells",
        "/pose_cells/grid",
        "/pose_cells/activity",
        "/pose_cells/peak",
        "/metrics/ate/odometry",
        "/metrics/ate/experience_map",
        "/metrics/ate/gtsam",
        "/metrics/count/experiences",
        "/metrics/count/links",
        "/metrics/count/snaps",
        "/metrics/count/keyframes",
        "/metrics/count/loop_closures_accepted",
        "/metrics/custom/value",
    }
    assert expected <= set(by_entity)
    assert "/metrics/skipped" not in by_entity
    timelines = {t for cs in by_entity.values() for c in cs for t in c.timeline_names}
    assert timelines == {"tick", "sim_time"}
    assert all(c.is_static for c in by_entity["/world/walls"] + by_entity["/pose_cells/grid"])
    schema = str(store.schema())
    assert "Index(timeline:tick)" in schema and "Index(timeline:sim_time)" in schema


def test_row_counts(recording):
    """One segment per tick for trajectories (none at the first tick); maps and activity at
    their periods plus the final tick; one point per false positive."""
    _, info, _, by_entity = recording
    assert rows(by_entity, "/world/ground_truth") == N_TICKS - 1
    assert rows(by_entity, "/world/odometry") == N_TICKS - 1
    p = info["peaks"][:, :2]
    jump = np.abs(np.diff(p, axis=0))
    wrapped = np.any(jump > np.array(GRID[:2]) / 2, axis=1)
    snapped = np.arange(1, N_TICKS) == SNAP_TICK
    assert wrapped.sum() >= 2  # the fake's path does wrap around the grid
    assert rows(by_entity, "/pose_cells/peak") == int((~wrapped | snapped).sum())
    n_periodic = lambda every: len(range(0, N_TICKS, every)) + ((N_TICKS - 1) % every != 0)  # noqa: E731
    assert rows(by_entity, "/pose_cells/activity") == n_periodic(EVERY_ACTIVITY)
    for e in (
        "/world/ratslam/experiences",
        "/world/ratslam/links",
        "/world/gtsam/estimate",
        "/metrics/count/experiences",
    ):
        assert rows(by_entity, e) == n_periodic(EVERY_MAP), e
    assert rows(by_entity, "/metrics/ate/odometry") == n_periodic(EVERY_MAP) - 1  # needs two poses
    assert rows(by_entity, "/world/false_positives") == len(FP_TICKS)


def test_a_growing_map_is_relogged_less_often(tmp_path):
    """Past ``map_size`` places (experiences and keyframes) the maps are re-logged every
    ``every_map`` times ``places // map_size`` ticks: the gaps grow with the map, in whole
    multiples of ``every_map``, and the last tick still has the final maps."""
    path = tmp_path / "r.rrd"
    make_recording(path, every_map=10, map_size=8)  # the fake's map grows by 0.15 places a tick
    chunks = [c for c in RrdReader(path).store().stream().to_chunks() if c.entity_path == "/world/ratslam/experiences"]
    ticks = np.sort(np.concatenate([c.to_record_batch().column("tick").cast(pa.int64()).to_numpy() for c in chunks]))
    gaps = np.diff(ticks[:-1])  # the last re-log is the final one, at the last tick
    assert ticks[-1] == N_TICKS - 1
    assert np.all(gaps % 10 == 0) and np.all(np.diff(gaps) >= 0)
    assert gaps[0] == 10 and gaps[-1] >= 40  # 0.15 * 250 places // 8 -> every 40 ticks or more
    assert len(ticks) < len(range(0, N_TICKS, 10))


def test_per_tick_rows_are_each_tick_once(recording):
    """Every tick 1..N-1 exactly once, each segment from the previous true position to the
    current one (the buffers are reused between batches, the file must not alias them)."""
    _, _, _, by_entity = recording
    ticks, strips = column(by_entity, "/world/ground_truth", "LineStrips2D:strips")
    np.testing.assert_array_equal(ticks, np.arange(1, N_TICKS))
    for k, strip in zip(ticks[::37], strips[::37]):
        np.testing.assert_allclose(strip[0], [ground_truth(k - 1)[:2], ground_truth(k)[:2]], atol=1e-5)


def test_snaps_drawn_distinctly(recording):
    _, _, _, by_entity = recording
    ticks, colors = column(by_entity, "/pose_cells/peak", "LineStrips2D:colors")
    _, radii = column(by_entity, "/pose_cells/peak", "LineStrips2D:radii")
    i = int(np.flatnonzero(ticks == SNAP_TICK)[0])
    rgba = lambda c: ((c >> 24) & 255, (c >> 16) & 255, (c >> 8) & 255, c & 255)  # noqa: E731
    assert rgba(colors[i][0]) == C_SNAP
    others = [j for j in range(len(ticks)) if j != i]
    assert all(rgba(colors[j][0]) != C_SNAP for j in others)
    assert radii[i][0] < min(radii[j][0] for j in others)


def test_maps_drawn_aligned_to_ground_truth(recording):
    """The experience map and GTSAM estimate live in their own frames (rotated 0.3 and -0.5
    rad); the recording shows them aligned, on top of the true positions."""
    _, info, _, by_entity = recording
    _, pts = column(by_entity, "/world/ratslam/experiences", "Points2D:positions")
    final = np.array(pts[-1])
    truth = np.array([ground_truth(k)[:2] for k in info["rs"].experience_first_tick])
    np.testing.assert_allclose(final, truth, atol=1e-4)
    _, strips = column(by_entity, "/world/gtsam/estimate", "LineStrips2D:strips")
    truth = np.array([ground_truth(k)[:2] for k in info["pg"].keyframe_ticks])
    np.testing.assert_allclose(np.array(strips[-1][0]), truth, atol=1e-4)
    _, ate = column(by_entity, "/metrics/ate/experience_map", "Scalars:scalars")
    assert max(v[0] for v in ate) < 1e-5


def test_rrd_verify_accepts_file(recording):
    path, *_ = recording
    rerun = Path(sys.executable).parent / "rerun"
    res = subprocess.run([str(rerun), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr[-2000:]


def test_without_ground_truth(tmp_path):
    """A replayed log without ground truth: no ground-truth trail, maps in their own frames."""
    path = tmp_path / "r.rrd"
    info = make_recording(path, with_gt=False)
    by_entity = {}
    for c in RrdReader(path).store().stream().to_chunks():
        by_entity.setdefault(c.entity_path, []).append(c)
    assert "/world/ground_truth" not in by_entity
    assert "/metrics/ate/experience_map" not in by_entity
    _, pts = column(by_entity, "/world/ratslam/experiences", "Points2D:positions")
    np.testing.assert_allclose(np.array(pts[-1]), info["rs"].experience_poses[:, :2], atol=1e-4)


def test_abort_leaves_nothing(tmp_path):
    path = tmp_path / "r.rrd"
    with pytest.raises(KeyError), Recorder(path, None, GRID) as rec:
        rec.log_tick(0, 0.0, None, np.zeros(3))
        raise KeyError("interrupted")
    assert list(tmp_path.iterdir()) == []


def test_stream_recorder_is_aborted_on_an_error(tmp_path):
    """Used as a context manager, a StreamRecorder closes on success and, on an error inside the
    block, removes its partial file: no recording.rrd, nothing half-written."""
    from harness.record.recorder import StreamRecorder

    n = 5
    odo = np.zeros((n, 3))
    t = np.arange(n) * 0.1
    with (
        pytest.raises(RuntimeError, match="run failed"),
        StreamRecorder(Recorder(tmp_path / "recording.rrd", None, GRID), t, odo) as rec,
    ):
        rec.on_tick(0, None, None)
        raise RuntimeError("run failed")
    assert list(tmp_path.iterdir()) == []
    with StreamRecorder(Recorder(tmp_path / "recording.rrd", None, GRID), t, odo) as rec:
        rec.on_tick(0, None, None)
    assert [p.name for p in tmp_path.iterdir()] == ["recording.rrd"]


def test_a_failing_run_leaves_no_recording(tmp_path, monkeypatch):
    """A run that fails part-way through its stream aborts the recording it was writing."""
    import harness.figures.stream_run as fr
    from baselines import PoseGraphConfig
    from harness.record.recorder import recorder_factory
    from harness.run.progress import Progress
    from ratslam import RatSLAMConfig
    from worlds import load_world, simulate

    world = load_world("small_loop")
    log = simulate(world, duration=5.0, seed=0)

    def failing_run_stream(log, rs_cfg, pg_cfg, on_tick=None, progress=None, odometry=None, alternatives=None):
        from baselines import PoseGraphSLAM
        from ratslam import RatSLAM

        rs, pg = RatSLAM(rs_cfg), PoseGraphSLAM(pg_cfg)
        for k in range(10):
            rs.step(log.dt[k], log.v_trans[k], log.v_rot[k], log.scene_id[k])
            on_tick(k, rs, pg)
        raise RuntimeError("failed at tick 10")

    monkeypatch.setattr(fr, "run_stream", failing_run_stream)
    with pytest.raises(RuntimeError, match="tick 10"):
        fr.run_single_stream(
            tmp_path,
            log,
            RatSLAMConfig(),
            PoseGraphConfig(),
            config_header="test",
            progress=Progress(len(log), "test", enabled=False),
            world=world,
            recorder_factory=recorder_factory,
        )
    assert not [p.name for p in tmp_path.iterdir() if ".rrd" in p.name]


def test_bad_config_is_one_line_value_error(tmp_path):
    with pytest.raises(ValueError, match="every_map"):
        Recorder(tmp_path / "r.rrd", None, GRID, every_map=0)
    assert list(tmp_path.iterdir()) == []


@pytest.fixture(scope="module")
def real_run(tmp_path_factory):
    """60 s of the small loop through both real systems, recorded by the runner's callback."""
    from harness.record.recorder import recorder_factory
    from harness.run.runner import dead_reckon, run_stream
    from ratslam import RatSLAMConfig
    from worlds import load_world, simulate

    world = load_world("small_loop")
    log = simulate(world, duration=60.0, seed=0, fp_rate=0.01)
    out = tmp_path_factory.mktemp("real")
    cfg = RatSLAMConfig()
    odometry = dead_reckon(log)
    stream = recorder_factory(out, world, log, cfg, odometry)
    res = run_stream(log, cfg, on_tick=stream.on_tick, odometry=odometry)
    assert res.odometry is odometry  # dead-reckoned once, for the runner and the recorder
    path = stream.close()
    return path, log, res


def test_recording_of_a_real_run(real_run):
    """The runner's callback records every tick of a simulated run; the final experience map
    in the file has as many nodes as the system's map."""
    path, log, res = real_run
    assert path.name == "recording.rrd" and path.exists()
    by_entity = {}
    for c in RrdReader(path).store().stream().to_chunks():
        by_entity.setdefault(c.entity_path, []).append(c)
    assert rows(by_entity, "/world/ground_truth") == len(log) - 1
    assert rows(by_entity, "/world/false_positives") == int(log.false_positive.sum())
    _, pts = column(by_entity, "/world/ratslam/experiences", "Points2D:positions")
    assert len(pts[-1]) == len(res.ratslam.experience_poses)
    _, snaps = column(by_entity, "/metrics/count/snaps", "Scalars:scalars")
    assert snaps[-1][0] == int(res.snapped.sum())


def test_screenshot_shows_every_panel(real_run, tmp_path):
    """Opened headless in the viewer, the default blueprint shows its four views without a
    reported problem, at the last tick."""
    from harness.record.screenshot import ScreenshotError, screenshot

    path, log, _ = real_run
    try:
        out = screenshot(path, tmp_path / "shot.png", size="1280x720", timeout=60)
    except ScreenshotError as e:
        if "Vulkan" in str(e):
            pytest.skip(str(e))
        raise
    assert out["tick"] == len(log) - 1
    assert len(out["views"]) == 4 and all(not problems for problems in out["views"].values()), out["views"]
    assert out["png"].stat().st_size > 20_000


def test_screenshot_errors_are_one_line(tmp_path, monkeypatch):
    import harness.record.screenshot as shot

    with pytest.raises(shot.ScreenshotError, match="no such recording"):
        shot.screenshot(tmp_path / "missing.rrd", tmp_path / "x.png")
    (tmp_path / "r.rrd").write_bytes(b"")
    monkeypatch.setattr(shot, "VULKAN_ICD_DIRS", (str(tmp_path / "none"),))
    monkeypatch.delenv("VK_ICD_FILENAMES", raising=False)
    monkeypatch.delenv("VK_DRIVER_FILES", raising=False)
    assert shot.main([str(tmp_path / "r.rrd"), str(tmp_path / "x.png")]) == 1
    with pytest.raises(shot.ScreenshotError, match="mesa-vulkan-drivers") as e:
        shot.screenshot(tmp_path / "r.rrd", tmp_path / "x.png")
    assert "\n" not in str(e.value)
