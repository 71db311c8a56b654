"""Benchmark: a large box's pose-cell step, whole (``ratslam.pose_cell_split.step_one_box``)
against layer by layer (``ratslam.pose_cell_layers.step_one_box``), call by call.

Run:  python bench/bench_layers.py [--streams a,b,...] [--every 4] [--most 4000] [--repeats 3]

For each stream of ``bench/streams.py`` the script steps RatSLAM (default configuration) over the
whole stream, every one-box step stepped whole, and keeps the arguments of every ``--every``-th of
the first ``--most`` steps of a box of ``LAYERED_MIN_CELLS`` cells or more. It then times both
forms on each kept call (best of ``--repeats``), checks that they return the same values bit for
bit, and prints their totals by the cover of the box's layers' rectangles (the fraction of the box
the layer-by-layer step works on), with the ratio.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import step_timer  # noqa: E402
from bench_ratslam import write_stream  # noqa: E402

import ratslam.pose_cells as pose_cells  # noqa: E402
from ratslam import pose_cell_layers as L  # noqa: E402
from ratslam import pose_cell_split as S  # noqa: E402

BINS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 1.01)


def large_calls(path: Path, every: int, most: int) -> list[tuple]:
    """The arguments of the large one-box steps of a whole run of the stream file ``path``."""
    data = np.load(path)
    dt, v, w, s = (data[k].tolist() for k in ("dt", "v_trans", "v_rot", "scene_id"))
    kept: list[tuple] = []
    seen = 0
    whole, bound = S.step_one_box, pose_cells.LAYERED_MIN_CELLS

    def keep(act, *rest):
        nonlocal seen
        if act.size >= bound and seen < most:
            if seen % every == 0:
                kept.append((act.copy(), *(a.copy() if isinstance(a, np.ndarray) else a for a in rest)))
            seen += 1
        return whole(act, *rest)

    S.step_one_box = keep
    pose_cells.LAYERED_MIN_CELLS = 10**12  # every box stepped whole (the same values either way)
    try:
        slam = step_timer.make_slam(data["grid"])
        for k in range(len(dt)):
            slam.step(dt[k], v[k], w[k], s[k])
    finally:
        S.step_one_box, pose_cells.LAYERED_MIN_CELLS = whole, bound
    return kept


def best_of(fn, args, repeats: int) -> tuple[float, tuple]:
    best, out = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn(*args)
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> None:
    from streams import STREAMS

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--streams", default="independent_square,small_loop_hard,plaza2_hard")
    ap.add_argument("--every", type=int, default=4)
    ap.add_argument("--most", type=int, default=4000)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    names = a.streams.split(",")
    unknown = [n for n in names if n not in STREAMS]
    if unknown:
        sys.exit(f"--streams: unknown stream {unknown[0]!r} (known: {', '.join(STREAMS)})")
    print("one large box's step, whole against layer by layer (ms over the calls, each call's best)")
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            path = Path(tmp) / f"{name}.npz"
            write_stream(name, path)
            calls = large_calls(path, a.every, a.most)
            if not calls:
                print(f"  {name}: no box of {pose_cells.LAYERED_MIN_CELLS} cells or more")
                continue
            S.step_one_box(*calls[0])  # loaded before timing
            L.step_one_box(calls[0][0], L.layer_windows(calls[0][0]), *calls[0][1:])
            rows = []
            for args in calls:
                act = args[0]
                rect = L.layer_windows(act)
                sizes = np.clip(rect[:, [1, 3]] - rect[:, [0, 2]], 0, None)
                cover = float(np.sum(sizes[:, 0] * sizes[:, 1]))
                t_whole, want = best_of(S.step_one_box, args, a.repeats)
                t_layers, got = best_of(L.step_one_box, (act, rect, *args[1:]), a.repeats)
                same = want[0] == got[0] and np.array_equal(want[1], got[1]) and want[2].tobytes() == got[2].tobytes()
                if not (same and want[2].shape == got[2].shape and want[3].tobytes() == got[3].tobytes()):
                    sys.exit(f"{name}: the two forms differ on a call (box {act.shape})")
                rows.append((cover / act.size, t_whole, t_layers))
            r = np.array(rows)
            whole, layers = r[:, 1].sum() * 1e3, r[:, 2].sum() * 1e3
            print(
                f"  {name:18s} {len(r):5d} calls: whole {whole:7.1f}  layers {layers:7.1f}  "
                f"ratio {whole / layers:.2f}x  (mean cover {r[:, 0].mean():.3f})"
            )
            for lo, hi in zip(BINS[:-1], BINS[1:]):
                m = (r[:, 0] >= lo) & (r[:, 0] < hi)
                if m.any():
                    whole, layers = r[m, 1].sum() * 1e3, r[m, 2].sum() * 1e3
                    print(
                        f"      cover {lo:4.2f}-{min(hi, 1.0):4.2f}: {m.sum():5d} calls  whole {whole:7.1f}  "
                        f"layers {layers:7.1f}  ratio {whole / layers:.2f}x"
                    )


if __name__ == "__main__":
    main()
