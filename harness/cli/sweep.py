"""``ratslam-harness sweep SPEC --out DIR``: a robustness study, resumable (rerun the same command to
finish a killed sweep)."""

from __future__ import annotations

import sys
from pathlib import Path

from .common import CliError, workers


def add_parser(sub) -> None:
    sw = sub.add_parser(
        "sweep",
        help="a robustness study: conditions x seeds x system configurations "
        "(resumable: rerun the same command to finish a killed sweep)",
    )
    sw.add_argument("spec", help="sweep spec (TOML; see sweeps/ for examples)")
    sw.add_argument("--out", required=True, help="sweep directory (runs/, runs.csv, report.md)")
    sw.add_argument("--workers", type=workers, help="local worker processes (default: one per core)")
    sw.add_argument("--scheduler", help="run on a Dask distributed cluster at this address (tcp://HOST:8786)")
    sw.add_argument(
        "--yes",
        action="store_true",
        help="run even if the spec expands to more than max_runs, or its runs exceed the size budget",
    )
    sw.set_defaults(func=command)


def command(args) -> None:
    from ..sweeps.run import run_sweep
    from ..sweeps.spec import check_sweep_size, read_sweep_spec

    spec = read_sweep_spec(args.spec)
    n = spec.run_count()  # counted, not expanded: a spec of a billion runs fails at once
    if n > spec.max_runs and not args.yes:
        raise CliError(
            f"{args.spec}: max_runs: the spec expands to {n:,} runs, more than {spec.max_runs:,}; "
            "pass --yes to run them all"
        )
    check_sweep_size(spec, args.yes)
    try:
        out = run_sweep(spec, args.out, workers=args.workers, scheduler=args.scheduler)
    except KeyboardInterrupt:
        runs = Path(args.out) / "runs"
        kept = sum(1 for _ in runs.glob("*/result.json")) if runs.is_dir() else 0
        where = f"the {kept} completed runs are kept in {runs}" if kept else "no run had completed"
        print(f"ratslam-harness: interrupted; {where}: rerun the same command to finish the sweep", file=sys.stderr)
        raise SystemExit(130) from None
    print(f"sweep directory: {out}\n  runs:   {out / 'runs.csv'}\n  report: {out / 'report.md'}")
