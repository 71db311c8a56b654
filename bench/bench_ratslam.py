"""Benchmark: RatSLAM.step over every tick of whole runs, beside a reference version timed in the
same run.

Run:  python bench/bench_ratslam.py [--reference DIR] [--repeats N] [--streams a,b,...] [--dense]

For each stream of ``bench/streams.py`` (always whole: no prefix; the simulator's, real odometry
and logs from an independent generator) the script writes the stream's odometry and scene numbers
to a file and times ``RatSLAM.step`` with the default configuration
(on the stream's grid) over every tick, in a subprocess per run (``bench/step_timer.py``): this
working copy, and, if ``--reference DIR`` is given (a checkout of another version with its own
virtual environment in ``DIR/.venv``), that version on the same file, the two alternating. It
prints steps/s per quarter of each run (so growth with the map and the packets shows), the
whole run's rate, the ratio to the reference, the median and the worst stream, and whether both
versions ended with the same map (a digest of the experience poses and the pose-cell peak).
With ``--dense`` it also times, once per stream, this working copy with its pose cells on the full
grid (``ratslam.pose_cells_reference``: the dense reference, every cell every tick) and prints the
ratio to it (slow: about 4 ms a tick on the 60 x 60 x 36 grid).

Timings are noisy on a shared machine: with ``--repeats N`` each version runs each stream N
times and each quarter keeps its best time; the ratios (measured minutes apart) are the figures
to compare. Each subprocess loads (or compiles) the compiled kernels before the timed run; the
reference uses its own kernel cache under the system's temporary directory, so the reference
checkout is only read.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from streams import GRIDS, STREAMS  # noqa: E402

DEFAULT_GRID = (60, 60, 36)


def write_stream(name: str, path: Path) -> int:
    """Write stream ``name`` for the timer; returns its tick count."""
    log = STREAMS[name]()
    np.savez(
        path,
        dt=np.asarray(log.dt, dtype=float),
        v_trans=np.asarray(log.v_trans, dtype=float),
        v_rot=np.asarray(log.v_rot, dtype=float),
        scene_id=np.asarray(log.scene_id, dtype=np.int64),
        grid=np.array(GRIDS.get(name, DEFAULT_GRID), dtype=np.int64),
    )
    return len(log.dt)


def time_stream(python: str, root: Path | None, stream: Path, cache: Path | None, dense: bool = False) -> dict:
    """Run ``step_timer.py`` on ``stream`` with interpreter ``python`` and, if ``root`` is given,
    the package from ``root`` (its kernel cache in ``cache``); ``dense``: with the full-grid pose
    cells. Returns the timer's record."""
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    if root is not None:
        env["PYTHONPATH"] = str(root)
        env["PYTHONDONTWRITEBYTECODE"] = "1"
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    out = subprocess.run(
        [python, str(HERE / "step_timer.py"), str(stream), *(["--dense"] if dense else [])],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if out.returncode != 0:
        raise SystemExit(f"{stream.stem}: timer failed ({python}):\n{out.stderr.strip()}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def best(records: list[dict]) -> dict:
    """Per quarter the best (smallest) time over repeats."""
    rec = dict(records[0])
    rec["seconds"] = [min(r["seconds"][q] for r in records) for q in range(4)]
    rec["warm_up_s"] = max(r["warm_up_s"] for r in records)
    return rec


def rates(rec: dict) -> tuple[list[float], float]:
    """Steps/s per quarter and over the whole run."""
    per_q = [t / s for t, s in zip(rec["ticks"], rec["seconds"])]
    return per_q, sum(rec["ticks"]) / sum(rec["seconds"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", type=Path, help="checkout of the version to compare with (its venv in DIR/.venv)")
    ap.add_argument("--repeats", type=int, default=1, help="runs per stream and version (best per quarter)")
    ap.add_argument("--streams", help="comma-separated stream names (default: all)")
    ap.add_argument("--json", type=Path, help="also write the records here")
    ap.add_argument("--dense", action="store_true", help="also time the dense (full-grid) reference, once")
    args = ap.parse_args()
    names = args.streams.split(",") if args.streams else list(STREAMS)
    unknown = [s for s in names if s not in STREAMS]
    if unknown:
        raise SystemExit(f"--streams: unknown stream(s) {unknown} (known: {', '.join(STREAMS)})")
    ref_python = None
    if args.reference is not None:
        ref_python = args.reference / ".venv" / "bin" / "python"
        if not ref_python.exists():
            raise SystemExit(f"--reference: {ref_python} not found")

    work = Path(tempfile.mkdtemp(prefix="bench_ratslam_"))
    # the reference's kernel cache: kept between runs, outside the reference checkout
    ref_cache = None
    if args.reference is not None:
        key = hashlib.sha256(str(args.reference.resolve()).encode()).hexdigest()[:12]
        ref_cache = Path(tempfile.gettempdir()) / "bench_ratslam_numba" / key
    print("RatSLAM.step, default configuration, every tick of each whole stream (steps/s)")
    quarters = " ".join(f"{q:>6s}" for q in ("Q1", "Q2", "Q3", "Q4"))
    header = f"  {'stream':18s} {'grid':>9s} {'ticks':>6s} | {quarters} | {'whole':>6s}"
    if ref_python:
        header += f" | {'reference':>9s} {'ratio':>6s}  same map"
    if args.dense:
        header += f" | {'dense':>6s} {'ratio':>7s}"
    print(header)
    results = {}
    for name in names:
        path = work / f"{name}.npz"
        ticks = write_stream(name, path)
        mine, ref = [], []
        for k in range(args.repeats):
            order = [False, True] if k % 2 == 0 else [True, False]
            for is_ref in order if ref_python else [False]:
                if is_ref:
                    ref.append(time_stream(str(ref_python), args.reference, path, ref_cache))
                else:
                    mine.append(time_stream(sys.executable, None, path, None))
        rec = best(mine)
        per_q, whole = rates(rec)
        grid = "x".join(str(v) for v in GRIDS.get(name, DEFAULT_GRID))
        line = f"  {name:18s} {grid:>9s} {ticks:6d} | " + " ".join(f"{r:6.0f}" for r in per_q) + f" | {whole:6.0f}"
        results[name] = {"this": rec, "rate": whole, "quarters": per_q}
        if ref_python:
            rrec = best(ref)
            _, rwhole = rates(rrec)
            same = "yes" if rrec["digest"] == rec["digest"] else "NO"
            line += f" | {rwhole:9.0f} {whole / rwhole:5.2f}x  {same}"
            results[name].update(reference=rrec, reference_rate=rwhole, ratio=whole / rwhole)
        if args.dense:
            _, dwhole = rates(time_stream(sys.executable, None, path, None, dense=True))
            line += f" | {dwhole:6.0f} {whole / dwhole:6.1f}x"
            results[name].update(dense_rate=dwhole, dense_ratio=whole / dwhole)
        if rec["warm_up_s"] > 2.0:
            line += f"  (kernels compiled in warm-up: {rec['warm_up_s']:.0f} s)"
        print(line, flush=True)
    whole_rates = {n: r["rate"] for n, r in results.items()}
    worst = min(whole_rates, key=whole_rates.__getitem__)
    summary = (
        f"  median over streams {statistics.median(whole_rates.values()):.0f} steps/s; "
        f"worst {worst} {whole_rates[worst]:.0f}"
    )
    if ref_python:
        ref_rates = {n: r["reference_rate"] for n, r in results.items()}
        rworst = min(ref_rates, key=ref_rates.__getitem__)
        summary += (
            f" (reference: median {statistics.median(ref_rates.values()):.0f}, worst {rworst} {ref_rates[rworst]:.0f}; "
            f"median ratio {statistics.median(r['ratio'] for r in results.values()):.2f}x)"
        )
    if args.dense:
        dense_median = statistics.median(float(r["dense_ratio"]) for r in results.values())
        summary += f"; median ratio to the dense reference {dense_median:.1f}x"
    print(summary)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
