"""Benchmark of sweep throughput (not a test): runs per hour with 1 and 2 local workers and on a
Dask LocalCluster of 2 worker processes, for the same small sweep.

The sweep: small_loop, 900 s per run (runs long enough that worker start-up is small beside
them), false-positive rate x 4 values and odometric bias x 4 values, 2 seeds (16 runs on the
curves, 14 distinct), RatSLAM and three pose-graph configurations on every stream. Each executor
starts from an empty directory; worker start-up is counted. Scaling target: >= 1.8x at 2
workers. Results must agree (runs.csv without wall times).

Usage: python bench/bench_sweep.py [--duration S]
"""

from __future__ import annotations

import argparse
import csv
import tempfile
import time
from pathlib import Path

from harness.sweeps.report import WALL_COLUMNS
from harness.sweeps.run import run_sweep
from harness.sweeps.spec import read_sweep_spec

SPEC = """
[base]
world = "small_loop"
duration = {duration}

[axes]
fp_rate = [0.002, 0.01, 0.05, 0.1]
odometric_bias = [0.0, 0.5, 1.5, 3.0]

[seeds]
count = 2

[systems.ratslam]
system = "ratslam"

[systems.gtsam_robust]
system = "gtsam"

[systems.gtsam_gaussian]
system = "gtsam"
backend.kind = "gaussian"

[systems.gtsam_bias]
system = "gtsam"
yaw_bias.estimate = true
"""


def _table(out: Path) -> list[dict]:
    with open(out / "runs.csv", newline="") as f:
        return [{k: v for k, v in r.items() if k not in WALL_COLUMNS} for r in csv.DictReader(f)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=900.0, help="simulated seconds per run")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        spec_path = tmp / "bench_sweep.toml"
        spec_path.write_text(SPEC.format(duration=args.duration))
        spec = read_sweep_spec(spec_path)
        results = {}

        def timed(name, **kw):
            start = time.perf_counter()
            out = run_sweep(spec, tmp / name, log=lambda line: None, **kw)
            wall = time.perf_counter() - start
            results[name] = (wall, _table(out))
            n = len(list((out / "runs").glob("*/result.json")))
            print(f"{name:>10}: {wall:6.1f} s for {n} runs = {3600 * n / wall:7.0f} runs/hour", flush=True)

        timed("1 worker", workers=1)
        timed("2 workers", workers=2)
        try:
            from distributed import LocalCluster
        except ImportError:
            print("      dask: skipped (pip install -e '.[cluster]')")
        else:
            with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c:
                timed("dask", scheduler=c.scheduler_address)
        one = results["1 worker"][0]
        for name, (wall, table) in results.items():
            same = "same runs.csv" if table == results["1 worker"][1] else "DIFFERENT runs.csv"
            print(f"{name:>10}: speed-up x{one / wall:.2f} over 1 worker; {same}")


if __name__ == "__main__":
    main()
