"""View-matcher throughput against the number of stored templates: frames per second.

    python bench/bench_view_matcher.py [--world office_floor] [--templates 1000 5000 20000] [--queries 300]

Templates are real views: frames of a long simulated run of the world (forward camera, or
panoramic with ``--panoramic``), spread evenly over it, stored without matching. Queries are frames
of another run (another seed), spread over it (``--consecutive``: its first ticks in order, as a
stream), through ``ViewMatcher.match`` with the default settings (mean pre-filter and the exact
bounds), then without the pre-filter, and the exhaustive search (every template at every shift,
no bound) for reference.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ratslam import ViewConfig
from ratslam.view_matcher import ViewMatcher
from worlds import load_world, simulate
from worlds.camera import Camera


def frames(world, kind: str, n: int, seed: int, consecutive: bool = False) -> np.ndarray:
    """``n`` frames spread over a run long enough to give them all (or its first ``n`` ticks)."""
    duration = max(900.0, n / world.tick_rate)
    log = simulate(world, duration=duration, seed=seed)
    pick = np.arange(n) if consecutive else np.linspace(0, len(log) - 1, n).astype(int)
    poses = np.column_stack([log.gt_x, log.gt_y, log.gt_theta])[pick]
    return Camera(world, kind, seed=seed).render_poses(poses, log.t[pick])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="office_floor")
    ap.add_argument("--templates", nargs="+", type=int, default=[1000, 5000, 20000])
    ap.add_argument("--queries", type=int, default=300)
    ap.add_argument("--panoramic", action="store_true")
    ap.add_argument(
        "--consecutive", action="store_true", help="queries: consecutive ticks (a stream), not spread over a run"
    )
    args = ap.parse_args()
    world = load_world(args.world)
    kind = "panoramic" if args.panoramic else "forward"
    cfg = ViewConfig(field_of_view_deg=360.0, template_width=64) if args.panoramic else ViewConfig()
    stored = frames(world, kind, max(args.templates), seed=0)
    queries = frames(world, kind, args.queries, seed=1, consecutive=args.consecutive)
    how = "consecutive" if args.consecutive else "spread"
    print(
        f"{world.name}, {kind} camera, templates {cfg.template_height}x{cfg.template_width}, "
        f"{args.queries} {how} queries"
    )
    print("templates  shifts   default frames/s  no pre-filter frames/s  exhaustive frames/s  matched")
    for n in args.templates:
        row = []
        matched = 0
        for prefilter in (True, False):
            vm = ViewMatcher(ViewConfig(**{**_fields(cfg), "mean_prefilter": prefilter}))
            for im in stored[np.linspace(0, len(stored) - 1, n).astype(int)]:
                vm.store(im)
            vm.match(queries[0])  # compile outside the timing
            t0 = time.perf_counter()
            out = [vm.match(q) for q in queries]
            row.append(len(queries) / (time.perf_counter() - t0))
            if prefilter:
                matched = sum(not m.new for m in out)
        few = queries[: max(5, args.queries // 20)]
        vm.differences(few[0])
        t0 = time.perf_counter()
        for q in few:
            vm.differences(q)
        exhaustive = len(few) / (time.perf_counter() - t0)
        print(f"{n:>9}  {len(vm.shifts):>6}  {row[0]:>17,.0f}  {row[1]:>22,.0f}  {exhaustive:>19,.1f}  {matched:>7}")


def _fields(cfg: ViewConfig) -> dict:
    import dataclasses

    return {f.name: getattr(cfg, f.name) for f in dataclasses.fields(cfg)}


if __name__ == "__main__":
    main()
