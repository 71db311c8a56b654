"""Benchmark: RatSLAM.step rate, against a straightforward full-grid pose-cell update.

Run:  /work/venv/bin/python bench/bench_ratslam.py [--quick]

Reports, in one run:
* full ``RatSLAM.step`` rate on a 60 x 60 x 36 grid with 1,000 and 20,000 experiences already in
  the map (the map correction runs over all their links every tick);
* the same pipeline with the pose cells replaced by the full-grid reference update
  (scipy.ndimage wrap-around correlations over the whole grid), as the ratio's denominator;
* the pose-cell update alone, windowed vs full grid;
* scaling with grid side (30, 60, 100 cells; 36 heading cells) and with experience count.

Input: the ``small_loop`` world (default aliasing and false positives), so view injections,
snaps and competing packets are part of the timing. Timings are noisy on a shared machine:
each figure is the best of ``--repeats`` runs; ratios are the figures to compare.
"""

from __future__ import annotations

import os

# The pose-cell matrices are small: on a loaded 2-core machine OpenBLAS threads only contend
# (measured: a 30x30x30 box update 40x slower with threads under load). Set before numpy loads.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import math
import time

import numpy as np  # noqa: E402

from ratslam import RatSLAM, RatSLAMConfig
from ratslam.pose_cells import PoseCells
from ratslam.pose_cells_reference import FullGridPoseCells


def observation_stream(n_ticks: int):
    """Inputs from the simulator (small_loop, 15 simulated minutes, seed 0)."""
    from worlds import simulate

    log = simulate("small_loop", duration=900.0, seed=0)
    k = min(n_ticks, len(log))
    return log.dt[:k], log.v_trans[:k], log.v_rot[:k], log.scene_id[:k]


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


def make_slam(n_experiences: int, side: int = 60, reference: bool = False) -> RatSLAM:
    cfg = RatSLAMConfig(nx=side, ny=side)
    slam = RatSLAM(cfg)
    if reference:
        slam.pose_cells = FullGridPoseCells(cfg)
    prefill_map(slam, n_experiences)
    return slam


def time_pipeline(stream, n_experiences: int, side: int = 60, reference: bool = False,
                  warmup: int = 300, repeats: int = 3) -> float:
    """Best steps/s of RatSLAM.step over the stream (after ``warmup`` untimed ticks)."""
    dt, v, w, s = stream
    best = 0.0
    for _ in range(repeats):
        slam = make_slam(n_experiences, side, reference)
        for k in range(warmup):
            slam.step(dt[k], v[k], w[k], s[k])
        t0 = time.perf_counter()
        for k in range(warmup, len(dt)):
            slam.step(dt[k], v[k], w[k], s[k])
        best = max(best, (len(dt) - warmup) / (time.perf_counter() - t0))
    return best


def time_pose_cells(cls, stream, side: int = 60, repeats: int = 3) -> float:
    """Best steps/s of the pose-cell update alone (odometry only)."""
    dt, v, w, _ = stream
    best = 0.0
    for _ in range(repeats):
        pc = cls(RatSLAMConfig(nx=side, ny=side))
        t0 = time.perf_counter()
        for k in range(len(dt)):
            pc.step(v[k] * dt[k], w[k] * dt[k])
        best = max(best, len(dt) / (time.perf_counter() - t0))
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ticks", type=int, default=2300, help="ticks per timed run (default 2300)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="fewer ticks and repeats")
    args = ap.parse_args()
    ticks, repeats = (800, 1) if args.quick else (args.ticks, args.repeats)
    stream = observation_stream(ticks)
    ref_stream = tuple(a[: max(300 + 100, ticks // 8)] for a in stream)

    print(f"RatSLAM.step on small_loop input, {ticks} ticks, best of {repeats}")
    fast_1k = time_pipeline(stream, 1000, repeats=repeats)
    fast_20k = time_pipeline(stream, 20000, repeats=repeats)
    ref_1k = time_pipeline(ref_stream, 1000, reference=True, repeats=1)
    print(f"  60x60x36, 1,000 experiences : {fast_1k:8.0f} steps/s ({1e3 / fast_1k:.3f} ms/step)")
    print(f"  60x60x36, 20,000 experiences: {fast_20k:8.0f} steps/s ({1e3 / fast_20k:.3f} ms/step)")
    print(f"  full-grid reference pipeline, 1,000 experiences: {ref_1k:8.0f} steps/s")
    print(f"  ratio windowed / full-grid (pipeline, 1,000 exp): {fast_1k / ref_1k:6.1f}x")

    pc_fast = time_pose_cells(PoseCells, stream, repeats=repeats)
    pc_ref = time_pose_cells(FullGridPoseCells, ref_stream, repeats=1)
    print(f"pose-cell update alone, 60x60x36: windowed {pc_fast:8.0f} steps/s, full grid {pc_ref:6.0f} "
          f"steps/s, ratio {pc_fast / pc_ref:6.1f}x")

    print("scaling with grid side (1,000 experiences; 36 heading cells):")
    for side in (30, 60, 100):
        fast = time_pipeline(stream, 1000, side=side, repeats=repeats)
        ref = time_pipeline(ref_stream, 1000, side=side, reference=True, repeats=1)
        print(f"  side {side:3d}: windowed {fast:8.0f} steps/s ({1e3 / fast:.3f} ms), full grid {ref:6.0f} "
              f"steps/s ({1e3 / ref:.2f} ms), ratio {fast / ref:6.1f}x")
    print("scaling with experience count (60x60x36):")
    for n in (0, 1000, 5000, 20000, 50000):
        fast = time_pipeline(stream, n, repeats=repeats)
        print(f"  {n:6d} experiences: {fast:8.0f} steps/s ({1e3 / fast:.3f} ms/step)")


if __name__ == "__main__":
    main()
