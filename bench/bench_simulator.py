"""Simulator throughput, headless: ticks per second on a world (default office_floor).

    python bench/bench_simulator.py [--world office_floor] [--duration 9000] [--repeats 3]

Reports the physics/route loop alone and the whole ``simulate`` call (scene model, odometry
noise, log assembly included), as ticks per second and as a multiple of real time at the world's
tick rate. The ratio of the two shows what the vectorised post-processing costs.
"""

from __future__ import annotations

import argparse
import time

from worlds import Simulator, load_world, simulate


def best_of(repeats, fn):
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="office_floor")
    ap.add_argument("--duration", type=float, default=9000.0, help="simulated seconds (default 2.5 h)")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()

    world = load_world(args.world)
    n = int(round(args.duration * world.tick_rate))
    physics = best_of(args.repeats, lambda: Simulator(world, seed=0).run(n))
    full = best_of(args.repeats, lambda: simulate(world, duration=args.duration, seed=0))
    print(f"world {world.name}: {n} ticks ({args.duration:.0f} s simulated at {world.tick_rate:g} Hz)")
    for label, t in (("physics + route", physics), ("simulate() total", full)):
        print(f"  {label:<17} {t:7.3f} s  {n / t:>10,.0f} ticks/s  x{args.duration / t:>8,.0f} real time")
    print(f"  post-processing share of simulate(): {1 - physics / full:.1%}")
    print("  target: >= 20,000 ticks/s (paper's 2.5 h run in a few seconds)")


if __name__ == "__main__":
    main()
