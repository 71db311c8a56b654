"""The observation-log CSV contract: exact round trip and one-line errors for bad logs."""

import numpy as np
import pytest

from worlds import ObservationLog, ObservationLogError, simulate

HEADER = "t,dt,v_trans,v_rot,scene_id"


def test_csv_round_trip_is_exact(tmp_path):
    log = simulate("small_loop", duration=120.0, seed=11, fp_rate=0.05)
    path = log.write_csv(tmp_path / "log.csv")
    back = ObservationLog.read_csv(path)
    for name, col in log.columns().items():
        other = getattr(back, name)
        assert other.dtype.kind == col.dtype.kind or name == "false_positive"
        assert np.array_equal(other, col), name
    # writing the read-back log reproduces the file byte for byte
    again = back.write_csv(tmp_path / "again.csv")
    assert again.read_bytes() == path.read_bytes()


def test_log_without_ground_truth(tmp_path):
    p = tmp_path / "user.csv"
    p.write_text(f"{HEADER}\n0.1,0.1,0.3,0.0,5\n0.2,0.1,0.3,0.01,-1\n")
    log = ObservationLog.read_csv(p)
    assert len(log) == 2 and not log.has_ground_truth
    assert log.scene_id.tolist() == [5, -1]


def test_ground_truth_without_false_positive_labels_is_read_with_none_flagged(tmp_path):
    """A user's log with a pose ground truth (motion capture, RTK) but no false-positive labels."""
    path = tmp_path / "log.csv"
    path.write_text(f"{HEADER},gt_x,gt_y,gt_theta\n0.1,0.1,0.3,0.0,5,0.03,0.0,0.0\n0.2,0.1,0.3,0.0,-1,0.06,0.0,0.0\n")
    log = ObservationLog.read_csv(path)
    assert log.has_ground_truth
    np.testing.assert_array_equal(log.ground_truth()[:, 0], [0.03, 0.06])
    assert log.false_positive is not None and not log.false_positive.any()


@pytest.mark.parametrize(
    "text, expected",
    [
        ("t,dt,v_trans,scene_id\n0.1,0.1,0.3,5\n", "header: missing column(s) v_rot"),
        (f"{HEADER}\n0.1,0.1,0.3,nan,5\n", "line 2, column v_rot: not a finite number"),
        (f"{HEADER}\n0.1,0.1,0.3,0.0,5\n0.1,0.1,0.3,0.0,5\n", "line 3, column t: time must increase"),
        (f"{HEADER}\n0.1,0.1,0.3,0.0,five\n", "line 2, column scene_id: not an integer"),
        (f"{HEADER}\n0.1,0.1,0.3,0.0\n", "line 2: expected 5 fields, got 4"),
        (f"{HEADER}\n0.1,-0.1,0.3,0.0,5\n", "line 2, column dt: must be positive"),
        (f"{HEADER}\n0.1,0.1,0.3,0.0,-4\n", "line 2, column scene_id: must be >= -1"),
        (f"{HEADER},speed\n0.1,0.1,0.3,0.0,1,2\n", "header: unknown column 'speed'"),
        (f"{HEADER},gt_x\n0.1,0.1,0.3,0.0,1,2\n", "ground-truth columns need all of gt_x,gt_y,gt_theta"),
        (f"{HEADER},false_positive\n0.1,0.1,0.3,0.0,1,0\n", "missing gt_x, gt_y, gt_theta"),
        (f"{HEADER}\n", "no observations"),
        (f"{HEADER}\n0.1,0.1,0.3,0.0,18446744073709551616\n", "column scene_id: beyond a 64-bit integer"),
        (f"{HEADER}\n0.1,0.1,0.3,0.0,1_0\n", "column scene_id: not an integer ('1_0')"),
        (f"{HEADER}\n0.1,0.1,0.3,0.0,3.0\n", "column scene_id: not an integer ('3.0')"),
        # dt in milliseconds: the odometry would be integrated 1000 times too far
        (f"{HEADER}\n0.1,100,0.3,0.0,1\n0.2,100,0.3,0.0,1\n", "column dt: does not match the spacing of t"),
        ("", "empty file"),
    ],
)
def test_malformed_log_fails_with_one_line(tmp_path, text, expected):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(ObservationLogError) as e:
        ObservationLog.read_csv(p)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(str(p))
    assert expected in msg


def test_missing_log_file(tmp_path):
    with pytest.raises(ObservationLogError, match="file not found"):
        ObservationLog.read_csv(tmp_path / "absent.csv")


def test_write_is_atomic(tmp_path, monkeypatch):
    """An interrupted write leaves neither a half-written log nor a temporary file behind."""
    log = simulate("small_loop", duration=10.0, seed=0)
    target = tmp_path / "log.csv"

    def broken_replace(src, dst):
        raise KeyboardInterrupt

    monkeypatch.setattr("worlds.files.os.replace", broken_replace)
    with pytest.raises(KeyboardInterrupt):
        log.write_csv(target)
    assert list(tmp_path.iterdir()) == []


def test_spreadsheet_byte_order_mark_and_the_largest_scene_numbers_are_read(tmp_path):
    p = tmp_path / "excel.csv"
    big = 2**63 - 1
    p.write_text(f"\ufeff{HEADER}\n0.1,0.1,0.3,0.0,{big}\n0.2,0.1,0.3,0.0,{big - 1}\n", encoding="utf-8")
    log = ObservationLog.read_csv(p)
    assert log.scene_id.tolist() == [big, big - 1]  # int64 end to end: distinct ids stay distinct


def test_isolated_gaps_in_time_are_allowed(tmp_path):
    """A dropout (t jumps, dt is the tick's own duration) is real data, not a unit mistake."""
    p = tmp_path / "gap.csv"
    rows = [f"{0.1 * (k + 1) + (5.0 if k >= 5 else 0.0):.1f},0.1,0.3,0.0,1" for k in range(10)]
    p.write_text(HEADER + "\n" + "\n".join(rows) + "\n")
    assert len(ObservationLog.read_csv(p)) == 10
