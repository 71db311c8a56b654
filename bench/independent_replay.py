"""Whole-run accuracy of ``ratslam-harness replay`` on the independent logs (bench/independent_logs.py).

Run:  python bench/independent_replay.py --out DIR [--logs square,eight] [--seeds 0,1,2] [--duration S] [--no-stops]

For each log and seed it writes the log (``DIR/logs``), replays it as a user would (``replay
LOG.csv --out DIR/runs/NAME --no-recording``: configurations derived from the log) and prints the
whole-run ATE (m) of the written TUM files ``odometry.tum``, ``ratslam.tum`` and ``gtsam.tum``
(each tick's online estimate) and ``ratslam_final.tum`` and ``gtsam_final.tum`` (each tick as the
final map places it) against ``ground_truth.tum``, with :func:`harness.report.metrics.ate_rmse`
(positions after the least-squares SE(2) alignment of the whole trajectory), and the same per
third of the run (each third aligned on its own).

``floor`` is what no online estimate can beat from revisits alone (ground truth, analysis only):
the ATE of an estimate that is the dead reckoning until the first tick at which the robot is back
within ``FLOOR_RADIUS_M`` of a place it passed at least ``FLOOR_TRAVEL_M`` of path before, and
exact from then on. Before that first revisit the odometry's yaw-rate bias shows only at a
standstill, when the robot is not turning (:mod:`slamkit.yaw_bias`).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

from independent_logs import LOGS, log_spec, make_log, write_log  # noqa: E402

from harness.report.metrics import ate_rmse  # noqa: E402

FLOOR_RADIUS_M = 1.0
FLOOR_TRAVEL_M = 5.0
SYSTEMS = ("odometry", "ratslam", "gtsam", "ratslam_final", "gtsam_final")


def read_tum(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Times and (x, y, theta) of a TUM trajectory file (z = 0, rotation about z)."""
    a = np.loadtxt(path, ndmin=2)
    return a[:, 0], np.c_[a[:, 1], a[:, 2], 2.0 * np.arctan2(a[:, 6], a[:, 7])]


def whole_and_thirds(est: np.ndarray, gt: np.ndarray) -> tuple[float, list[float]]:
    """Whole-run ATE and the ATE of each third (aligned on its own)."""
    n = len(est)
    cuts = [0, n // 3, 2 * n // 3, n]
    return ate_rmse(est, gt), [ate_rmse(est[a:b], gt[a:b]) for a, b in zip(cuts[:-1], cuts[1:])]


def run_ates(run: Path) -> dict[str, tuple[float, list[float]]]:
    """Whole-run and per-third ATE of each system's TUM file in a run directory."""
    t_gt, gt = read_tum(run / "trajectories" / "ground_truth.tum")
    out = {}
    for name in SYSTEMS:
        t, est = read_tum(run / "trajectories" / f"{name}.tum")
        idx = np.clip(np.searchsorted(t_gt, t), 0, len(t_gt) - 1)
        out[name] = whole_and_thirds(est, gt[idx])
    return out


def revisit_floor(columns: dict[str, np.ndarray]) -> tuple[float, float]:
    """(time of the first revisit, the floor ATE): see the module doc."""
    gt = np.c_[columns["gt_x"], columns["gt_y"], columns["gt_theta"]]
    dt, v, w = columns["dt"], columns["v_trans"], columns["v_rot"]
    path = np.r_[0.0, np.cumsum(np.hypot(*np.diff(gt[:, :2], axis=0).T))]
    tree = cKDTree(gt[:, :2])
    first = len(gt)
    for k in range(len(gt)):
        near = tree.query_ball_point(gt[k, :2], FLOOR_RADIUS_M)
        if any(path[j] <= path[k] - FLOOR_TRAVEL_M for j in near):
            first = k
            break
    th = gt[0, 2] + np.cumsum(w * dt)
    mid = th - 0.5 * w * dt
    dr = np.c_[gt[0, 0] + np.cumsum(v * dt * np.cos(mid)), gt[0, 1] + np.cumsum(v * dt * np.sin(mid)), th]
    est = np.where((np.arange(len(gt)) < first)[:, None], dr, gt)
    return float(np.cumsum(dt)[min(first, len(gt) - 1)]), ate_rmse(est, gt)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--logs", default=",".join(LOGS))
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--duration", type=float, help="seconds (default: each log's own)")
    ap.add_argument("--no-stops", action="store_true", help="the robot never stands still")
    ap.add_argument("--harness", default=str(Path(sys.executable).with_name("ratslam-harness")))
    args = ap.parse_args(argv)
    print("log     seed  first revisit s  floor  | whole-run ATE m (thirds): " + "  ".join(SYSTEMS))
    for name in args.logs.split(","):
        for seed in (int(s) for s in args.seeds.split(",")):
            spec = log_spec(name, seed, args.duration, stops=not args.no_stops)
            cols = make_log(spec)
            log = args.out / "logs" / f"{name}_s{seed}.csv"
            write_log(cols, log)
            run = args.out / "runs" / f"{name}_s{seed}"
            subprocess.run(
                [args.harness, "replay", str(log), "--out", str(run), "--no-recording", "--quiet"],
                check=True,
                stdout=subprocess.DEVNULL,
            )
            t_first, floor = revisit_floor(cols)
            ates = run_ates(run)
            cells = "  ".join(f"{a:.2f} ({'/'.join(f'{x:.2f}' for x in thirds)})" for a, thirds in ates.values())
            print(f"{name:12s} {seed:2d} {t_first:8.0f} {floor:8.2f}  | {cells}", flush=True)


if __name__ == "__main__":
    main()
