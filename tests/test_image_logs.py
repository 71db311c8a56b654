"""Image logs from a user's robot: a folder of time-stamped images and an odometry trajectory
become an image log, replayed through the view matcher and both systems; the matcher's template
is derived from the image size, the field of view must be known, and bad images are refused in
one line naming the file and the log's line."""

import json
import math
import re
import shutil
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from harness.camera.stream import derived_template_size, match_camera_log, read_image
from harness.cli import main
from harness.figures.run import replay
from harness.run.runner import dead_reckon
from ratslam import ViewConfig
from worlds import InputError, ObservationLog, ObservationLogError, simulate
from worlds.camera import Camera, to_uint8
from worlds.files import write_tum
from worlds.image_folder import ImageFolderError, import_image_folder
from worlds.image_log import CAMERA_FILE, CameraDescription, write_image_log
from worlds.images import MAX_IMAGE_PIXELS, ImageReadError, read_grey

SECONDS = 25.0


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    """What a user's robot leaves: colour JPEGs (128x32, twice the simulator's forward camera)
    named by their time stamps at 5 Hz, and TUM odometry and ground truth at the 7 Hz ticks."""
    root = tmp_path_factory.mktemp("robot")
    log = simulate("small_loop", duration=SECONDS, seed=1)
    frames = Camera("small_loop", "forward", seed=1).render_poses(log.ground_truth(), log.t)
    folder = root / "frames"
    folder.mkdir()
    for k in range(len(log)):
        if k % 7 in (0, 3, 5):  # about 3 of every 7 ticks: a camera slower than the odometry
            grey = Image.fromarray(to_uint8(frames[k]), mode="L").resize((128, 32), Image.Resampling.BILINEAR)
            grey.convert("RGB").save(folder / f"{log.t[k] - 0.01:.3f}.jpg", quality=90)
    odom = dead_reckon(log)
    poses = np.vstack(([0.0, 0.0, 0.0], odom))
    t = np.concatenate(([0.0], log.t))
    write_tum(root / "odom.tum", t, poses[:, 0], poses[:, 1], poses[:, 2])
    gt = np.vstack(([log.gt_x[0], log.gt_y[0], log.gt_theta[0]], log.ground_truth()))
    write_tum(root / "gt.tum", t, gt[:, 0], gt[:, 1], gt[:, 2])
    return root


def test_an_image_folder_is_imported_and_replayed_through_both_systems(robot, capsys):
    out = robot / "log.csv"
    args = ["import", "images", str(robot / "frames"), "--odometry", str(robot / "odom.tum")]
    assert main([*args, "--gt", str(robot / "gt.tum"), "--out", str(out), "--fov", "50"]) == 0
    assert "ticks" in capsys.readouterr().out
    log = ObservationLog.read_csv(out)
    assert log.has_ground_truth and len(log) == round(SECONDS * 7)
    # each tick has the latest image taken at or before it
    stamps = np.array([float(Path(name).stem) for name in log.image])
    assert np.all(stamps <= log.t) and np.all(log.t - stamps < 3 / 7)
    assert (out.parent / "log_images" / CAMERA_FILE).read_text().count("field_of_view_deg = 50.0") == 1

    run = replay(out, robot / "run", show_progress=False, recorder_factory=None)
    metrics = json.loads((run / "metrics.json").read_text())["variants"]["replay"]
    for system in ("ratslam", "gtsam", "odometry", "ground_truth"):
        assert len((run / "trajectories" / f"{system}.tum").read_text().splitlines()) > 10
    ate = metrics["ate"]
    assert all(math.isfinite(ate[k]) for k in ("experience_map", "gtsam", "odometry"))
    assert metrics["experiences"] > 1 and metrics["keyframes"] > 1
    header = (run / "config.toml").read_text()
    assert "template 32x8 from the 128x32 (cropped) images" in header
    assert "template_width = 32" in header and "template_height = 8" in header
    # the threshold from the first minute's self-similarity, written where replay reads it back
    derived = re.search(r"match threshold ([0-9.]+) = 0\.9 x ([0-9.]+), the median", header)
    assert derived is not None and float(derived.group(1)) == pytest.approx(0.9 * float(derived.group(2)), rel=1e-3)
    written = float(re.search(r"match_threshold = ([0-9.e-]+)", header).group(1))
    assert written == pytest.approx(float(derived.group(1)), rel=1e-3) and written != ViewConfig().match_threshold


def test_a_configured_threshold_and_template_are_kept(robot, tmp_path):
    (tmp_path / "c.toml").write_text(
        "[ratslam.view]\nmatch_threshold = 0.05\ntemplate_width = 16\nfield_of_view_deg = 40.0\n"
    )
    out = tmp_path / "log.csv"
    paired = import_image_folder(robot / "frames", robot / "odom.tum")
    write_image_log(out, paired.odometry, paired.images)  # no camera.toml: the configuration's field of view
    from harness.run.config_file import read_config_file

    run = replay(
        out, tmp_path / "run", show_progress=False, recorder_factory=None, config=read_config_file(tmp_path / "c.toml")
    )
    config = (run / "config.toml").read_text()
    assert "match_threshold = 0.05\n" in config and "field_of_view_deg = 40.0\n" in config
    assert "template_width = 16\n" in config and "template_height = 4\n" in config  # rows in the images' aspect


def test_the_template_is_derived_from_the_image_size():
    assert derived_template_size(64, 16, panoramic=False) == (32, 8)  # the simulator's: the defaults
    assert derived_template_size(128, 16, panoramic=True) == (64, 8)
    assert derived_template_size(128, 32, panoramic=False) == (32, 8)
    assert derived_template_size(640, 480, panoramic=False) == (32, 16)  # at most 16 rows
    assert derived_template_size(40, 30, panoramic=False) == (20, 15)
    assert derived_template_size(5, 3, panoramic=False) == (2, 1)


@pytest.fixture
def grey_log(tmp_path):
    """A 12-tick image log of 64x16 grey frames, written without a camera description."""
    rng = np.random.default_rng(0)
    odometry = ObservationLog(
        t=np.arange(1, 13) / 7.0,
        dt=np.full(12, 1 / 7.0),
        v_trans=np.full(12, 0.3),
        v_rot=np.zeros(12),
        scene_id=np.full(12, -1),
    )
    frames = [rng.integers(0, 256, (16, 64), dtype=np.uint8) for _ in range(12)]
    return write_image_log(tmp_path / "g.csv", odometry, iter(frames)), tmp_path / "g.csv"


def test_without_a_field_of_view_replay_says_how_to_give_it(grey_log, tmp_path, capsys):
    _, path = grey_log
    assert main(["replay", str(path), "--out", str(tmp_path / "run"), "--quiet", "--no-recording"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "field of view is unknown: give it with --fov DEG" in err
    assert not (tmp_path / "run").exists()
    assert main(["replay", str(path), "--out", str(tmp_path / "run"), "--quiet", "--no-recording", "--fov", "60"]) == 0
    assert "field_of_view_deg = 60.0" in (tmp_path / "run" / "config.toml").read_text()


def _replace_image(log_path: Path, line: int, write) -> str:
    name = ObservationLog.read_csv(log_path).image[line - 2]
    write(log_path.parent / name)
    return name


def _refused(log_path: Path) -> str:
    log = ObservationLog.read_csv(log_path)
    with pytest.raises(ObservationLogError) as e:
        match_camera_log(log, log_path, ViewConfig())
    assert "\n" not in str(e.value)
    return str(e.value)


def test_a_truncated_image_is_one_line(grey_log):
    _, path = grey_log

    def truncate(p):
        p.write_bytes(p.read_bytes()[:200])

    name = _replace_image(path, 7, truncate)
    assert _refused(path).startswith(f"{path}: line 7, column image: {name}: truncated image")


def test_frames_of_changing_size_are_one_line(grey_log):
    _, path = grey_log
    name = _replace_image(path, 9, lambda p: Image.new("L", (64, 20)).save(p))
    assert _refused(path) == (
        f"{path}: line 9, column image: {name}: 64x20 pixels, but the first image is 64x16; "
        "every frame must have one size"
    )


def _bomb_png(columns: int, rows: int) -> bytes:
    """A tiny PNG whose header declares ``columns`` x ``rows`` grey pixels (its data a few bytes)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", columns, rows, 8, 0, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + chunk(b"IEND", b"")
    )


@pytest.mark.parametrize("columns", [10_000, 100_000])  # beyond this bound, and beyond twice Pillow's own
def test_a_decompression_bomb_is_refused_from_its_header(grey_log, columns):
    _, path = grey_log
    name = _replace_image(path, 5, lambda p: p.write_bytes(_bomb_png(columns, 100_000)))
    assert (path.parent / name).stat().st_size < 200
    message = _refused(path)
    assert message.startswith(f"{path}: line 5, column image: {name}: declares") and "decompression bomb" in message
    assert columns * 100_000 > MAX_IMAGE_PIXELS


def test_a_missing_image_and_a_bad_folder_are_one_line(grey_log, tmp_path):
    _, path = grey_log
    name = _replace_image(path, 3, lambda p: p.unlink())
    assert _refused(path) == f"{path}: line 3, column image: {name}: no such file"
    folder = tmp_path / "frames"
    folder.mkdir()
    Image.new("L", (64, 16)).save(folder / "1.000.png")
    Image.new("L", (64, 24)).save(folder / "2.000.png")
    write_tum(tmp_path / "o.tum", np.arange(5.0), np.arange(5.0), np.zeros(5), np.zeros(5))
    with pytest.raises(
        ImageFolderError, match=r"2\.000\.png: 64x24 pixels, but the first image \(1\.000\.png\) is 64x16"
    ):
        import_image_folder(folder, tmp_path / "o.tum")
    (folder / "2.000.png").write_bytes(_bomb_png(100_000, 100_000))
    with pytest.raises(ImageFolderError, match=r"2\.000\.png: declares .*decompression bomb"):
        import_image_folder(folder, tmp_path / "o.tum")


def test_any_png_or_jpeg_is_read_as_grey_levels(tmp_path):
    rgb = np.zeros((8, 12, 3), dtype=np.uint8)
    rgb[..., 1] = 200
    Image.fromarray(rgb, mode="RGB").save(tmp_path / "c.png")
    assert read_grey(tmp_path / "c.png").shape == (8, 12)
    assert int(read_grey(tmp_path / "c.png")[0, 0]) == round(200 * 0.587)  # ITU-R 601 luma of green
    deep = (np.arange(96, dtype=np.uint16).reshape(8, 12) * 600).astype(np.uint16)
    Image.fromarray(deep).save(tmp_path / "d.png")
    assert read_grey(tmp_path / "d.png").max() == round(95 * 600 * 255 / 65535)
    (tmp_path / "t.txt").write_text("not an image")
    with pytest.raises(ImageReadError, match="t.txt: not a PNG or JPEG image"):
        read_grey(tmp_path / "t.txt")


def test_writing_an_image_log_is_all_or_nothing(grey_log, tmp_path):
    log, path = grey_log
    before = path.read_text()
    short = ObservationLog(t=log.t, dt=log.dt, v_trans=log.v_trans, v_rot=log.v_rot, scene_id=log.scene_id)
    with pytest.raises(InputError, match="11 images for 12 odometry ticks"):
        write_image_log(path, short, [np.zeros((16, 64), dtype=np.uint8)] * 11)
    assert path.read_text() == before and len(list(tmp_path.glob(".g_images*"))) == 0
    # image files: copied once however many ticks name them; the camera described
    src = tmp_path / "src.png"
    shutil.copy(path.parent / log.image[0], src)
    again = write_image_log(tmp_path / "h.csv", short, [src] * 12, CameraDescription(360.0, "panoramic"))
    assert set(again.image) == {"h_images/src.png"}
    assert sorted(p.name for p in (tmp_path / "h_images").iterdir()) == [CAMERA_FILE, "src.png"]
    assert np.array_equal(read_image(tmp_path / "h.csv", 2, again.image[0]), read_grey(src))


def test_a_folder_is_paired_by_the_importers_one_rule(tmp_path):
    """Ticks beyond the last image plus two image intervals are left out, not paired with a stale
    image (the rule of worlds.image_pairing, as for bags and video)."""
    folder = tmp_path / "frames"
    folder.mkdir()
    for stamp in (1.0, 2.0, 3.0):
        Image.new("L", (8, 4)).save(folder / f"{stamp:.3f}.png")
    write_tum(tmp_path / "o.tum", np.arange(11.0), np.arange(11.0), np.zeros(11), np.zeros(11))
    paired = import_image_folder(folder, tmp_path / "o.tum")  # ticks at 1 ... 10 s
    np.testing.assert_array_equal(paired.odometry.t, [1.0, 2.0, 3.0, 4.0, 5.0])  # 3 s + 2 x 1 s
    assert [p.name for p in paired.images] == ["1.000.png", "2.000.png", "3.000.png", "3.000.png", "3.000.png"]
    assert (paired.skipped, paired.skipped_at_end) == (0, 5)
