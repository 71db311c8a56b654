"""The simulated camera: deterministic images, look-alike rooms alike, the [camera] world table."""

import dataclasses
import math

import numpy as np
import pytest

from worlds import WorldFileError, load_world
from worlds.camera import Camera, to_uint8

OFFICE = load_world("office_floor")
ROOM_C_SHIFT = 19.25  # office_floor: room C is room B 19.25 m east (its [camera] same_as)


def test_same_pose_and_seed_give_the_same_image():
    noisy = dataclasses.replace(OFFICE, camera=dataclasses.replace(OFFICE.camera, noise=0.05))
    a = Camera(noisy, "forward", seed=3).render(8.0, 6.5, 0.3, t=12.0, tick=84)
    b = Camera(noisy, "forward", seed=3).render(8.0, 6.5, 0.3, t=12.0, tick=84)
    assert a.shape == (16, 64) and a.dtype == np.float32
    assert np.array_equal(a, b)
    assert not np.array_equal(a, Camera(noisy, "forward", seed=4).render(8.0, 6.5, 0.3, t=12.0, tick=84))
    assert not np.array_equal(a, Camera(noisy, "forward", seed=3).render(8.0, 6.5, 0.3, t=12.0, tick=85))


def test_a_run_renders_as_its_frames_do():
    cam = Camera("small_loop", "forward", seed=1)
    poses = np.array([[1.25, 1.25, 0.0], [3.0, 1.3, 0.1], [5.75, 3.0, 1.6]])
    run = cam.render_poses(poses, t=np.array([0.0, 1.0, 2.0]), ticks=np.array([5, 6, 7]), chunk=2)
    for k, pose in enumerate(poses):
        assert np.array_equal(run[k], cam.render(*pose, t=float(k), tick=5 + k))
    assert len({to_uint8(im).tobytes() for im in run}) == 3  # three places, three images


@pytest.mark.parametrize("kind", ["forward", "panoramic"])
def test_a_turn_by_one_column_shifts_the_image_by_one_column(kind):
    """Cylindrical projection: what the matcher's shifts measure is exactly the robot's turn."""
    cam = Camera(OFFICE, kind)
    col = cam.fov / cam.width
    a, b = cam.render(8.0, 6.5, 1.0), cam.render(8.0, 6.5, 1.0 + col)
    if cam.panoramic:
        assert np.array_equal(np.roll(a, 1, axis=1), b)
    else:  # turned left: the content moves right, a new column enters on the left
        assert np.array_equal(a[:, :-1], b[:, 1:])


@pytest.mark.parametrize("pose", [(2.9, 2.0, -math.pi / 2), (2.9, 2.0, math.pi), (4.5, 2.0, 0.0), (1.5, 3.0, -0.4)])
def test_look_alike_rooms_render_alike(pose):
    """Rooms B and C of the office floor look the same from the same place in each; without the
    look-alike regions they would not, nor does another room."""
    x, y, th = pose
    cam = Camera(OFFICE, "forward")
    in_b, in_c = cam.render(x, y, th), cam.render(x + ROOM_C_SHIFT, y, th)
    assert np.array_equal(in_b, in_c)
    plain = dataclasses.replace(OFFICE, camera=dataclasses.replace(OFFICE.camera, same_as=()))
    unlike = Camera(plain, "forward")
    assert np.abs(unlike.render(x, y, th) - unlike.render(x + ROOM_C_SHIFT, y, th)).mean() > 0.02


def test_distinct_places_look_different_through_a_small_set_of_motifs():
    """Six motifs over the small loop's panels, and yet its corners do not look the same."""
    cam = Camera("small_loop", "forward")
    corners = [cam.render(1.25, 1.25, 0.0), cam.render(5.75, 1.25, math.pi / 2), cam.render(5.75, 5.75, math.pi)]
    assert all(np.abs(a - b).mean() > 0.02 for i, a in enumerate(corners) for b in corners[i + 1 :])
    assert cam.motifs.shape[0] == cam.spec.motifs == 6


def test_lighting_changes_the_image_over_time():
    lit = dataclasses.replace(OFFICE, camera=dataclasses.replace(OFFICE.camera, lighting_amplitude=0.3))
    cam = Camera(lit, "forward")
    a, b = cam.render(8.0, 6.5, 0.3, t=0.0), cam.render(8.0, 6.5, 0.3, t=150.0)  # quarter period: gain 1.3
    assert b.mean() > 1.2 * a.mean()


GOOD = """
name = "tiny"
size = [6.0, 4.0]
[start]
pose = [1.0, 1.0, 0.0]
[walls]
rectangles = [[0.0, 0.0, 6.0, 4.0]]
[route]
nodes = { A = [1.0, 1.0], B = [5.0, 2.0] }
edges = [["A", "B"]]
[camera]
width = 64
"""


def test_a_world_file_sets_the_camera(tmp_path):
    p = tmp_path / "w.toml"
    p.write_text(
        GOOD.replace(
            "width = 64", "width = 96\nfov_deg = 60.0\nsame_as = [[[0.0, 0.0, 1.0, 1.0], [4.0, 2.0, 5.0, 3.0]]]"
        )
    )
    cam = load_world(p).camera
    assert (cam.width, cam.fov_deg, cam.same_as) == (96, 60.0, (((0.0, 0.0, 1.0, 1.0), (4.0, 2.0, 5.0, 3.0)),))
    assert load_world("small_loop").camera.same_as is None  # no [camera]: the defaults


@pytest.mark.parametrize(
    "line, field, problem",
    [
        ("width = 0", "camera.width", "must be >= 4"),
        ("width = 2.5", "camera.width", "must be an integer"),
        ("fov_deg = -50", "camera.fov_deg", "must be positive"),
        ("fov_deg = 400", "camera.fov_deg", "must be <= 360"),
        ("noise = 'lots'", "camera.noise", "must be a number"),
        ("eye_height = 2.5", "camera.eye_height", "must be below wall_height"),
        ("colour = true", "camera.colour", "unknown key"),
        ("same_as = [[[0.0, 0.0, 1.0, 1.0]]]", "camera.same_as[0]", "must be a pair of rectangles"),
        ("same_as = [[[0.0, 0.0, 1.0, 1.0], [2.0, 2.0, 4.0, 3.0]]]", "camera.same_as[0]", "same size"),
        ("same_as = [[[0.0, 0.0, 1.0, 1.0], [5.5, 0.0, 6.5, 1.0]]]", "camera.same_as[0][1]", "outside the world"),
    ],
)
def test_bad_camera_settings_name_the_field(tmp_path, line, field, problem):
    p = tmp_path / "w.toml"
    p.write_text(GOOD.replace("width = 64", line))
    with pytest.raises(WorldFileError) as e:
        load_world(p)
    message = str(e.value)
    assert "\n" not in message and message.startswith(f"{p}: {field}: ") and problem in message


def test_an_unknown_camera_kind_is_refused():
    with pytest.raises(ValueError, match="camera: must be one of forward, panoramic"):
        Camera("small_loop", "fisheye")
