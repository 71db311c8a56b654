"""World files: every shipped world loads; every malformed one fails with one clear line."""

import re

import pytest

from worlds import WorldFileError, list_worlds, load_world

GOOD = """
name = "tiny"
size = [6.0, 4.0]
[start]
pose = [1.0, 1.0, 0.0]
[walls]
rectangles = [[0.0, 0.0, 6.0, 4.0]]
segments = [[3.0, 2.5, 3.0, 4.0]]
[obstacles]
rectangles = [[4.0, 0.5, 4.5, 1.0]]
[route]
mode = "explore"
nodes = { A = [1.0, 1.0], B = [5.0, 2.0], C = [1.0, 3.0] }
edges = [["A", "B"], ["A", "C"]]
[robot]
speed = 0.3
[odometry]
bias_deg_s = 1.5
"""


def _write(tmp_path, text):
    p = tmp_path / "world.toml"
    p.write_text(text)
    return p


def test_shipped_worlds_load():
    names = list_worlds()
    assert {"small_loop", "office_floor", "full_floor", "open_plan"} <= set(names)
    sizes = {n: load_world(n).size for n in names}
    assert sizes["small_loop"] == (7.0, 7.0)
    assert sizes["office_floor"] == (25.0, 13.0)
    assert sizes["full_floor"] == (43.0, 13.0)
    w, h = sizes["open_plan"]
    assert 70 <= w * h <= 90  # paper Fig 13: about 80 m^2


def test_user_world_file_loads(tmp_path):
    w = load_world(_write(tmp_path, GOOD))
    assert w.name == "tiny" and w.odometry.bias_deg_s == 1.5 and len(w.obstacles) == 1


@pytest.mark.parametrize(
    "edit, field, problem",
    [
        (("size = [6.0, 4.0]\n", ""), "size", "missing"),
        (("speed = 0.3", "speed = 0.3\nwheels = 2"), "robot.wheels", "unknown key"),
        (
            ("segments = [[3.0, 2.5, 3.0, 4.0]]", "segments = [[3.0, 2.5, 3.0, 2.5]]"),
            "walls.segments[0]",
            "zero-length wall",
        ),
        (("pose = [1.0, 1.0, 0.0]", "pose = [0.1, 1.0, 0.0]"), "start.pose", "overlaps a wall"),
        (("pose = [1.0, 1.0, 0.0]", "pose = [4.25, 0.75, 0.0]"), "start.pose", "inside obstacle"),
        (
            ('edges = [["A", "B"], ["A", "C"]]', 'edges = [["A", "B"], ["A", "C"], ["B", "C"]]'),
            "route.edges[2]",
            "crosses a wall",
        ),
        (("speed = 0.3", "speed = -0.3"), "robot.speed", "must be positive"),
        (("bias_deg_s = 1.5", 'bias_deg_s = "fast"'), "odometry.bias_deg_s", "must be a number"),
        (("bias_deg_s = 1.5", "bias_deg_s = 1.5\nscale_error = 0.9"), "odometry.scale_error", "must be <= 0.5"),
        # half a turn per tick at the default 7 Hz: no heading can be told from the odometry
        (("bias_deg_s = 1.5", "bias_deg_s = 1e308"), "odometry.bias_deg_s", "must be <= 1260"),
        (("bias_deg_s = 1.5", "bias_deg_s = 1.5\nslip_duration = 0"), "odometry.slip_duration", "must be positive"),
        (('edges = [["A", "B"], ["A", "C"]]', 'edges = [["A", "Z"]]'), "route.edges[0]", "unknown node"),
        (('name = "tiny"', 'name = "tiny"\n[[oops'), "toml", "not valid TOML"),
        # sizes that used to exhaust memory, tunnel through walls or place things off the world
        (("bias_deg_s = 1.5", "bias_deg_s = 1.5\n[scenes]\ncell_size = 1e-6"), "scenes.cell_size", "cells of 1e-06 m"),
        (("speed = 0.3", "speed = 100.0"), "robot.speed", "it would pass through walls"),
        (
            ("rectangles = [[0.0, 0.0, 6.0, 4.0]]", "rectangles = [[0.0, 0.0, 6.0, 4.0], [7.0, 1.0, 8.0, 2.0]]"),
            "walls",
            "outside the world's size",
        ),
        (
            ("rectangles = [[4.0, 0.5, 4.5, 1.0]]", "rectangles = [[4.0, 0.5, 4.5, 1.0], [9.0, 0.5, 9.5, 1.0]]"),
            "obstacles.rectangles[1]",
            "outside the world's size",
        ),
        (
            (
                "nodes = { A = [1.0, 1.0], B = [5.0, 2.0], C = [1.0, 3.0] }",
                "nodes = { A = [1.0, 1.0], B = [5.0, 2.0], C = [1.0, 3.0], D = [9.0, 9.0] }",
            ),
            "route.nodes.D",
            "outside the world's size",
        ),
        (
            (
                "bias_deg_s = 1.5",
                "bias_deg_s = 1.5\n[scenes]\nlookalikes = [[[1.0, 1.0, 2.0, 2.0], [-2.0, 1.0, -1.0, 2.0]]]",
            ),
            "scenes.lookalikes[0][1]",
            "outside the world's size",
        ),
        (
            (
                "bias_deg_s = 1.5",
                "bias_deg_s = 1.5\n[scenes]\nlookalikes = [[[1.0, 1.0, 2.0, 2.0], [3.0, 1.0, 5.0, 3.0]]]",
            ),
            "scenes.lookalikes[0]",
            "the same size",
        ),
        (("speed = 0.3", "speed = 0.3\n[sim]\ntick_rate = 1e6"), "sim.duration", "ticks"),
        # a start shut in a box of walls: the robot never reaches its route
        (
            (
                "pose = [1.0, 1.0, 0.0]\n[walls]\nrectangles = [[0.0, 0.0, 6.0, 4.0]]",
                "pose = [2.0, 1.0, 0.0]\n[walls]\nrectangles = [[0.0, 0.0, 6.0, 4.0], [1.6, 0.6, 2.4, 1.4]]",
            ),
            "start.pose",
            "a wall stands between the start and the route",
        ),
    ],
)
def test_malformed_world_fails_with_one_line(tmp_path, edit, field, problem):
    old, new = edit
    assert old in GOOD
    path = _write(tmp_path, GOOD.replace(old, new))
    with pytest.raises(WorldFileError) as e:
        load_world(path)
    msg = str(e.value)
    assert "\n" not in msg
    assert msg.startswith(str(path))
    assert f": {field}: " in msg or (field == "toml" and ": toml: " in msg)
    assert re.search(problem, msg)


def test_unknown_world_name_lists_shipped_worlds():
    with pytest.raises(WorldFileError, match="no such world file or shipped world.*small_loop"):
        load_world("no_such_world")


def test_missing_world_file(tmp_path):
    with pytest.raises(WorldFileError, match="not found"):
        load_world(tmp_path / "absent.toml")
