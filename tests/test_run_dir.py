"""The run directory never deletes what the run did not write: an existing ``--out`` must be empty
or an earlier run holding only the files its manifest lists, and never the folder that holds the
run's input."""

import os

import pytest

from harness.run.directory import OutputError, staged_directory
from tests.helpers import cli

LOG = "t,dt,v_trans,v_rot,scene_id\n" + "".join(f"{0.1 * (k + 1):.1f},0.1,0.3,0.0,{k // 10}\n" for k in range(60))


def _stage_into(out, inputs=()):
    with staged_directory(out, inputs) as stage:
        (stage / "metrics.json").write_text("{}")


def test_a_users_folder_is_refused_and_kept(tmp_path):
    folder = tmp_path / "data"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match="holds notes.txt .no manifest.txt: not a run directory"):
        _stage_into(folder)
    assert (folder / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data"]  # no staging left behind


def test_an_empty_folder_and_an_earlier_run_are_replaced(tmp_path):
    (tmp_path / "empty").mkdir()
    _stage_into(tmp_path / "empty")
    run = tmp_path / "run"
    with staged_directory(run) as stage:  # an earlier run that wrote one more file
        (stage / "metrics.json").write_text("{}")
        (stage / "old.png").write_text("stale")
    assert sorted(p.name for p in run.iterdir()) == ["manifest.txt", "metrics.json", "old.png"]
    _stage_into(run)
    assert sorted(p.name for p in run.iterdir()) == ["manifest.txt", "metrics.json"]


def test_a_run_directory_holding_the_input_is_refused(tmp_path):
    run = tmp_path / "run"
    _stage_into(run)
    (run / "log.csv").write_text(LOG)
    with pytest.raises(OutputError, match="holds the input"):
        _stage_into(run, (run / "log.csv",))
    assert (run / "log.csv").read_text() == LOG


def test_dot_names_the_current_directory(tmp_path, monkeypatch):
    (tmp_path / "work").mkdir()
    (tmp_path / "work" / "log.csv").write_text(LOG)
    monkeypatch.chdir(tmp_path / "work")
    with pytest.raises(OutputError, match="work: holds the input"):
        _stage_into(".", ("log.csv",))
    assert sorted(os.listdir(tmp_path)) == ["work"]


def test_replay_into_the_logs_own_folder_keeps_the_log(tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    (d / "mylog.csv").write_text(LOG)
    (d / "notes.txt").write_text("mine")
    r = cli("replay", str(d / "mylog.csv"), "--out", str(d), "--quiet", "--no-recording")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "holds the input" in r.stderr
    assert sorted(p.name for p in d.iterdir()) == ["mylog.csv", "notes.txt"]
    r = cli("replay", "mylog.csv", "--out", ".", "--quiet", "--no-recording", cwd=d)
    assert r.returncode == 2 and "holds the input" in r.stderr, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d"]
