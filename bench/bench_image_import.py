"""Image logs from a robot's recordings, end to end: a simulated run written as a ROS 2 bag (raw
mono8 images), a ROS 1 bag (PNG-compressed images) and an H.264 video with TUM odometry, each
imported and replayed with the command line as a user runs it.

    python bench/bench_image_import.py [--world small_loop] [--duration 900] [--seed 0] [--dir DIR]

Writing the recordings is not timed. Reported per source: the import's and the replay's wall time
(``ratslam-harness import ...``, then ``ratslam-harness replay LOG``, the field of view from the
bag's CameraInfo or, for the video, given at import with ``--fov 50``; each a fresh interpreter),
the multiple of real time of both together, and the ATE (m) of the odometry, RatSLAM's experience
map and GTSAM against the recording's ground truth.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.recordings import simulated_run, write_run_bag, write_tum, write_video


def timed(*args: str) -> float:
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "harness.cli", *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(args)}: {r.stderr.strip()}")
    return time.perf_counter() - t0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="small_loop")
    ap.add_argument("--duration", type=float, default=900.0, help="simulated seconds (default 900)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--dir", help="where the recordings and runs go (default: a temporary folder)")
    args = ap.parse_args()
    work = Path(args.dir or tempfile.mkdtemp(prefix="image_import_"))
    work.mkdir(parents=True, exist_ok=True)
    run = simulated_run(args.world, args.duration, args.seed)
    log, frames, odo, gt, t = run
    sources = {
        "ROS 2 bag, mono8": (
            ["rosbag", str(write_run_bag(work / "ros2", run, 2, compressed=False)), "--odom", "/odom"],
            ["--gt", "/ground_truth", "--image", "/camera/image_raw"],
        ),
        "ROS 1 bag, PNG compressed": (
            ["rosbag", str(write_run_bag(work / "ros1.bag", run, 1, compressed=True)), "--odom", "/odom"],
            ["--gt", "/ground_truth", "--image", "/camera/image_raw/compressed"],
        ),
        "H.264 video + TUM": (
            ["video", str(write_video(work / "run.mp4", np.concatenate([frames[:1], frames]), "libx264"))],
            ["--odometry", str(write_tum(work / "odom.tum", t, odo)), "--gt", str(write_tum(work / "gt.tum", t, gt))]
            + ["--fov", "50"],
        ),
    }
    print(f"{args.world}, {args.duration:g} s, seed {args.seed}, {len(log)} ticks; recordings in {work}")
    print("| source | import s | replay s | x real time | ATE odometry | ATE RatSLAM map | ATE GTSAM |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for k, (name, (head, tail)) in enumerate(sources.items()):
        out = work / f"log{k}.csv"
        t_import = timed("import", *head, *tail, "--out", str(out))
        t_replay = timed("replay", str(out), "--out", str(work / f"run{k}"), "--quiet")
        ate = json.loads((work / f"run{k}" / "metrics.json").read_text())["variants"]["replay"]["ate"]
        print(
            f"| {name} | {t_import:.1f} | {t_replay:.1f} | {args.duration / (t_import + t_replay):.0f} | "
            f"{ate['odometry']:.3f} | {ate['experience_map']:.3f} | {ate['gtsam']:.3f} |"
        )


if __name__ == "__main__":
    main()
