"""Time ``RatSLAM.step`` over every tick of one whole stream (run by ``bench_ratslam.py``).

Run:  python bench/step_timer.py STREAM.npz [--profile OUT.prof] [--dense]

``STREAM.npz`` holds ``dt``, ``v_trans``, ``v_rot``, ``scene_id`` and ``grid`` (nx, ny, n_theta).
The script imports only ``ratslam`` and numpy, so the same file times any version of the package
(the ``ratslam`` first on ``PYTHONPATH``). It loads (or compiles) the kernels on a throwaway
system over the stream's first fifth, then steps a fresh system with the default configuration on that grid through
every tick and prints one JSON line: the seconds of each quarter of the run, the ticks per
quarter, the experience count at the end and a digest of the final map (the same digest from
two versions means they made the same map on this stream). With ``--dense`` the system's pose
cells are the full-grid reference of the same update (``ratslam.pose_cells_reference``, every cell
every tick; equal to the boxes to rounding), the baseline the boxes are measured against.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # the arrays are small: BLAS threads only contend

import argparse
import hashlib
import json
import time

import numpy as np

from ratslam import RatSLAM, RatSLAMConfig
from ratslam.config import PoseCellConfig


def make_slam(grid) -> RatSLAM:
    nx, ny, nth = (int(v) for v in grid)
    return RatSLAM(RatSLAMConfig(pose_cells=PoseCellConfig(nx=nx, ny=ny, n_theta=nth)))


def warm_up(grid, dt, v, w, s) -> float:
    """Load (or compile) the kernels: a throwaway system over the stream's first fifth (untimed).
    Returns the seconds it took."""
    t0 = time.perf_counter()
    slam = make_slam(grid)
    for k in range(len(dt) // 5):
        slam.step(dt[k], v[k], w[k], s[k])
    return time.perf_counter() - t0


def run(path: str, profile: str | None) -> dict:
    data = np.load(path)
    dt, v, w, s = (data[k].tolist() for k in ("dt", "v_trans", "v_rot", "scene_id"))
    grid = data["grid"]
    warm = warm_up(grid, dt, v, w, s)
    n = len(dt)
    bounds = [round(n * q / 4) for q in range(5)]
    slam = make_slam(grid)
    step = slam.step
    seconds = []
    prof = None
    if profile:
        import cProfile

        prof = cProfile.Profile()
        prof.enable()
    for q in range(4):
        t0 = time.perf_counter()
        for k in range(bounds[q], bounds[q + 1]):
            step(dt[k], v[k], w[k], s[k])
        seconds.append(time.perf_counter() - t0)
    if prof is not None:
        prof.disable()
        prof.dump_stats(profile)
    digest = hashlib.sha256(np.ascontiguousarray(slam.experience_poses).tobytes())
    digest.update(np.ascontiguousarray(slam.peak).tobytes())
    return {
        "ticks": [bounds[q + 1] - bounds[q] for q in range(4)],
        "seconds": seconds,
        "warm_up_s": warm,
        "experiences": int(len(slam.experience_poses)),
        "links": int(len(slam.links)),
        "digest": digest.hexdigest()[:16],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("stream", help="stream file (.npz) written by bench_ratslam.py")
    ap.add_argument("--profile", help="write cProfile statistics of the timed run here")
    ap.add_argument("--dense", action="store_true", help="the pose cells on the full grid (the dense reference)")
    args = ap.parse_args()
    if args.dense:
        import ratslam.front_end
        from ratslam.pose_cells_reference import FullGridPoseCells

        ratslam.front_end.PoseCells = FullGridPoseCells  # the front end's pose cells
    print(json.dumps(run(args.stream, args.profile)))


if __name__ == "__main__":
    main()
