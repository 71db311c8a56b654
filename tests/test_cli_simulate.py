"""``ratslam-harness simulate`` and ``list``: outputs, and one-line errors that write nothing."""

import pytest

from tests.helpers import cli, cli_process
from worlds import ObservationLog


def test_simulate_writes_log_and_png(tmp_path):
    out = tmp_path / "run" / "log.csv"
    r = cli(
        "simulate", "small_loop", "--out", str(out), "--duration", "60", "--seed", "3", "--bias", "1.5", "--fp", "0.01"
    )
    assert r.returncode == 0, r.stderr
    log = ObservationLog.read_csv(out)
    assert len(log) == 420 and log.has_ground_truth
    png = out.with_suffix(".png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "wrote" in r.stdout


def test_list_names_the_worlds():
    """``python -m harness.cli list`` in a fresh interpreter (the entry point itself)."""
    r = cli_process("list")
    assert r.returncode == 0
    for name in ("small_loop", "office_floor", "full_floor", "open_plan"):
        assert name in r.stdout


@pytest.mark.parametrize(
    "args, expected",
    [
        (["simulate", "atlantis", "--out", "{out}"], "no such world file or shipped world"),
        (["simulate", "small_loop", "--out", "{out}", "--bias", "nan"], "--bias: must be a finite number"),
        (["simulate", "small_loop", "--out", "{out}", "--fp", "2"], "--fp: must be a rate in [0, 1]"),
        (["simulate", "small_loop", "--out", "{out}", "--duration", "-5"], "--duration: must be a positive"),
        (["simulate", "{bad_world}", "--out", "{out}"], "robot.speed: must be positive"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, args, expected):
    bad_world = tmp_path / "bad.toml"
    bad_world.write_text(
        'name = "x"\nsize = [4.0, 4.0]\n[start]\npose = [1.0, 1.0, 0.0]\n'
        "[walls]\nrectangles = [[0.0, 0.0, 4.0, 4.0]]\n"
        '[route]\nnodes = { A = [1.0, 1.0], B = [3.0, 1.0] }\nedges = [["A", "B"]]\n'
        "[robot]\nspeed = -1.0\n"
    )
    out = tmp_path / "out" / "log.csv"
    r = cli(*[a.format(out=out, bad_world=bad_world) for a in args])
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and expected in lines[0], r.stderr
    assert not out.exists()
