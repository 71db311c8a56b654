"""One base for user-facing errors: the CLI reports an ``InputError`` as one line (exit 2) and
lets anything else, a bug, raise with its traceback."""

from pathlib import Path

import pytest

import harness.cli as cli
from harness.cli import listing
from tests.helpers import cli as run_cli
from worlds import InputError


def _user_facing_errors():
    from harness.cli import CliError
    from harness.figures.registry import FigureError
    from harness.record.screenshot import ScreenshotError
    from harness.report.results import ResultsError
    from harness.report.run_report import ReportError
    from harness.run.config_file import ConfigFileError
    from harness.run.directory import OutputError
    from harness.sweeps.report import SweepReportError
    from harness.sweeps.run import SchedulerError
    from harness.sweeps.spec import SweepSpecError
    from worlds import ObservationLogError, WorldFileError
    from worlds.bag_import import BagImportError
    from worlds.real_data import RealDataError
    from worlds.trajectory_import import TrajectoryImportError

    return (
        CliError,
        ConfigFileError,
        FigureError,
        ReportError,
        ResultsError,
        OutputError,
        ScreenshotError,
        SweepReportError,
        SchedulerError,
        SweepSpecError,
        ObservationLogError,
        WorldFileError,
        BagImportError,
        RealDataError,
        TrajectoryImportError,
    )


@pytest.mark.parametrize("error", _user_facing_errors(), ids=lambda e: e.__name__)
def test_every_user_facing_error_derives_from_input_error(error, monkeypatch, capsys):
    assert issubclass(error, InputError)
    instance = error.__new__(error)
    Exception.__init__(instance, "somewhere: went wrong")

    def fail(args):
        raise instance

    monkeypatch.setattr(listing, "command", fail)
    assert cli.main(["list"]) == 2
    err = capsys.readouterr().err
    assert err == "ratslam-harness: error: somewhere: went wrong\n"


@pytest.mark.parametrize("error", [ValueError, KeyError, TypeError, RuntimeError])
def test_other_exceptions_are_bugs_and_raise(error, monkeypatch):
    def fail(args):
        raise error("a bug")

    monkeypatch.setattr(listing, "command", fail)
    with pytest.raises(error, match="a bug"):
        cli.main(["list"])


@pytest.mark.parametrize(
    "args, expected",
    [
        (
            ("run", "fig7", "--config", "{bad_config}", "--out", "{out}"),
            "[ratslam.pose_cells] nx: must be an integer >= 4",
        ),
        (("replay", "{bad_log}", "--out", "{out}"), "bad.csv"),
        (("report", "{bad_run}"), "metrics.json: cannot be read as JSON"),
        (("import", "tum", "{bad_log}", "--synthesise", "--out", "{out}/log.csv"), "bad.csv"),
        (("simulate", "small_loop", "--seed", "-5", "--out", "{out}/log.csv"), "--seed: must be a non-negative"),
        (("simulate", "small_loop", "--duration", "1e12", "--out", "{out}/log.csv"), "more than 1e+08 ticks"),
        (("report", "{sweep}"), "runs.csv: line 2: expected"),
        # a yaw bias of half a turn or more per tick (7 Hz) is no heading at all
        (("simulate", "small_loop", "--bias", "1e308", "--out", "{out}/log.csv"), "more than half a turn per tick"),
        # a world whose route cannot hold the aliased pairs its alias_rate asks for
        (("simulate", "{far_alias}", "--out", "{out}/log.csv"), "far_alias.toml: scenes.alias_min_distance: only 0"),
    ],
    ids=[
        "config_file",
        "observation_log",
        "metrics_json",
        "tum_import",
        "seed",
        "duration",
        "truncated_runs_csv",
        "bias",
        "alias_min_distance",
    ],
)
def test_bad_inputs_are_one_line(tmp_path, args, expected):
    (tmp_path / "bad.toml").write_text('[ratslam.pose_cells]\nnx = "sixty"\n')
    (tmp_path / "bad.csv").write_text("t,dt\n1,2\n")
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "metrics.json").write_text("{")
    (tmp_path / "run" / "maps.npz").write_bytes(b"")
    (tmp_path / "sweep").mkdir()
    from harness.sweeps.report import COLUMNS

    (tmp_path / "sweep" / "runs.csv").write_text(",".join(COLUMNS) + "\nrun-1,small_loop\n")  # cut short
    small_loop = (Path(__file__).parents[1] / "worlds" / "small_loop.toml").read_text()
    (tmp_path / "far_alias.toml").write_text(
        small_loop.replace("alias_rate = 0.1", "alias_rate = 0.1\nalias_min_distance = 100.0")
    )
    paths = {
        "far_alias": tmp_path / "far_alias.toml",
        "bad_config": tmp_path / "bad.toml",
        "bad_log": tmp_path / "bad.csv",
        "bad_run": tmp_path / "run",
        "sweep": tmp_path / "sweep",
    }
    r = run_cli(*(a.format(out=tmp_path / "out", **paths) for a in args), cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and expected in lines[0], r.stderr
    assert not any(p.is_file() for p in (tmp_path / "out").rglob("*"))  # nothing written
