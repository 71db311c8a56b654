"""Camera logs: ``simulate --camera`` writes the images, a log with an ``image`` column is read,
matched into template numbers and rotations, and replayed through both systems."""

import json
import math

import numpy as np
import pytest

from harness.camera.stream import match_camera_log, read_image
from harness.figures.run import replay
from harness.record.log_output import simulate_to_files
from ratslam import ViewConfig
from tests.helpers import cli
from worlds import ObservationLog, ObservationLogError
from worlds.camera import Camera, to_uint8


@pytest.fixture(scope="module")
def camera_log(tmp_path_factory):
    out = tmp_path_factory.mktemp("cam") / "log.csv"
    simulate_to_files("small_loop", out, duration=30.0, seed=2, camera="forward", show_progress=False)
    return out


def test_simulate_writes_a_camera_log(camera_log):
    log = ObservationLog.read_csv(camera_log)
    header = camera_log.read_text().splitlines()[0].split(",")
    assert "image" in header and "scene_id" not in header
    assert len(log) == 210 and log.image[0] == "log_images/000001.png"
    assert np.all(log.scene_id == -1)  # nothing matched yet
    # each PNG is the frame the camera renders at that tick's true pose
    cam = Camera("small_loop", "forward", seed=2)
    for k in (0, 100, 209):
        expected = to_uint8(cam.render(log.gt_x[k], log.gt_y[k], log.gt_theta[k], t=log.t[k], tick=k))
        assert np.array_equal(read_image(camera_log, k + 2, log.image[k]), expected)


def test_matching_gives_template_numbers_and_rotations(camera_log):
    log = match_camera_log(ObservationLog.read_csv(camera_log), camera_log, ViewConfig())
    assert log.scene_id[0] == 0 and log.scene_id.min() == 0
    assert 1 < log.scene_id.max() < len(log) / 3  # a corridor seen for a while is a few templates
    assert np.all(np.diff(np.maximum.accumulate(log.scene_id)) <= 1)  # numbered in order of storing
    assert log.view_rotation is not None and np.all(np.abs(log.view_rotation) <= math.radians(20.0) + 1e-12)
    assert np.any(log.view_rotation != 0.0)  # the robot turns at the corner


def test_replay_of_a_camera_log_runs_both_systems(camera_log, tmp_path):
    out = replay(camera_log, tmp_path / "run", show_progress=False, recorder_factory=None)
    metrics = json.loads((out / "metrics.json").read_text())["variants"]["replay"]
    assert metrics["ticks"] == 210 and metrics["experiences"] > 1 and metrics["keyframes"] > 1


def test_a_missing_image_is_one_line(camera_log, tmp_path):
    text = camera_log.read_text().replace("log_images/000005.png", "log_images/nowhere.png")
    bad = camera_log.with_name("bad.csv")
    bad.write_text(text)
    with pytest.raises(ObservationLogError) as e:
        match_camera_log(ObservationLog.read_csv(bad), bad, ViewConfig())
    assert str(e.value) == f"{bad}: line 6, column image: log_images/nowhere.png: no such file"
    both = camera_log.with_name("both.csv")
    both.write_text(text.replace("image,", "image,scene_id,", 1))
    with pytest.raises(ObservationLogError, match="instead of scene_id, not both"):
        ObservationLog.read_csv(both)


def test_cli_simulate_camera(tmp_path):
    out = tmp_path / "c.csv"
    r = cli("simulate", "small_loop", "--out", str(out), "--duration", "5", "--camera", "panoramic", "--quiet")
    assert r.returncode == 0, r.stderr
    assert "35 panoramic camera images in c_images/" in r.stdout
    assert read_image(out, 2, "c_images/000001.png").shape == (16, 128)


def test_a_figure_runs_from_the_camera(tmp_path):
    """``run FIG --camera forward``: both systems on the matcher's template numbers; the run says so."""
    from harness.figures.run import run_figure

    out = run_figure(
        "fig7", tmp_path / "fig7", duration=40.0, show_progress=False, variants=(), workers=1, camera="forward"
    )
    run = json.loads((out / "metrics.json").read_text())
    assert run["figure"]["title"].endswith("from the forward camera")
    assert run["provenance"]["camera"] == "forward"
    assert run["variants"]["default"]["experiences"] > 1
    with pytest.raises(Exception, match="no simulated world to render"):
        run_figure("plaza1", tmp_path / "p", duration=10.0, show_progress=False, camera="forward")


def test_a_variant_without_look_alikes_has_none_to_the_camera():
    """Fig 4's distinct-rooms variant: rooms B and C show their own scenes and their own walls."""
    from harness.figures.registry import Variant, get_figure
    from harness.figures.streams import variant_world
    from worlds import load_world

    office, fig4 = load_world("office_floor"), get_figure("fig4")
    distinct = variant_world(fig4, office, Variant("distinct_rooms", "own scenes", lookalikes=False))
    assert office.camera.same_as and distinct.camera.same_as == () and distinct.scenes.lookalikes == ()
    assert variant_world(fig4, office, Variant("default", "as shipped")).camera.same_as == office.camera.same_as
