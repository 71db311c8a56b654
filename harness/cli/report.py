"""``ratslam-harness report DIR``: report.md and the PNG panels of a run, navigation or sweep directory
rebuilt from its files, without re-running."""

from __future__ import annotations

from pathlib import Path

from ..run.directory import output_errors


def add_parser(sub) -> None:
    rep = sub.add_parser("report", help="rebuild report.md and the PNG panels of a run or sweep directory")
    rep.add_argument("dir", help="run directory, or sweep directory (rebuilt from its runs.csv)")
    rep.set_defaults(func=command)


def command(args) -> None:
    with output_errors(args.dir):
        _report(args)


def _report(args) -> None:
    if (Path(args.dir) / "runs.csv").is_file():
        from ..sweeps.report import rebuild_sweep_report

        print(f"wrote {rebuild_sweep_report(args.dir)}")
        return
    from ..navigation.experiment import is_nav_run, rebuild_nav_report
    from ..report.run_report import write_report

    print(f"wrote {rebuild_nav_report(args.dir) if is_nav_run(args.dir) else write_report(args.dir)}")
