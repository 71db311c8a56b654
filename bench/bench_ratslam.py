"""Benchmark: RatSLAM.step per stream, the sparse box path against the full-grid reference.

Run:  python bench/bench_ratslam.py [--quick]

Reports, in one run:
* per stream of ``bench/streams.py`` (clean, false positives + aliasing + bias, the office
  floor, a fast simulated stream, two real vehicles' odometry): ``RatSLAM.step`` steps/s with
  the default configuration (60 x 60 x 36) over the stream, and on its first ``--ref-ticks``
  ticks both the box path and the same pipeline with the pose cells replaced by the full-grid
  reference (``ratslam.pose_cells_reference``), with their ratio; the median and the worst
  stream;
* the worst case for boxes: activity over the whole grid (one step, box path vs reference);
* scaling with experience count (map correction over all links every tick).

Timings are noisy on a shared machine: each figure is the best of ``--repeats`` runs and the
ratios (measured in the same run) are the figures to compare. Compiled kernels are loaded
(or compiled) before timing; the warm-up is reported.
"""

from __future__ import annotations

import os

# The pose-cell arrays are small: BLAS threads would only contend. Set before numpy loads.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from streams import STREAMS

from ratslam import RatSLAM, RatSLAMConfig
from ratslam.pose_cells_reference import FullGridPoseCells


def make_slam(reference: bool = False, n_experiences: int = 0) -> RatSLAM:
    slam = RatSLAM(RatSLAMConfig())
    if reference:
        slam.pose_cells = FullGridPoseCells(slam.config)
    prefill_map(slam, n_experiences)
    return slam


def prefill_map(slam: RatSLAM, n_experiences: int, seed: int = 0) -> None:
    """Put ``n_experiences`` experiences (a random walk, chained, with ~10% extra loop-closure
    links) into the map, with views no real scene uses, so every tick corrects them all."""
    if n_experiences == 0:
        return
    em = slam.experience_map
    rng = np.random.default_rng(seed)
    pose = np.zeros(3)
    for i in range(n_experiences):
        em.add_experience(pose, rng.uniform(0, 60, 3), -1000 - i, 0)
        step = rng.normal([0.3, 0.0, 0.0], [0.05, 0.05, 0.2])
        c, s = math.cos(pose[2]), math.sin(pose[2])
        pose = pose + [c * step[0] - s * step[1], s * step[0] + c * step[1], step[2]]
        if i:
            em.add_transition(i - 1, i, step[0], step[1], step[2], 1.0)
    for _ in range(n_experiences // 10):
        i, j = rng.integers(0, n_experiences, 2)
        em.add_transition(int(i), int(j), *rng.normal(0, 1, 3), 1.0)
    em.current = -1


def steps_per_second(log, ticks: int, repeats: int, reference: bool = False, n_experiences: int = 0) -> float:
    """Best steps/s of ``RatSLAM.step`` over the first ``ticks`` ticks of ``log``."""
    dt, v, w, s = (np.asarray(a)[:ticks] for a in (log.dt, log.v_trans, log.v_rot, log.scene_id))
    dt, v, w, s = dt.tolist(), v.tolist(), w.tolist(), s.tolist()
    best = 0.0
    for _ in range(repeats):
        slam = make_slam(reference, n_experiences)
        t0 = time.perf_counter()
        for k in range(len(dt)):
            slam.step(dt[k], v[k], w[k], s[k])
        best = max(best, len(dt) / (time.perf_counter() - t0))
    return best


def dense_step_ms() -> tuple[float, float]:
    """One step with activity on every cell: box path vs full-grid reference (ms)."""
    cfg = RatSLAMConfig()
    rng = np.random.default_rng(0)
    cells = np.stack(np.meshgrid(*(np.arange(n) for n in cfg.shape), indexing="ij"), -1).reshape(-1, 3)
    energy = rng.uniform(0.5, 1.0, len(cells)) * 1e-3
    out = []
    for reference in (False, True):
        best = math.inf
        for _ in range(3):
            slam = make_slam(reference=reference)
            slam.pose_cells.inject(cells, energy)
            t0 = time.perf_counter()
            slam.pose_cells.step(0.04, 0.01)
            best = min(best, time.perf_counter() - t0)
        out.append(best * 1e3)
    return out[0], out[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ticks", type=int, default=4000, help="ticks per stream for the box path (default 4000)")
    ap.add_argument("--ref-ticks", type=int, default=400, help="ticks compared with the reference (default 400)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="fewer ticks, one repeat")
    args = ap.parse_args()
    ticks, ref_ticks, repeats = (1000, 200, 1) if args.quick else (args.ticks, args.ref_ticks, args.repeats)

    t0 = time.perf_counter()
    warm = make_slam()
    for k in range(5):
        warm.step(0.14, 0.3, 0.1 * k, k % 2)  # loads (or compiles) the kernels
    print(f"kernel warm-up (load or compile): {time.perf_counter() - t0:.2f} s")

    print(f"RatSLAM.step, default config 60x60x36, best of {repeats}")
    print(
        f"  {'stream':16s} {'ticks':>6s} {'steps/s':>9s} | "
        f"first {ref_ticks}: {'box':>7s} {'full grid':>9s} {'ratio':>6s}"
    )
    rates = {}
    for name, make in STREAMS.items():
        log = make()
        n = min(ticks, len(log))
        rate = steps_per_second(log, n, repeats)
        box = steps_per_second(log, ref_ticks, repeats)
        ref = steps_per_second(log, ref_ticks, 1, reference=True)
        rates[name] = rate
        print(f"  {name:16s} {n:6d} {rate:9.0f} | {box:18.0f} {ref:9.0f} {box / ref:5.1f}x", flush=True)
    values = np.array(list(rates.values()))
    worst = min(rates, key=rates.get)
    print(f"  median over streams {np.median(values):.0f} steps/s; worst {worst} {rates[worst]:.0f} steps/s")

    box_ms, ref_ms = dense_step_ms()
    print(
        f"activity on every cell, one pose-cell step: box path {box_ms:.2f} ms, full grid {ref_ms:.2f} ms, "
        f"ratio {ref_ms / box_ms:.1f}x"
    )

    print("scaling with experience count (small_loop stream, 60x60x36):")
    log = STREAMS["small_loop"]()
    base = None
    for n_exp in (0, 1000, 5000, 20000) if not args.quick else (0, 5000):
        rate = steps_per_second(log, min(ticks, 2000), repeats, n_experiences=n_exp)
        base = base or rate
        print(f"  {n_exp:6d} experiences: {rate:8.0f} steps/s ({1e3 / rate:.3f} ms/step, {rate / base:.2f}x of empty)")


if __name__ == "__main__":
    main()
