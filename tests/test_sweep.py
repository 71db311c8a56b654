"""Sweeps: spec validation, resumption after a kill, identical results for any executor."""

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from harness.cli import main
from harness.sweeps.report import WALL_COLUMNS, read_runs_csv, rebuild_sweep_report
from harness.sweeps.run import run_sweep, run_tasks
from harness.sweeps.spec import SweepSpecError, read_sweep_spec
from harness.sweeps.task import run_one

SPEC = """
[base]
world = "small_loop"
duration = {duration}

[axes]
fp_rate = [0.002, 0.05]
odometric_bias = [0.0, 3.0]

[seeds]
count = 2

[systems.ratslam]
system = "ratslam"

[systems.gtsam_robust]
system = "gtsam"

[systems.gtsam_gaussian]
system = "gtsam"
backend.kind = "gaussian"
"""


def _spec(tmp_path, text=None, duration=30.0, name="sweep.toml") -> Path:
    path = tmp_path / name
    path.write_text(text if text is not None else SPEC.format(duration=duration))
    return path


def _rows_without_wall_time(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return [{k: v for k, v in row.items() if k not in WALL_COLUMNS} for row in csv.DictReader(f)]


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda s: s.replace("fp_rate = [0.002, 0.05]", "fp_ratio = [0.0]"), "[axes] fp_ratio: unknown axis"),
        (lambda s: s.replace("fp_rate = [0.002, 0.05]", "fp_rate = []"), "[axes] fp_rate: expected a non-empty list"),
        (
            lambda s: s.replace("fp_rate = [0.002, 0.05]", "fp_rate = [0.0, 1.5]"),
            "[axes] fp_rate: value 1.5 out of range",
        ),
        (
            lambda s: s.replace('backend.kind = "gaussian"', 'backend.kind = "gaussian"\nbakend = 1'),
            "[systems.gtsam_gaussian] bakend: unknown key (not a field of PoseGraphConfig)",
        ),
        (
            lambda s: s.replace('backend.kind = "gaussian"', 'backend.kindd = "gaussian"'),
            "[systems.gtsam_gaussian.backend] kindd: unknown key (not a field of BackendConfig)",
        ),
        (
            lambda s: s.replace('backend.kind = "gaussian"', '"backend.kind" = "gaussian"'),
            "[systems.gtsam_gaussian] backend.kind: unknown key (not a field of PoseGraphConfig); a quoted dotted key?",
        ),
        (
            lambda s: s.replace('backend.kind = "gaussian"', 'backend = "gaussian"'),
            "[systems.gtsam_gaussian] backend: expected a table [systems.gtsam_gaussian.backend], got 'gaussian'",
        ),
        (
            lambda s: s.replace('backend.kind = "gaussian"', 'backend.kind = "lasso"'),
            "[systems.gtsam_gaussian.backend] kind: must be one of 'gaussian', 'robust', 'gnc', got 'lasso'",
        ),
        (
            lambda s: s.replace('system = "ratslam"', 'system = "ratslam"\npose_cells.nx = 2'),
            "[systems.ratslam.pose_cells] nx: must be an integer >= 4, got 2",
        ),
        (lambda s: s.replace('system = "ratslam"', 'system = "orbslam"'), "[systems.ratslam] system"),
        (lambda s: s.replace("count = 2", "count = 0"), "[seeds] count"),
        (lambda s: s.replace('world = "small_loop"', 'world = "moon_base"'), "[base] world"),
        (lambda s: s.replace("[axes]", "[axis]"), "axis: unknown key or table"),
    ],
)
def test_spec_errors_are_one_line_naming_file_and_key(tmp_path, edit, message):
    path = _spec(tmp_path, edit(SPEC.format(duration=30.0)))
    with pytest.raises(SweepSpecError) as e:
        read_sweep_spec(path)
    text = str(e.value)
    assert "\n" not in text and str(path) in text and message in text


def test_systems_take_nested_config_fields(tmp_path):
    """A system's sub-config fields are TOML dotted keys or sub-tables, as in a config file; with
    a figure as the base, RatSLAM takes the figure's grid unless it sets its own fields there."""
    text = """
[base]
figure = "fig4"
duration = 30.0
[axes]
pi_bias = [1.5]
[systems.ratslam]
system = "ratslam"
[systems.ratslam_sum]
system = "ratslam"
pose_cells.nx = 48
experience_map.energy = "sum"
[systems.gtsam_bias]
system = "gtsam"
closures.max_candidates = 2
[systems.gtsam_bias.yaw_bias]
estimate = true
"""
    spec = read_sweep_spec(_spec(tmp_path, text))
    systems = {s.name: s.config for s in spec.systems}
    assert systems["ratslam"].pose_cells.shape == (40, 40, 36)  # the figure's grid
    assert systems["ratslam_sum"].pose_cells.shape == (48, 40, 36)
    assert systems["ratslam_sum"].experience_map.energy == "sum"
    assert systems["gtsam_bias"].yaw_bias.estimate and systems["gtsam_bias"].closures.max_candidates == 2
    task = run_tasks(spec, "code")[0]
    configs = {s["name"]: s["config"] for s in task["systems"]}  # nested, as dataclasses.asdict
    assert configs["ratslam_sum"]["pose_cells"]["path_integration_bias_deg_s"] == 1.5
    assert configs["ratslam_sum"]["experience_map"]["energy"] == "sum"
    assert configs["gtsam_bias"]["yaw_bias"]["estimate"] is True


def test_spec_expands_one_axis_at_a_time_or_as_a_grid(tmp_path):
    spec = read_sweep_spec(_spec(tmp_path))
    assert len(spec.runs()) == (2 + 2) * 2
    grid = read_sweep_spec(_spec(tmp_path, 'design = "grid"\n' + SPEC.format(duration=30.0), name="g.toml"))
    assert len(grid.runs()) == 2 * 2 * 2


def test_too_many_runs_need_yes(tmp_path, capsys):
    path = _spec(tmp_path, "max_runs = 3\n" + SPEC.format(duration=30.0))
    assert main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "max_runs" in err and "8 runs" in err and "--yes" in err
    assert not (tmp_path / "out").exists()


def test_a_failing_run_is_recorded_with_a_one_line_error():
    result = run_one({"world": "no_such_world", "duration": 10.0, "condition": {}, "seed": 0, "systems": []})
    assert result["error"] and "\n" not in result["error"] and "no_such_world" in result["error"]


def test_same_runs_csv_for_one_worker_two_workers_and_dask(tmp_path):
    """Determinism whatever the executor: runs.csv (wall times aside) is identical for one local
    worker, two local workers and a Dask LocalCluster of two worker processes."""
    distributed = pytest.importorskip("distributed")
    spec = read_sweep_spec(_spec(tmp_path))
    outs = [
        run_sweep(spec, tmp_path / "w1", workers=1, log=lambda line: None),
        run_sweep(spec, tmp_path / "w2", workers=2, log=lambda line: None),
    ]
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        outs.append(run_sweep(spec, tmp_path / "dask", scheduler=cluster.scheduler_address, log=lambda line: None))
    tables = [_rows_without_wall_time(out / "runs.csv") for out in outs]
    # 8 runs on the curves x 3 systems; fp_rate 0.002 is the world's own rate, so that run is the
    # base of the bias curve too and ran once per seed (6 run directories)
    assert len(tables[0]) == 8 * 3 and len({r["run_id"] for r in tables[0]}) == 6
    assert all(len(list((out / "runs").glob("*/result.json"))) == 6 for out in outs)
    assert tables[0] == tables[1] == tables[2]


def test_killed_sweep_resumes_without_recomputing(tmp_path):
    """A sweep killed with SIGKILL mid-run and restarted with the same command computes only the
    missing runs: every run exists once and the completed ones are untouched."""
    path = _spec(tmp_path, duration=60.0)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "harness.cli", "sweep", str(path), "--out", str(out), "--workers", "1"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    runs = out / "runs"

    def results_in_place():
        # pathlib's "*" also matches the hidden ".<id>.partial-<pid>" staging directories: a kill
        # between staging and the move leaves one behind, which is not a completed run
        return {
            p.parent.name: (p.stat().st_mtime_ns, p.read_bytes())
            for p in runs.glob("*/result.json")
            if not p.parent.name.startswith(".")
        }

    deadline = time.time() + 120
    while time.time() < deadline and len(results_in_place()) < 2:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    before = results_in_place()
    assert 2 <= len(before) < 6, "the sweep should have been killed mid-way"
    (out / ".curve_fp_rate.png.x1y2z3.tmp.png").write_bytes(b"half")  # a report file being written at the kill
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert f"({len(before)} already done, {6 - len(before)} to run)" in r.stderr
    after = results_in_place()
    assert len(after) == 6 and all(after[k] == v for k, v in before.items())
    assert not list(runs.glob(".*partial*")) and not list(out.glob(".*.tmp*"))
    rows = read_runs_csv(out / "runs.csv")
    assert len({r["run_id"] for r in rows}) == 6 and not any(r["error"] for r in rows)


def test_report_rebuilds_from_runs_csv(tmp_path):
    spec = read_sweep_spec(_spec(tmp_path, duration=20.0))
    out = run_sweep(spec, tmp_path / "out", workers=1, log=lambda line: None)
    first = (out / "report.md").read_text()
    (out / "report.md").unlink()
    (out / "curve_fp_rate.png").unlink()
    rebuild_sweep_report(out)
    assert (out / "report.md").read_text() == first
    assert (out / "curve_fp_rate.png").read_bytes()[:4] == b"\x89PNG"
    assert "| system | fp_rate | odometric_bias |" in first


def test_a_sweep_into_another_specs_folder_says_so(tmp_path):
    """The folder's sweep.toml is replaced by the spec run now, with a line saying so (the runs
    already there stay and are reused where the same run is asked for); the same spec again
    says nothing."""
    tiny = '[base]\nworld = "small_loop"\nduration = 10.0\n[axes]\nfp_rate = [{fp}]\n[seeds]\ncount = 1\n'
    tiny += '[systems.ratslam]\nsystem = "ratslam"\n'
    first = _spec(tmp_path, tiny.format(fp=0.002), name="first.toml")
    second = _spec(tmp_path, tiny.format(fp=0.01), name="second.toml")
    out = tmp_path / "out"
    for spec, warned in ((first, False), (first, False), (second, True)):
        lines: list[str] = []
        run_sweep(read_sweep_spec(spec), out, workers=1, log=lines.append)
        assert any("another spec's" in line for line in lines) == warned, lines
        assert (out / "sweep.toml").read_text() == spec.read_text()


def test_code_version_reads_every_result_source():
    """Every source a run's result depends on is there to hash: a module moved or renamed without
    its pattern would drop out of the code version silently, and a changed result would reuse the
    old runs."""
    from harness.sweeps.run import _RESULT_SOURCES

    root = Path(__file__).resolve().parents[1]
    assert [p for p in _RESULT_SOURCES if not list(root.glob(p))] == []
