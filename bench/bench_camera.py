"""Camera rendering throughput: frames per second over a whole simulated run of a world.

    python bench/bench_camera.py [--world small_loop ...] [--duration S] [--size 64x16 ...] [--repeats 3]

The run is simulated first (not timed); then every tick's ground-truth pose is rendered by
``Camera.render_poses`` (vectorised in chunks of frames) and, for comparison, one frame at a time
with ``Camera.render``. Forward camera at each ``--size`` (columns x rows), panoramic at twice the
columns. Reported: frames/s and the multiple of real time at the world's tick rate.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from worlds import load_world, simulate
from worlds.camera import Camera


def best_of(repeats, fn):
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", nargs="+", default=["small_loop", "open_plan", "office_floor", "full_floor"])
    ap.add_argument("--duration", type=float, default=900.0, help="simulated seconds per world (default 900)")
    ap.add_argument("--size", nargs="+", default=["64x16", "128x32"], help="forward camera columns x rows")
    ap.add_argument("--single", type=int, default=500, help="frames rendered one at a time (0: skip)")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    print("world          walls  camera       size     batched frames/s  x real time  one-by-one frames/s")
    for name in args.world:
        world = load_world(name)
        log = simulate(world, duration=args.duration, seed=0)
        poses = np.column_stack([log.gt_x, log.gt_y, log.gt_theta])
        for size in args.size:
            w, h = (int(v) for v in size.split("x"))
            spec = dataclasses.replace(world.camera, width=w, height=h, panoramic_width=2 * w)
            sized = dataclasses.replace(world, camera=spec)
            for kind in ("forward", "panoramic"):
                cam = Camera(sized, kind)
                batched = best_of(args.repeats, lambda cam=cam, poses=poses, t=log.t: cam.render_poses(poses, t))
                single = ""
                if args.single:
                    k = min(args.single, len(poses))
                    t = best_of(args.repeats, lambda cam=cam, few=poses[:k]: [cam.render(*p) for p in few])
                    single = f"{k / t:>12,.0f}"
                fps = len(poses) / batched
                print(
                    f"{world.name:<14} {len(world.walls):>5}  {kind:<11} {cam.width:>4}x{cam.height:<4}"
                    f" {fps:>16,.0f}  {fps / world.tick_rate:>11,.0f}  {single}"
                )


if __name__ == "__main__":
    main()
