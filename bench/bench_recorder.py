"""Benchmark: Rerun recording size and logging time for a 2.5-hour run at 7 Hz.

Run:  /work/venv/bin/python bench/bench_recorder.py [--ticks 63000] [--sweep] [--real SECONDS]

Synthetic (default): 63,000 ticks (2.5 h at 7 Hz) fed to :class:`harness.record.recorder.Recorder` by
stand-in SLAM objects of realistic size -- a 60 x 60 x 36 pose-cell grid with a moving packet,
snaps and wrap-arounds; an experience map growing linearly to 5,000 experiences and 6,500
links; a GTSAM estimate growing to 6,000 keyframes and 3,000 proposed closures. Only the
recorder's own calls are timed. Reports the .rrd size (target <= 300 MB) and the recorder's
time per tick; ``--sweep`` repeats this for several ``every_map`` periods.

``--real SECONDS``: the office_floor world (Fig 4) run through the real RatSLAM (40 x 40 x 36
grid, as the fig4 entry) and GTSAM baseline, with the recorder at its defaults: reports the run's
wall time, the recorder's share of it (target <= 25 %) and the .rrd size. ``--real 9000`` is
the full 2.5-hour figure.

Timings are noisy on a shared 2-core machine; the overhead ratio is the figure to compare.

Measured: docs/speed.md ("The Rerun recording").
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from harness.record.recorder import Recorder


class SyntheticRatSLAM:
    """Stand-in with RatSLAM's read-access attributes; sizes grow linearly over the run."""

    def __init__(self, n_ticks: int, grid=(60, 60, 36), n_exp=5000, n_links=6500, seed=0):
        rng = np.random.default_rng(seed)
        self.grid, self.n_ticks = grid, n_ticks
        self._poses = np.column_stack([rng.uniform(0, 25, n_exp), rng.uniform(0, 13, n_exp), rng.uniform(-3, 3, n_exp)])
        self._cells = rng.uniform(0, grid[0], (n_exp, 3))
        self._last = np.sort(rng.integers(0, n_ticks, n_exp))
        chain = np.column_stack([np.arange(n_exp - 1), np.arange(1, n_exp)])
        extra = np.sort(rng.integers(0, n_exp, (n_links - len(chain), 2)), axis=1)
        self._links = np.concatenate([chain, extra])[np.argsort(np.r_[chain[:, 1], extra[:, 1]], kind="stable")]
        nx, ny, nt = grid
        x, y, t = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nt), indexing="ij")
        self._blobs = [
            np.exp(-((x - cx) ** 2 + (y - cy) ** 2) / 4.0 - (t - ct) ** 2 / 2.0)
            for cx, cy, ct in rng.uniform(0, nx, (8, 3))
        ]
        self._rng = rng
        self.peak = np.array([nx / 2, ny / 2, 0.0])
        self.snapped = False
        self.k = 0

    def step(self, k: int) -> None:
        self.k = k
        nx, ny, nt = self.grid
        self.snapped = k % 600 == 599
        step = 8.0 if self.snapped else 0.17  # 0.3 m/s at 7 Hz in 0.25 m cells
        heading = 2 * np.pi * (k // 700) / 7.0
        self.peak = np.mod(self.peak + [step * np.cos(heading), step * np.sin(heading), 0.0], [nx, ny, nt])

    def _n(self, total: int) -> int:
        return max(1, int(total * (self.k + 1) / self.n_ticks))

    @property
    def pose_cell_activity(self):
        return self._blobs[(self.k // 35) % len(self._blobs)]

    @property
    def experience_poses(self):
        return self._poses[: self._n(len(self._poses))].copy()

    @property
    def experience_last_tick(self):
        return np.minimum(self._last[: self._n(len(self._last))], self.k)

    @property
    def links(self):
        n = self._n(len(self._poses))
        lk = self._links[: self._n(len(self._links))]
        return lk[(lk < n).all(axis=1)]


class SyntheticPoseGraph:
    def __init__(self, n_ticks: int, n_kf=6000, n_closures=3000, seed=1):
        rng = np.random.default_rng(seed)
        self.n_ticks, self.k = n_ticks, 0
        self._kf = np.column_stack([rng.uniform(0, 25, n_kf), rng.uniform(0, 13, n_kf), rng.uniform(-3, 3, n_kf)])
        self._ticks = np.linspace(0, n_ticks - 1, n_kf).astype(int)
        self._pairs = np.sort(rng.integers(0, n_kf, (n_closures, 2)), axis=1)
        self._pairs = self._pairs[np.argsort(self._pairs[:, 1], kind="stable")]
        self._acc = rng.random(n_closures) < 0.8

    def step(self, k: int) -> None:
        self.k = k

    @property
    def keyframe_poses(self):
        return self._kf[: int(np.searchsorted(self._ticks, self.k, side="right"))].copy()

    @property
    def keyframe_ticks(self):
        return self._ticks[: int(np.searchsorted(self._ticks, self.k, side="right"))]

    @property
    def loop_closures(self):
        return self._pairs[self._pairs[:, 1] < len(self.keyframe_ticks)]

    @property
    def closure_accepted(self):
        return self._acc[: len(self.loop_closures)]


def synthetic(n_ticks: int, every_map: int, every_activity: int, out: Path) -> dict:
    """Time the recorder alone on a synthetic run; returns seconds, µs/tick and MB."""
    rs, pg = SyntheticRatSLAM(n_ticks), SyntheticPoseGraph(n_ticks)
    walls = np.array([[[0, 0], [25, 0]], [[25, 0], [25, 13]], [[25, 13], [0, 13]], [[0, 13], [0, 0]]], float)
    s = np.arange(n_ticks) * 0.3 / 7.0
    gt = np.column_stack([12.5 + 10 * np.cos(s / 12), 6.5 + 5 * np.sin(s / 7), s / 12 + np.pi / 2])
    odom = gt + np.column_stack([np.zeros(n_ticks), 1e-5 * np.arange(n_ticks), np.zeros(n_ticks)])
    fp = np.random.default_rng(2).random(n_ticks) < 0.002
    t = (np.arange(n_ticks) + 1) / 7.0
    spent = 0.0
    clock = time.perf_counter
    rec = Recorder(out, walls, rs.grid, every_map=every_map, every_activity=every_activity)
    for k in range(n_ticks):
        rs.step(k)
        pg.step(k)
        t0 = clock()
        rec.log_tick(k, t[k], gt[k], odom[k], rs, pg, bool(fp[k]))
        spent += clock() - t0
    t0 = clock()
    rec.close()
    spent += clock() - t0
    return {"seconds": spent, "us_per_tick": 1e6 * spent / n_ticks, "mb": out.stat().st_size / 1e6}


def real(duration: float, out: Path) -> dict:
    """The office_floor world through the real systems, with and without the recorder."""
    from harness.run.runner import dead_reckon, run_stream
    from ratslam import PoseCellConfig, RatSLAMConfig
    from worlds import load_world, simulate

    world = load_world("office_floor")
    log = simulate(world, duration=duration, seed=0)
    odo, gt, fp = dead_reckon(log), log.ground_truth(), log.false_positive
    cfg = RatSLAMConfig(pose_cells=PoseCellConfig(nx=40, ny=40, n_theta=36))
    rec = Recorder(out, world.walls, cfg.shape)
    spent = [0.0]

    def on_tick(k, rs, pg):
        t0 = time.perf_counter()
        rec.log_tick(k, log.t[k], gt[k], odo[k], rs, pg, bool(fp[k]))
        spent[0] += time.perf_counter() - t0

    t0 = time.perf_counter()
    res = run_stream(log, cfg, on_tick=on_tick)
    t1 = time.perf_counter()
    rec.close()
    spent[0] += time.perf_counter() - t1
    wall = time.perf_counter() - t0
    return {
        "ticks": len(log),
        "wall_s": wall,
        "recorder_s": spent[0],
        "share": spent[0] / wall,
        "overhead_vs_run_without": spent[0] / (wall - spent[0]),
        "mb": out.stat().st_size / 1e6,
        "experiences": len(res.ratslam.experience_poses),
        "links": len(res.ratslam.links),
        "keyframes": len(res.gtsam.keyframe_poses),
        "slam_wall": res.wall,
    }


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--ticks", type=int, default=63000)
    p.add_argument("--every-map", type=int, default=70)
    p.add_argument("--every-activity", type=int, default=35)
    p.add_argument("--sweep", action="store_true", help="also every_map = 35, 140, 350")
    p.add_argument("--real", type=float, default=None, metavar="SECONDS", help="office_floor run of this length")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        periods = [args.every_map] + ([m for m in (35, 140, 350) if m != args.every_map] if args.sweep else [])
        print(f"synthetic: {args.ticks} ticks, 60x60x36 grid, 5,000 experiences, 6,000 keyframes")
        for m in periods:
            r = synthetic(args.ticks, m, args.every_activity, Path(tmp) / f"syn{m}.rrd")
            print(
                f"  every_map={m:4d} every_activity={args.every_activity}: {r['mb']:7.1f} MB, "
                f"recorder {r['seconds']:6.1f} s = {r['us_per_tick']:6.1f} us/tick"
            )
        if args.real:
            r = real(args.real, Path(tmp) / "real.rrd")
            print(
                f"real office_floor {args.real:.0f} s ({r['ticks']} ticks, {r['experiences']} experiences, "
                f"{r['links']} links, {r['keyframes']} keyframes): run {r['wall_s']:.1f} s, recorder "
                f"{r['recorder_s']:.1f} s = {100 * r['share']:.1f}% of the run "
                f"({100 * r['overhead_vs_run_without']:.1f}% on top of the systems), {r['mb']:.1f} MB; "
                f"systems {r['slam_wall']}"
            )


if __name__ == "__main__":
    main()
