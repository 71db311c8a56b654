"""worlds.files: atomic writes leave nothing behind on failure; TUM and JSON round trips."""

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest

from worlds import files
from worlds.plot import save_figure


def _loop(n=200):
    s = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([3 * np.cos(s), 2 * np.sin(s), s + np.pi / 2])


class Boom(Exception):
    pass


# ------------------------------------------------------------------------------ atomic writes
def test_atomic_write_text_and_bytes(tmp_path):
    p = files.atomic_write_text(tmp_path / "sub" / "a.txt", "hello\n")
    assert p.read_text() == "hello\n"
    files.atomic_write_bytes(p, b"\x00\x01")  # replaces the previous content
    assert p.read_bytes() == b"\x00\x01"
    assert sorted(x.name for x in p.parent.iterdir()) == ["a.txt"]


@pytest.mark.parametrize("mode", ["w", "wb"])
def test_exception_inside_atomic_open_leaves_no_file_and_no_temporary(tmp_path, mode):
    target = tmp_path / "out.npz"
    with pytest.raises(Boom), files.atomic_open(target, mode) as f:
        f.write("partial" if mode == "w" else b"partial")
        raise Boom
    assert list(tmp_path.iterdir()) == []


def test_exception_keeps_the_previous_file(tmp_path):
    target = files.atomic_write_text(tmp_path / "keep.txt", "old\n")
    with pytest.raises(Boom), files.atomic_path(target) as tmp:
        tmp.write_text("new\n")
        raise Boom
    assert target.read_text() == "old\n"
    assert list(tmp_path.iterdir()) == [target]


def test_failed_move_leaves_no_temporary(tmp_path, monkeypatch):
    """Interrupted at the very last step (the move), nothing is left behind either."""

    def broken_replace(src, dst):
        raise KeyboardInterrupt

    monkeypatch.setattr("worlds.files.os.replace", broken_replace)
    with pytest.raises(KeyboardInterrupt):
        files.atomic_write_text(tmp_path / "x.txt", "text")
    assert list(tmp_path.iterdir()) == []


def test_atomic_path_keeps_the_suffix_for_writers_that_infer_the_format(tmp_path):
    """savefig picks PNG from the name; np.savez through atomic_open writes a loadable file."""
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    png = save_figure(fig, tmp_path / "f.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with files.atomic_open(tmp_path / "m.npz", "wb") as f:
        np.savez(f, a=np.arange(3))
    np.testing.assert_array_equal(np.load(tmp_path / "m.npz")["a"], [0, 1, 2])
    assert sorted(x.name for x in tmp_path.iterdir()) == ["f.png", "m.npz"]


def test_save_figure_failure_leaves_nothing(tmp_path, monkeypatch):
    fig, _ = plt.subplots()

    def broken_savefig(*args, **kwargs):
        raise Boom

    monkeypatch.setattr(fig, "savefig", broken_savefig)
    with pytest.raises(Boom):
        save_figure(fig, tmp_path / "f.png")
    assert list(tmp_path.iterdir()) == []


def test_read_text_errors_are_one_line(tmp_path):
    with pytest.raises(ValueError, match=r"absent\.txt: file not found$"):
        files.read_text(tmp_path / "absent.txt", ValueError)
    (tmp_path / "bin.txt").write_bytes(b"\xff\xfe\xfa")
    with pytest.raises(OSError, match="cannot be read") as e:
        files.read_text(tmp_path / "bin.txt")
    assert "\n" not in str(e.value)


# ---------------------------------------------------------------------------------------- TUM
def test_tum_round_trip(tmp_path):
    gt = _loop()
    t = np.arange(len(gt)) / 7.0
    path = files.write_tum(tmp_path / "gt.tum", t, *gt.T)
    lines = path.read_text().splitlines()
    assert lines[0] == "# timestamp x y z qx qy qz qw"
    first = lines[1].split()
    assert len(first) == 8 and first[3] == "0"
    t2, p2 = files.read_tum(path)
    np.testing.assert_allclose(t2, t, atol=1e-6)
    np.testing.assert_allclose(p2[:, :2], gt[:, :2], atol=1e-6)
    dyaw = (p2[:, 2] - gt[:, 2] + math.pi) % (2 * math.pi) - math.pi
    np.testing.assert_allclose(dyaw, 0, atol=1e-8)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["gt.tum"]  # no temporary left behind


def test_tum_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match="different lengths"):
        files.write_tum(tmp_path / "x.tum", [0, 1], [0, 1], [0, 1], [0])
    assert list(tmp_path.iterdir()) == []
    bad = tmp_path / "bad.tum"
    bad.write_text("0 1 2 3\n")
    with pytest.raises(ValueError, match="8 columns"):
        files.read_tum(bad)


def test_empty_tum(tmp_path):
    path = files.write_tum(tmp_path / "e.tum", [], [], [], [])
    t, poses = files.read_tum(path)
    assert t.shape == (0,) and poses.shape == (0, 3)


# --------------------------------------------------------------------------------------- JSON
def test_json_round_trip_with_numpy_values(tmp_path):
    data = {
        "int": np.int64(7),
        "float": np.float32(0.5),
        "bool": np.bool_(True),
        "array": np.arange(6).reshape(2, 3),
        "tuple": (1, 2),
        "nan": float("nan"),
        "none": None,
        "nested": {"x": [np.float64(1.25)]},
    }
    path = files.write_json(tmp_path / "m.json", data)
    back = files.read_json(path)
    assert back["int"] == 7 and type(back["int"]) is int
    assert back["float"] == 0.5 and back["bool"] is True
    assert back["array"] == [[0, 1, 2], [3, 4, 5]] and back["tuple"] == [1, 2]
    assert math.isnan(back["nan"]) and back["none"] is None and back["nested"] == {"x": [1.25]}
    assert path.read_text().endswith("}\n")


def test_json_rejects_unknown_types_and_leaves_nothing(tmp_path):
    with pytest.raises(TypeError, match="not JSON serialisable: object"):
        files.write_json(tmp_path / "m.json", {"x": object()})
    assert list(tmp_path.iterdir()) == []
