"""TUM trajectories + place labels as observation logs (your own data): the import inverts the
odometry it is given, holds labels to their ticks, and rejects bad files in one line."""

import numpy as np
import pytest

from harness.run.runner import dead_reckon
from tests.helpers import cli
from worlds import simulate
from worlds.files import write_tum
from worlds.trajectory_import import PlaceLabels, TrajectoryImportError, import_tum, labels_at


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A simulated run written as a user's recording: TUM odometry and ground truth, labels CSV."""
    d = tmp_path_factory.mktemp("rec")
    log = simulate("small_loop", duration=120.0, seed=2)
    t0 = np.concatenate(([0.0], log.t))
    odo = np.vstack([[0.0, 0.0, 0.0], dead_reckon(log)])
    write_tum(d / "odom.tum", t0, *odo.T)
    gt = log.ground_truth()
    write_tum(d / "gt.tum", log.t, *gt.T)
    lines = ["t,scene_id"] + [f"{t!r},{s}" for t, s in zip(log.t.tolist(), log.scene_id.tolist())]
    (d / "labels.csv").write_text("\n".join(lines) + "\n")
    return d, log


def test_tum_odometry_and_labels_round_trip(recorded):
    d, log = recorded
    got = import_tum(d / "odom.tum", ground_truth=d / "gt.tum", labels=d / "labels.csv")
    assert len(got) == len(log)
    np.testing.assert_allclose(got.t, log.t, atol=1e-6)
    # TUM keeps 6 decimals: velocities agree to the file's precision
    np.testing.assert_allclose(got.v_trans, log.v_trans, atol=2e-4)
    np.testing.assert_allclose(got.v_rot, log.v_rot, atol=2e-4)
    np.testing.assert_array_equal(got.scene_id, log.scene_id)
    np.testing.assert_allclose(got.ground_truth()[:, :2], log.ground_truth()[:, :2], atol=1e-5)


def test_labels_hold_for_their_age_only():
    labels = PlaceLabels(np.array([1.0, 2.0]), np.array([7, 8]))
    t = np.array([0.5, 1.0, 1.2, 1.9, 2.05, 3.5])
    assert labels_at(labels, t, max_age=0.5).tolist() == [-1, 7, 7, -1, 8, -1]


def test_synthesised_scene_numbers_need_ground_truth(recorded):
    d, _ = recorded
    from worlds.real_data import PLAZA_SCENES

    with pytest.raises(TrajectoryImportError, match="need a ground-truth trajectory"):
        import_tum(d / "odom.tum", synthesise=PLAZA_SCENES)
    log = import_tum(d / "odom.tum", ground_truth=d / "gt.tum", synthesise=PLAZA_SCENES)
    assert (log.scene_id >= 0).mean() > 0.5


@pytest.mark.parametrize(
    "name, text, expected",
    [
        ("short.tum", "0 0 0 0 0 0 0 1\n1 1 0 0\n", "line 2: expected 8 columns"),
        ("order.tum", "0 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n1 2 0 0 0 0 0 1\n", "line 3: t: 1.0 is not after"),
        ("labels.csv", "t,scene_id\n1.0,3\n0.5,4\n", "line 3: t: 0.5 is not after"),
        ("labels.csv", "time,scene\n1.0,3\n", "line 1: expected the header 't,scene_id'"),
        ("labels.csv", "t,scene_id\n1.0,x\n", "line 2: scene_id: not an integer"),
    ],
)
def test_bad_files_are_one_line_and_write_nothing(recorded, tmp_path, name, text, expected):
    d, _ = recorded
    bad = tmp_path / name
    bad.write_text(text)
    odom, labels = (str(d / "odom.tum"), str(bad)) if name.endswith(".csv") else (str(bad), str(d / "labels.csv"))
    out = tmp_path / "log.csv"
    r = cli("import", "tum", odom, "--labels", labels, "--out", str(out))
    assert r.returncode == 2 and expected in r.stderr and str(bad) in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_imported_log_replays_end_to_end(recorded, tmp_path):
    d, _ = recorded
    out = tmp_path / "log.csv"
    r = cli(
        "import",
        "tum",
        str(d / "odom.tum"),
        "--gt",
        str(d / "gt.tum"),
        "--labels",
        str(d / "labels.csv"),
        "--out",
        str(out),
    )
    assert r.returncode == 0, r.stderr
    r = cli("replay", str(out), "--out", str(tmp_path / "run"), "--quiet", "--no-recording")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "run" / "metrics.json").is_file()


def test_label_ids_beyond_float_precision_stay_distinct(recorded, tmp_path):
    """Labels used to pass through a float64 array: ids 2**60 + k all became 2**60."""
    d, log = recorded
    ids = [2**60 + s if s >= 0 else -1 for s in log.scene_id.tolist()]
    lines = ["t,scene_id"] + [f"{t!r},{s}" for t, s in zip(log.t.tolist(), ids)]
    (tmp_path / "big.csv").write_text("\n".join(lines) + "\n")
    got = import_tum(d / "odom.tum", labels=tmp_path / "big.csv")
    want = np.where(log.scene_id >= 0, 2**60 + log.scene_id, -1)
    np.testing.assert_array_equal(got.scene_id, want)


def test_a_label_below_minus_one_is_refused_at_import(recorded, tmp_path):
    d, _ = recorded
    (tmp_path / "neg.csv").write_text("t,scene_id\n1.0,-5\n")
    with pytest.raises(TrajectoryImportError, match="scene_id -5 at t=1.0: must be in -1.."):
        import_tum(d / "odom.tum", labels=tmp_path / "neg.csv")
