"""Nothing lost: a command never writes over its own input, never deletes what it did not write
(a run directory lists its own files in manifest.txt), writes the README's first command into the
git-ignored runs/ rather than over the committed reports, and meets a read-only, full or
wrong-type output location with one line (exit 2), no staging folder left and no hang (the
recording included)."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from harness.run.directory import MANIFEST, read_manifest
from tests.helpers import cli

ROOT = Path(__file__).resolve().parents[1]
LOG = "t,dt,v_trans,v_rot,scene_id\n" + "".join(f"{0.1 * (k + 1):.1f},0.1,0.3,0.0,{k // 10}\n" for k in range(60))


def _one_line(r, *expected):
    assert r.returncode == 2, (r.returncode, r.stderr)
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.startswith("ratslam-harness")]  # a sweep's progress aside
    assert len(lines) == 1 and "Traceback" not in r.stderr and r.stderr.strip().endswith(lines[0]), r.stderr
    for text in expected:
        assert text in lines[0], r.stderr
    return lines[0]


def _tum(path, n=60):
    with open(path, "w") as f:
        for k in range(n):
            f.write(f"{0.2 * k:.3f} {0.06 * k:.4f} 0 0 0 0 0 1\n")


# ------------------------------------------------------------------------ inputs and manifests
@pytest.mark.parametrize("which", ["odom.tum", "labels.csv"])
def test_import_never_writes_over_its_input(tmp_path, which):
    _tum(tmp_path / "odom.tum")
    (tmp_path / "labels.csv").write_text("t,scene_id\n0.0,1\n2.0,2\n")
    before = {p.name: p.read_text() for p in tmp_path.iterdir()}
    r = cli("import", "tum", "odom.tum", "--labels", "labels.csv", "--out", f"./{which}", cwd=tmp_path)
    _one_line(r, "is the input", which)
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == before


@pytest.mark.parametrize("option", ["--out", "--png"])
def test_simulate_never_writes_over_the_world_file(tmp_path, option):
    world = tmp_path / "W.toml"
    shutil.copy(ROOT / "worlds" / "small_loop.toml", world)
    text = world.read_text()
    other = ("--png", "x.png") if option == "--out" else ("--out", "x.csv")
    r = cli("simulate", "W.toml", option, "W.toml", *other, "--duration", "20", "--quiet", cwd=tmp_path)
    _one_line(r, "W.toml", "input")
    assert world.read_text() == text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["W.toml"]


def test_a_file_of_the_users_in_an_earlier_run_is_kept(tmp_path):
    (tmp_path / "log.csv").write_text(LOG)
    run = tmp_path / "run"
    r = cli("replay", "log.csv", "--out", "run", "--quiet", "--no-recording", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    listed = read_manifest(run)
    assert listed is not None and {"metrics.json", "report.md", "config.toml", "maps.npz"} <= listed
    assert listed == {p.relative_to(run).as_posix() for p in run.rglob("*") if p.is_file()} - {MANIFEST}
    # a rerun replaces the run's own files...
    r = cli("replay", "log.csv", "--out", "run", "--quiet", "--no-recording", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    # ...but never a file the run did not write
    (run / "trajectories" / "notes.txt").write_text("mine")
    r = cli("replay", "log.csv", "--out", "run", "--quiet", "--no-recording", cwd=tmp_path)
    _one_line(r, "trajectories/notes.txt", "manifest.txt")
    assert (run / "trajectories" / "notes.txt").read_text() == "mine"
    # an older run directory without a manifest (metrics.json and a user's file) is refused too
    old = tmp_path / "old"
    old.mkdir()
    (old / "metrics.json").write_text("{}")
    (old / "notes.txt").write_text("mine")
    r = cli("replay", "log.csv", "--out", "old", "--quiet", "--no-recording", cwd=tmp_path)
    _one_line(r, "no manifest.txt")
    assert sorted(p.name for p in old.iterdir()) == ["metrics.json", "notes.txt"]
    assert not [p for p in tmp_path.iterdir() if ".partial-" in p.name]


def test_a_report_rebuild_keeps_the_run_replaceable(tmp_path):
    (tmp_path / "log.csv").write_text(LOG)
    assert cli("replay", "log.csv", "--out", "run", "--quiet", "--no-recording", cwd=tmp_path).returncode == 0
    for png in (tmp_path / "run").glob("*.png"):
        png.unlink()
    assert cli("report", "run", cwd=tmp_path).returncode == 0
    assert cli("replay", "log.csv", "--out", "run", "--quiet", "--no-recording", cwd=tmp_path).returncode == 0


def test_sweep_never_writes_into_a_users_folder(tmp_path):
    spec = tmp_path / "s.toml"
    spec.write_text(
        '[base]\nworld = "small_loop"\nduration = 20.0\n[axes]\nfp_rate = [0.0]\n'
        '[systems.ratslam]\nsystem = "ratslam"\n'
    )
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "report.md").write_text("my report")
    _one_line(cli("sweep", str(spec), "--out", str(mine), cwd=tmp_path), "not an earlier sweep directory")
    assert sorted(p.name for p in mine.iterdir()) == ["report.md"]
    assert (mine / "report.md").read_text() == "my report"


# ------------------------------------------------------------------------ the README's first command
def test_run_writes_into_runs_not_over_the_committed_reports(tmp_path):
    r = cli("run", "fig7", "--duration", "20", "--no-recording", "--workers", "1", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "runs" / "fig7" / "metrics.json").is_file()
    assert not (tmp_path / "reports").exists()
    assert "/runs/" in (ROOT / ".gitignore").read_text().splitlines()
    readme = (ROOT / "README.md").read_text()
    assert "ratslam-harness run fig9\n" in readme and "writes `runs/fig9/`" in readme
    # the committed reports are replaceable by an explicit --out: each lists exactly its files
    for d in sorted((ROOT / "reports").glob("*/metrics.json")):
        listed = read_manifest(d.parent)
        assert listed is not None, d.parent
        tracked = subprocess.run(
            ["git", "-C", str(ROOT), "ls-files", str(d.parent.relative_to(ROOT))], capture_output=True, text=True
        ).stdout.split()
        if tracked:  # a checkout with git: the committed files are listed, and the rest the run
            # wrote are the regenerated ones git ignores (trajectories, the recording)
            rel = {Path(t).relative_to(d.parent.relative_to(ROOT)).as_posix() for t in tracked} - {MANIFEST}
            assert rel <= listed, d.parent
            assert all("trajectories/" in f or f.endswith(".rrd") for f in listed - rel), d.parent


# ------------------------------------------------------------------------ read-only / full / wrong type
def _mount(where: Path, options: str) -> None:
    where.mkdir(parents=True, exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(where)], capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({r.stderr.strip() or 'mount failed'})")


@pytest.fixture
def small_fs(tmp_path):
    """A read-only and a nearly full (36 KB free) tmpfs; root only (skipped otherwise)."""
    if os.geteuid() != 0 or not shutil.which("mount"):
        pytest.skip("a read-only or full file system needs root to mount a tmpfs")
    ro, full = tmp_path / "ro", tmp_path / "full"
    _mount(ro, "ro,size=64k")
    try:
        _mount(full, "size=64k")
        st = os.statvfs(full)
        (full / "filler").write_bytes(b"\0" * (st.f_bavail * st.f_frsize - 36 * 1024))
        yield ro, full
    finally:
        for m in (ro, full):
            subprocess.run(["umount", "-l", str(m)], capture_output=True)


def _leftovers(where: Path) -> list[str]:
    return [p.name for p in where.rglob("*") if ".partial-" in p.name or ".tmp" in p.name]


def _cli_timed(*args, cwd, timeout=90):
    try:
        return subprocess.run(
            [sys.executable, "-m", "harness.cli", *args], capture_output=True, text=True, cwd=cwd, timeout=timeout
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"hung: {' '.join(args)}")


def test_replay_with_a_recording_onto_a_full_disk_is_one_line_not_a_hang(tmp_path, small_fs):
    _, full = small_fs
    (tmp_path / "log.csv").write_text(LOG)
    r = _cli_timed("replay", "log.csv", "--out", str(full / "r"), "--quiet", cwd=tmp_path)
    _one_line(r, str(full / "r"), "No space left on device")
    assert sorted(p.name for p in full.iterdir()) == ["filler"]


@pytest.mark.parametrize("where", ["ro", "full"])
@pytest.mark.parametrize(
    "command",
    [
        ("simulate", "small_loop", "--duration", "20", "--quiet", "--out", "{o}/x.csv"),
        ("import", "tum", "odom.tum", "--synthesise", "--gt", "odom.tum", "--out", "{o}/t.csv"),
        ("replay", "log.csv", "--quiet", "--no-recording", "--out", "{o}/r"),
        ("sweep", "s.toml", "--workers", "1", "--out", "{o}/s"),
    ],
    ids=["simulate", "import_tum", "replay", "sweep"],
)
def test_read_only_and_full_destinations_are_one_line(tmp_path, small_fs, where, command):
    ro, full = small_fs
    mount = ro if where == "ro" else full
    (tmp_path / "log.csv").write_text(LOG)
    _tum(tmp_path / "odom.tum", 1000)  # a log larger than the 36 KB left
    (tmp_path / "s.toml").write_text(
        '[base]\nworld = "small_loop"\nduration = 10.0\n[axes]\nfp_rate = [0.0]\n[systems.g]\nsystem = "gtsam"\n'
    )
    r = _cli_timed(*(a.format(o=mount) for a in command), cwd=tmp_path)
    _one_line(r, str(mount))
    assert not _leftovers(mount)


def test_report_in_a_read_only_run_directory_is_one_line(tmp_path, small_fs):
    ro, _ = small_fs
    (tmp_path / "log.csv").write_text(LOG)
    assert cli("replay", "log.csv", "--out", "run", "--quiet", "--no-recording", cwd=tmp_path).returncode == 0
    for png in (tmp_path / "run").glob("*.png"):
        png.unlink()
    subprocess.run(["umount", "-l", str(ro)], check=True)
    _mount(ro, "size=2m")
    shutil.copytree(tmp_path / "run", ro / "run")
    subprocess.run(["mount", "-o", "remount,ro", str(ro)], check=True)
    _one_line(_cli_timed("report", str(ro / "run"), cwd=tmp_path), "Read-only file system")


@pytest.mark.parametrize(
    "command, expected",
    [
        (("replay", "log.csv", "--no-recording", "--out", "afile"), "not a directory"),
        (("sweep", "s.toml", "--out", "afile"), "not a directory"),
        (("sweep", "s.toml", "--out", "afile/s"), "afile is a file"),
        (("simulate", "small_loop", "--duration", "20", "--out", "afile/x.csv"), "not a directory"),
    ],
    ids=["replay", "sweep", "sweep_under_a_file", "simulate"],
)
def test_a_file_where_a_directory_goes_is_one_line(tmp_path, command, expected):
    (tmp_path / "log.csv").write_text(LOG)
    (tmp_path / "afile").write_text("a file")
    (tmp_path / "s.toml").write_text(
        '[base]\nworld = "small_loop"\nduration = 10.0\n[axes]\nfp_rate = [0.0]\n[systems.g]\nsystem = "gtsam"\n'
    )
    _one_line(_cli_timed(*command, "--quiet" if command[0] != "sweep" else "--workers=1", cwd=tmp_path), expected)
    assert (tmp_path / "afile").read_text() == "a file"
