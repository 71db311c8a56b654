"""Image logs from ROS bags (ROS 1 and ROS 2, raw and compressed image topics) and from video:
bags written here from the simulator's rendered camera are imported and replayed end to end
(both systems, ATE against the bag's ground truth, a report), and every bad input is one line that
writes nothing."""

from __future__ import annotations

import dataclasses
import json
import math
import struct
import zlib

import numpy as np
import pytest

pytest.importorskip("rosbags")

from PIL import Image

from harness.camera.stream import match_camera_log, read_image
from harness.figures.run import replay
from ratslam import ViewConfig
from tests.recordings import T0, Bag, png, simulated_run, write_run_bag, write_tum, write_video
from worlds import ObservationLog
from worlds.bag_images import import_bag_images
from worlds.errors import InputError
from worlds.image_decode import decode_raw
from worlds.image_log import CAMERA_FILE, CameraDescription, images_folder, read_camera_description
from worlds.image_pairing import pair_ticks
from worlds.images import MAX_IMAGE_PIXELS, ImageReadError, read_grey


@pytest.fixture(scope="module")
def run():
    """40 s of the small loop: the odometry dead-reckoned, the true poses, the rendered frames."""
    return simulated_run("small_loop", 40.0, 3)


@pytest.fixture
def av():
    return pytest.importorskip("av", reason="the video import needs PyAV: pip install -e '.[video]'")


def test_ros2_raw_and_ros1_compressed_bags_give_the_rendered_frames_and_field_of_view(run, tmp_path):
    log, frames, *_ = run
    for ros, compressed, topic in ((2, False, "/camera/image_raw"), (1, True, "/camera/image_raw/compressed")):
        bag = write_run_bag(tmp_path / (f"ros{ros}.bag" if ros == 1 else "ros2"), run, ros, compressed)
        out = tmp_path / f"ros{ros}.csv"
        result = import_bag_images(bag, "/odom", topic, out, ground_truth_topic="/ground_truth")
        got = ObservationLog.read_csv(out)
        assert len(got) == len(log) and result.images == len(log) and result.dropped == 0
        np.testing.assert_allclose(got.v_trans, log.v_trans, atol=1e-9)
        np.testing.assert_allclose(got.ground_truth()[:, :2], log.ground_truth()[:, :2], atol=1e-9)
        for k in (0, 111, len(log) - 1):  # each tick's own frame, bit for bit
            assert np.array_equal(read_image(out, k + 2, got.image[k]), frames[k])
        assert result.fov_deg == pytest.approx(50.0, abs=1e-9)
        assert read_camera_description(out, got.image[0]).field_of_view_deg == result.fov_deg
        assert "field_of_view_deg = 50.0" in (images_folder(out) / CAMERA_FILE).read_text()


def test_a_bag_replays_end_to_end_as_the_rendered_camera_log(run, tmp_path, capsys):
    """Imported from a bag, the images give the matcher the same templates as the rendered frames,
    and both systems' trajectories (ATE against the bag's ground truth, a report) are those of the
    same run written by ``simulate --camera``; the bag's recording shows each tick's image."""
    from harness.camera.stream import write_images
    from harness.cli import main
    from harness.record.recorder import recorder_factory

    from .test_camera_recording import _images

    log, frames, *_ = run
    bag = write_run_bag(tmp_path / "run", run, 2, compressed=False)
    out = tmp_path / "cam.csv"
    argv = ["import", "rosbag", str(bag), "--odom", "/odom", "--gt", "/ground_truth", "--image", "/camera/image_raw"]
    assert main([*argv, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {out} ({len(log)} ticks, {len(log)} images of 64 x 16 in cam_images/, ground truth" in printed
    assert (
        "field of view 50.00 deg (/camera/camera_info: fx = " in printed and f"in cam_images/{CAMERA_FILE}" in printed
    )
    matched = match_camera_log(ObservationLog.read_csv(out), out, ViewConfig())
    np.testing.assert_array_equal(matched.scene_id, [m.template for m in map(_matcher().match, frames)])
    reference = tmp_path / "ref.csv"
    images = write_images(frames / 255.0, reference, CameraDescription(50.0))
    dataclasses.replace(log, image=images).write_csv(reference)
    metrics = {}
    for name, path in (("bag", out), ("simulated", reference)):  # each with its camera.toml, no configuration
        recorder = recorder_factory if name == "bag" else None
        run_dir = replay(path, tmp_path / name, show_progress=False, recorder_factory=recorder)
        assert (run_dir / "report.md").is_file() and (run_dir / "trajectories" / "ratslam.tum").is_file()
        metrics[name] = json.loads((run_dir / "metrics.json").read_text())["variants"]["replay"]
    got, want = metrics["bag"], metrics["simulated"]
    print(got["ate"])
    assert got["ticks"] == len(log) and got["experiences"] == want["experiences"] > 1
    assert got["keyframes"] == want["keyframes"] > 1
    assert set(got["ate"]) >= {"odometry", "experience_map", "gtsam"}
    for key, value in want["ate"].items():  # the bag's odometry: pose differences, equal to 1e-12
        assert got["ate"][key] == pytest.approx(value, rel=1e-6, abs=1e-9), key
    recorded = _images(tmp_path / "bag" / "recording.rrd", "/camera/image")
    assert sorted(recorded) == list(range(len(log)))
    for k in (0, len(log) - 1):
        assert np.array_equal(recorded[k], frames[k].ravel())


def _matcher():
    from ratslam.view_matcher import ViewMatcher

    return ViewMatcher(ViewConfig())


def test_ticks_before_the_first_image_are_dropped(run, tmp_path):
    bag = write_run_bag(tmp_path / "late.bag", run, 1, compressed=False, camera_info=False, image_from=10)
    out = tmp_path / "late.csv"
    result = import_bag_images(bag, "/odom", "/camera/image_raw", out)
    assert result.dropped == 10 and len(result.log) == len(run[0]) - 10 and result.fov_deg is None
    assert not (images_folder(out) / CAMERA_FILE).exists()


def test_pairing_takes_the_latest_image_at_or_before_each_tick():
    frames = np.array([0.0, 0.25, 0.5, 0.75])
    ticks = np.array([-0.1, 0.0, 0.2, 0.5, 0.74, 0.9])
    np.testing.assert_array_equal(pair_ticks(frames, ticks, np.full(6, 0.1)).latest, [-1, 0, 0, 2, 2, 3])
    # a camera that starts late and stops early: ticks before its first frame, and beyond the last
    # frame plus two frame intervals, are dropped
    ticks = np.arange(1, 21) * 0.1
    pairing = pair_ticks(frames + 0.22, ticks, np.full(20, 0.1))
    assert (pairing.first, pairing.end) == (2, 14)  # 0.3 ... 1.4 s (0.97 + 2 x 0.25)
    assert pairing.dropped() == (2, 6)


# --- decoding --------------------------------------------------------------------------------


def test_every_raw_encoding_with_row_padding_and_byte_order():
    rng = np.random.default_rng(0)
    rgb = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
    grey = np.asarray(Image.fromarray(rgb, "RGB").convert("L"))  # Pillow's luma
    alpha = np.full((5, 7, 1), 9, np.uint8)
    cases = {
        "rgb8": rgb,
        "bgr8": rgb[..., ::-1],
        "rgba8": np.concatenate([rgb, alpha], axis=2),
        "bgra8": np.concatenate([rgb[..., ::-1], alpha], axis=2),
    }
    for encoding, pixels in cases.items():
        bpp = pixels.shape[2]
        data = np.hstack([pixels.reshape(5, -1), np.full((5, 3), 77, np.uint8)])  # 3 bytes of padding a row
        got = decode_raw(encoding, 5, 7, 7 * bpp + 3, False, data.ravel(), "x")
        assert np.array_equal(got, grey), encoding
    mono = rng.integers(0, 256, (5, 7), dtype=np.uint8)
    assert np.array_equal(decode_raw("mono8", 5, 7, 7, False, mono.ravel(), "x"), mono)
    deep = rng.integers(0, 65536, (5, 7), dtype=np.uint16)
    for big, dtype in ((False, "<u2"), (True, ">u2")):
        data = deep.astype(dtype).view(np.uint8)
        assert np.array_equal(decode_raw("mono16", 5, 7, 14, big, data.ravel(), "x"), (deep >> 8).astype(np.uint8))
    assert np.array_equal(read_grey(png(mono), "x"), mono)
    png16 = __import__("io").BytesIO()
    Image.fromarray(deep).save(png16, format="PNG")
    assert np.array_equal(read_grey(png16.getvalue(), "x"), (deep >> 8).astype(np.uint8))
    jpeg = __import__("io").BytesIO()
    Image.fromarray(rgb, "RGB").save(jpeg, format="JPEG", quality=95)
    assert np.abs(read_grey(jpeg.getvalue(), "x").astype(int) - grey).max() < 20  # lossy


def _png_header(width: int, height: int) -> bytes:
    """A PNG that declares width x height grey pixels and carries one row of them."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b"")


def test_decode_errors():
    with pytest.raises(ImageReadError, match=r"x: encoding 'yuv422' not read"):
        decode_raw("yuv422", 2, 2, 4, False, np.zeros(8, np.uint8), "x")
    with pytest.raises(ImageReadError, match=r"x: 7 bytes of data, step x height needs 8 \(truncated\)"):
        decode_raw("mono8", 2, 4, 4, False, np.zeros(7, np.uint8), "x")
    with pytest.raises(ImageReadError, match="x: step 3 is less than"):
        decode_raw("mono8", 2, 4, 3, False, np.zeros(8, np.uint8), "x")
    side = int(math.isqrt(MAX_IMAGE_PIXELS)) + 1
    with pytest.raises(ImageReadError, match=rf"x: declares {side}x{side} pixels, more than"):
        read_grey(_png_header(side, side), "x")
    for side in (10_000, 100_000):  # Pillow's own bomb checks (a warning, then an error), beyond ours: one line
        with pytest.raises(
            ImageReadError, match=r"^x: declares .*\(a decompression bomb\?\); refused before decoding$"
        ):
            read_grey(_png_header(side, side), "x")
    with pytest.raises(ImageReadError, match="x: truncated image"):
        read_grey(png(np.zeros((40, 40), np.uint8))[:-30], "x")
    with pytest.raises(ImageReadError, match="x: not a PNG or JPEG image"):
        read_grey(b"GIF89a not really", "x")


# --- bad bags: one line each, nothing written ----------------------------------------------------


def _small_bag(path, images, ros: int = 2):
    """Ten odometry ticks at 10 Hz and ``images(bag, t)`` called at each tick's time."""
    bag = Bag(path, ros)
    for k in range(11):
        t = T0 + 0.1 * k
        bag.pose("/odom", t, 0.05 * k, 0.0, 0.0)
        images(bag, t, k)
    bag.close()
    return path


def _bad(kind):
    grey = np.zeros((8, 16), np.uint8)

    def images(bag, t, k):
        if kind == "empty":
            if k == 0:
                bag.topic("/cam/image", "sensor_msgs/msg/Image")
        elif kind == "encoding":
            bag.raw_image("/cam/image", t, grey, encoding="yuv422")
        elif kind == "size":
            bag.raw_image("/cam/image", t, grey if k < 4 else np.zeros((8, 20), np.uint8))
        elif kind == "truncated":
            bag.compressed("/cam/image", t, png(grey + k)[: -30 if k == 6 else None])
        elif kind == "bomb":
            bag.compressed("/cam/image", t, _png_header(8000, 8000) if k == 3 else png(grey))
        elif kind == "format":
            bag.compressed("/cam/image", t, png(grey), fmt="16UC1; compressedDepth")

    return images


@pytest.mark.parametrize(
    "kind, expected",
    [
        ("empty", "topic /cam/image (images): no messages"),
        ("encoding", "topic /cam/image: message 1: encoding 'yuv422' not read (read: mono8, mono16, rgb8"),
        ("size", "topic /cam/image: message 5: 20x8 pixels, but the first image is 16x8"),
        ("truncated", "topic /cam/image: message 7: truncated image"),
        ("bomb", "topic /cam/image: message 4: declares 8000x8000 pixels, more than 40,000,000"),
        ("format", "topic /cam/image: message 1: compressed format '16UC1; compressedDepth' not read"),
    ],
)
def test_bad_image_topics_are_one_line_and_write_nothing(tmp_path, kind, expected):
    bag = _small_bag(tmp_path / "bad", _bad(kind))
    before = sorted(p.name for p in tmp_path.iterdir())
    out = tmp_path / "log.csv"
    with pytest.raises(InputError) as e:
        import_bag_images(bag, "/odom", "/cam/image", out)
    assert str(e.value).startswith(f"{bag}: ") and expected in str(e.value), str(e.value)
    assert "\n" not in str(e.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no log, no images, no staging folder
    assert not images_folder(out).exists()


def test_cli_refuses_an_unknown_encoding_in_one_line(tmp_path, capsys):
    from harness.cli import main

    bag = _small_bag(tmp_path / "bad.bag", _bad("encoding"), ros=1)
    out = tmp_path / "log.csv"
    assert main(["import", "rosbag", str(bag), "--odom", "/odom", "--image", "/cam/image", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert f"{bag}: topic /cam/image: message 1: encoding 'yuv422' not read" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.bag"]


# --- video ---------------------------------------------------------------------------------------


def test_a_video_replays_end_to_end(run, tmp_path, capsys, av):
    """H.264 video (the container's own frame times) plus TUM odometry and ground truth: each tick
    gets its frame (lossy: within a few grey levels), and both systems run on the matched views."""
    from harness.cli import main

    log, frames, odo, gt, t = run
    video = write_video(tmp_path / "run.mp4", np.concatenate([frames[:1], frames]), "libx264")
    odom, truth = write_tum(tmp_path / "odom.tum", t, odo), write_tum(tmp_path / "gt.tum", t, gt)
    out = tmp_path / "video.csv"
    assert main(["import", "video", str(video), "--odometry", str(odom), "--gt", str(truth), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"wrote {out} ({len(log)} ticks, {len(log)} images of 64 x 16 in video_images/, ground truth" in printed
    assert "field of view unknown (a video does not say)" in printed
    got = ObservationLog.read_csv(out)
    for k in (0, 140, len(log) - 1):
        assert np.abs(read_image(out, k + 2, got.image[k]).astype(int) - frames[k]).mean() < 3.0
    run_dir = replay(out, tmp_path / "replay", show_progress=False, fov_deg=50.0)  # the video's unknown
    metrics = json.loads((run_dir / "metrics.json").read_text())
    replayed = metrics["variants"]["replay"]
    print(replayed["ate"])
    assert replayed["ticks"] == len(log) and set(replayed["ate"]) >= {"odometry", "experience_map", "gtsam"}


def test_video_frame_times_from_fps_a_timestamps_file_or_the_container(run, tmp_path, av):
    from worlds.video_import import import_video

    _, frames, odo, _, t = run
    n = 30
    video = write_video(tmp_path / "v.mkv", frames[:n], "ffv1")  # lossless
    odom = write_tum(tmp_path / "odom.tum", t[:n], odo[:n])
    stamps = tmp_path / "stamps.txt"
    stamps.write_text("".join(f"{float(tk)!r}\n" for tk in t[:n]))
    # the container's own times (Matroska: rounded to 1 ms, so up to half a millisecond after the tick)
    for kwargs in ({"fps": 7.0}, {"timestamps": stamps}, {}):
        out = tmp_path / f"{''.join(kwargs) or 'container'}.csv"
        result = import_video(video, odom, out, **kwargs)
        assert len(result.log) == n - 1 and result.images == n - 1  # tick j: the frame taken at pose j
        for j in (0, n - 2):
            assert np.array_equal(read_image(out, j + 2, result.log.image[j]), frames[j + 1])
    # a field of view given goes into the log's camera.toml, where replay reads it
    result = import_video(video, odom, tmp_path / "fov.csv", fps=7.0, fov_deg=50.0)
    assert read_camera_description(tmp_path / "fov.csv", result.log.image[0]) == CameraDescription(
        50.0, source="ratslam-harness import video"
    )


@pytest.mark.parametrize(
    "case, expected",
    [
        ("bomb", "declares 64x16 pixels, more than 1,000 (a decompression bomb?); refused before decoding"),
        ("short", "the video is shorter than the odometry: its 20 frames cover 1000.000-1002.857 s, the odometry"),
        ("count", "20 frames, but {stamps} has 19 timestamps"),
    ],
)
def test_bad_videos_are_one_line_and_write_nothing(run, tmp_path, case, expected, av, monkeypatch):
    from worlds import images
    from worlds.video_import import import_video

    if case == "bomb":  # the limit lowered below the video's size: refused before a frame is decoded
        monkeypatch.setattr(images, "MAX_IMAGE_PIXELS", 1000)

    _, frames, odo, _, t = run
    video = write_video(tmp_path / "v.mkv", frames[:20], "ffv1")
    odom = write_tum(tmp_path / "odom.tum", t[:40], odo[:40])
    stamps = tmp_path / "stamps.txt"
    stamps.write_text("".join(f"{float(tk)!r}\n" for tk in t[:19]))
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(InputError) as e:
        import_video(video, odom, tmp_path / "log.csv", timestamps=stamps if case == "count" else None)
    assert str(e.value).startswith(f"{video}: ") and expected.format(stamps=stamps) in str(e.value), str(e.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_field_of_view_from_camera_info_found_given_or_uncalibrated(tmp_path):
    grey = np.zeros((8, 16), np.uint8)

    def images(bag, t, k):
        bag.raw_image("/cam/left/image", t, grey)
        if k == 0:
            bag.camera_info("/cam/left/camera_info", t, 8.0, 16, 8)  # 2 atan(16 / 16) = 90 degrees
            bag.camera_info("/cam/uncalibrated", t, 0.0, 16, 8)

    bag = _small_bag(tmp_path / "bag", images)
    found = import_bag_images(bag, "/odom", "/cam/left/image", tmp_path / "a.csv")
    assert found.fov_deg == pytest.approx(90.0) and "/cam/left/camera_info: fx = 8 px" in found.fov_note
    described = read_camera_description(tmp_path / "a.csv", found.log.image[0])
    assert described.field_of_view_deg == found.fov_deg  # what replay reads from the log's camera.toml
    with pytest.raises(InputError, match=r"bag: topic /cam/uncalibrated: fx = K\[0\] = 0 and width 16: not a calibr"):
        import_bag_images(bag, "/odom", "/cam/left/image", tmp_path / "b.csv", camera_info_topic="/cam/uncalibrated")
    assert not (tmp_path / "b.csv").exists()
