"""A camera run's recording (the view and its matched template each tick) and the configurations a
camera stream gets (:func:`harness.camera.stream.camera_configs`)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

from baselines import PoseGraphConfig
from harness.camera.stream import (
    camera_configs,
    camera_view_config,
    camera_views,
    match_heading_sigma,
)
from ratslam import RatSLAMConfig
from worlds import load_world, simulate


@pytest.fixture(scope="module")
def camera_run(tmp_path_factory):
    """20 s of the small loop seen by the forward camera, through both systems, recorded."""
    from harness.figures.stream_run import run_single_stream
    from harness.record.recorder import recorder_factory
    from harness.run.progress import Progress

    world = load_world("small_loop")
    log = simulate(world, duration=20.0, seed=0)
    view = camera_view_config("forward")
    log, views = camera_views(world, log, "forward", 0, view)
    out = tmp_path_factory.mktemp("camera_run")
    run_single_stream(
        out,
        log,
        RatSLAMConfig(view=view),
        PoseGraphConfig(),
        config_header="test",
        progress=Progress(len(log), "test", enabled=False),
        world=world,
        recorder_factory=recorder_factory,
        camera=views,
    )
    return out / "recording.rrd", log, views


def _images(path, entity):
    """An image entity's pixels by tick."""
    out = {}
    for c in RrdReader(path).store().stream().to_chunks():
        if c.entity_path != entity:
            continue
        rb = c.to_record_batch()
        if "tick" not in rb.schema.names:  # the static magnification filter
            continue
        ticks = rb.column("tick").cast(pa.int64()).to_numpy()
        buffers = rb.column(next(n for n in rb.schema.names if n.endswith("Image:buffer"))).to_pylist()
        for k, buf in zip(ticks, buffers):
            out[int(k)] = np.asarray(buf[0] if buf and isinstance(buf[0], list) else buf, dtype=np.uint8)
    return out


def test_the_recording_shows_each_view_and_its_template(camera_run):
    """Every tick of a camera run records the camera image and the stored template it matched
    (pixel for pixel), and the blueprint has the two camera panels."""
    path, log, views = camera_run
    image, template = _images(path, "/camera/image"), _images(path, "/camera/template")
    assert sorted(image) == sorted(template) == list(range(len(log)))
    for k in (0, len(log) // 2, len(log) - 1):
        assert np.array_equal(image[k], views.images[k].ravel())
        assert np.array_equal(template[k], views.templates[log.scene_id[k]].ravel())
    assert len(views.templates) == log.scene_id.max() + 1 > 1


def test_a_scene_number_recording_has_no_camera(tmp_path):
    """A run of scene numbers records no camera entity (its recording as before)."""
    from harness.record.recorder import recorder_factory
    from harness.run.runner import dead_reckon

    world = load_world("small_loop")
    log = simulate(world, duration=5.0, seed=0)
    stream = recorder_factory(tmp_path, world, log, RatSLAMConfig(), dead_reckon(log))
    for k in range(len(log)):
        stream.on_tick(k, None, None)
    path = stream.close()
    assert not {c.entity_path for c in RrdReader(path).store().stream().to_chunks()} & {
        "/camera/image",
        "/camera/template",
    }


def test_the_heading_a_match_gives_comes_from_the_matchers_settings():
    forward, panoramic = camera_view_config("forward"), camera_view_config("panoramic")
    assert math.degrees(match_heading_sigma(forward)) == pytest.approx(40 / math.sqrt(12))
    assert math.degrees(match_heading_sigma(panoramic)) == pytest.approx(360 / math.sqrt(12))


def test_camera_configs_from_the_stream_alone():
    """The derivation reads the stream's template numbers, speed and tick (never its ground truth):
    a forward stream's match gives the heading to +-20 degrees, its 5-tick templates the position
    to a quarter of a 1 m scene cell's, and everything else stays at the defaults."""
    world = load_world("small_loop")
    log = simulate(world, duration=60.0, seed=0)
    n = len(log)
    nan = np.full(n, np.nan)
    log = dataclasses.replace(log, scene_id=np.arange(n) // 5, gt_x=nan, gt_y=nan, gt_theta=nan)
    view = camera_view_config("forward")
    rs0, pg0 = RatSLAMConfig(view=view), PoseGraphConfig()
    rs, pg, text = camera_configs(log, view, rs0, pg0)
    assert pg.closures.sigma_theta_rad == pytest.approx(match_heading_sigma(view))
    assert rs.yaw_bias.revisit_sigma_heading_deg == pytest.approx(math.degrees(match_heading_sigma(view)), abs=1e-3)
    # 5 ticks at 0.3 m/s and 7 Hz: 0.21 m, x0.25 of 0.9 m on the ladder
    assert pg.closures.sigma_xy_m == pytest.approx(pg0.closures.sigma_xy_m / 4)
    assert rs.yaw_bias.revisit_sigma_xy_m == pytest.approx(rs0.yaw_bias.revisit_sigma_xy_m / 4)
    assert (
        rs.replace(yaw_bias=dataclasses.asdict(rs0.yaw_bias)) == rs0
        and pg.replace(closures=dataclasses.asdict(pg0.closures)) == pg0
    )
    assert "5.0 ticks" in text and "11.5 deg" in text


def test_a_bad_view_setting_in_a_configuration_file_is_one_line(tmp_path):
    """The matcher's settings in a configuration file: a bad value is one line naming the file,
    the table and the field."""
    from harness.run.config_file import ConfigFileError, read_config_file

    p = tmp_path / "c.toml"
    p.write_text("[ratslam.view]\nmatch_threshold = -1\n")
    with pytest.raises(ConfigFileError) as e:
        read_config_file(p)
    message = str(e.value)
    assert "\n" not in message and message.startswith(f"{p}: [ratslam.view] match_threshold: must be")
