"""Where a figure's pose graph spends its time: ``PoseGraphSLAM.step`` over one variant's stream.

Run:
    python bench/profile_pose_graph.py stream fig4 OUT.csv [--camera forward]
    python bench/profile_pose_graph.py time OUT.csv fig4 [--camera forward] [--ticks N] [--profile OUT.prof]

``stream`` writes the figure's first variant's observation log as a figure run builds it
(simulated with the figure's seed; with ``--camera``, rendered and matched as
``harness.camera.stream.camera_views`` does, the scene numbers replaced by template numbers).
``time`` steps a fresh pose graph over that log (its first ``--ticks``), configured as the figure
run configures it (``harness.camera.stream.camera_configs`` for a camera log, which reads the log's
labels only), and prints one JSON line: CPU seconds per quarter and in all, keyframes, closures
proposed and accepted, the iSAM2 updates (with closures, early flushes), the variables they
re-eliminated and relinearised, the recoveries, and the keyframe ATE of the online estimate
(SE(2)-aligned, ground truth read here only).

``--drop-wrong-closures D`` is a diagnostic that reads the ground truth: closure candidates more
than ``D`` metres from the new keyframe in truth (wrong matches) are never proposed, to measure
what the wrong ones cost.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import cProfile
import json
import math
import time

import numpy as np

import baselines.optimizers as optimizers
import baselines.pose_graph as pose_graph
from baselines import PoseGraphConfig, PoseGraphSLAM
from harness.figures import streams as figure_streams
from harness.figures.registry import FIGURES
from worlds import ObservationLog, load_world


def _figure(name: str):
    fig = FIGURES[name]
    world = load_world(fig.world) if fig.world is not None else None
    variant = fig.variants[0]
    return fig, variant, figure_streams.variant_world(fig, world, variant)


def build_stream(name: str, out: str, camera: str | None) -> None:
    fig, _, world = _figure(name)
    log = figure_streams.variant_log(fig, world, None, fig.seed)
    if camera is not None:
        from harness.camera.stream import camera_view_config, camera_views

        log, _ = camera_views(world, log, camera, fig.seed, camera_view_config(camera))
    log.write_csv(out)


def figure_config(name: str, log: ObservationLog, camera: str | None) -> PoseGraphConfig:
    fig, variant, _ = _figure(name)
    rs, pg, _ = figure_streams.variant_configs(fig, variant, log)
    if camera is not None:
        from harness.camera.stream import camera_configs, camera_view_config

        view = camera_view_config(camera)
        _, pg, _ = camera_configs(log, view, rs.replace(view=view), pg)
    return pg


_COUNTS = {"reeliminated": 0, "relinearized": 0}


class _CountingISAM2:
    """iSAM2 that adds up (in ``_COUNTS``) what each update re-eliminated and relinearised."""

    def __init__(self, isam) -> None:
        self._isam = isam

    def update(self, *args):
        result = self._isam.update(*args)
        if args:
            _COUNTS["reeliminated"] += result.getVariablesReeliminated()
            _COUNTS["relinearized"] += result.getVariablesRelinearized()
        return result

    def __getattr__(self, name):
        return getattr(self._isam, name)


def _drop_wrong_closures(log: ObservationLog, distance: float) -> None:
    """Diagnostic: the pose graphs made from now on never propose a closure between keyframes more
    than ``distance`` metres apart in truth."""
    truth = np.asarray(log.ground_truth())[:, :2]
    proposing: list[PoseGraphSLAM] = []

    class TrueIndex(pose_graph.SceneIndex):
        def candidates(self, *args):
            slam = proposing[-1]
            here = truth[slam.tick - 1]
            found = super().candidates(*args)
            return [i for i in found if np.hypot(*(truth[slam.keyframe_ticks[i]] - here)) <= distance]

    init = PoseGraphSLAM.__init__

    def remembered_init(self, *args, **kwargs):
        proposing.append(self)
        init(self, *args, **kwargs)

    pose_graph.SceneIndex = TrueIndex  # type: ignore[misc]
    PoseGraphSLAM.__init__ = remembered_init  # type: ignore[method-assign]


def time_stream(log: ObservationLog, config: PoseGraphConfig, ticks: int, profile: str | None) -> dict:
    make = optimizers.make_isam2
    pose_graph.make_isam2 = lambda *a, **k: _CountingISAM2(make(*a, **k))
    updates = {"updates": 0, "with_closures": 0, "early_flushes": 0}
    update, disagrees = PoseGraphSLAM._update_isam, PoseGraphSLAM._disagrees

    def counted_update(self, tagged, *args, **kwargs):
        updates["updates"] += 1
        updates["with_closures"] += any(c is not None for _, c in tagged)
        return update(self, tagged, *args, **kwargs)

    def counted_disagrees(self, closures, guess):
        early = disagrees(self, closures, guess)
        updates["early_flushes"] += early
        return early

    PoseGraphSLAM._update_isam, PoseGraphSLAM._disagrees = counted_update, counted_disagrees
    slam = PoseGraphSLAM(config)
    dt, v, w, s = log.dt, log.v_trans, log.v_rot, log.scene_id
    n = min(ticks, len(log))
    quarters = []
    prof = cProfile.Profile() if profile else None
    if prof:
        prof.enable()
    t0 = last = time.process_time()
    for k in range(n):
        slam.step(dt[k], v[k], w[k], int(s[k]))
        if (k + 1) * 4 % n < 4 and k + 1 >= n // 4:
            now = time.process_time()
            quarters.append(round(now - last, 2))
            last = now
    slam.finalize()
    total = time.process_time() - t0
    if prof:
        prof.disable()
        prof.dump_stats(profile)
    return {
        "ticks": n,
        "cpu_s": round(total, 2),
        "quarters_s": quarters,
        "keyframes": slam.num_keyframes,
        "ms_per_keyframe": round(1000 * total / max(slam.num_keyframes, 1), 2),
        "closures": len(slam.loop_closures),
        "accepted": int(slam.closure_accepted.sum()),
        **updates,
        **_COUNTS,
        "recoveries": slam.isam2_recoveries,
        "yaw_bias_rebuilds": slam.yaw_bias_rebuilds,
        "keyframe_ate_m": round(_ate(slam, log), 4),
    }


def _ate(slam: PoseGraphSLAM, log: ObservationLog) -> float:
    poses = slam.keyframe_poses
    truth = np.asarray(log.ground_truth())[slam.keyframe_ticks, :2]
    f = pose_graph._fit_se2(poses[:, :2], truth)
    c, s = math.cos(f.theta()), math.sin(f.theta())
    x = f.x() + c * poses[:, 0] - s * poses[:, 1]
    y = f.y() + s * poses[:, 0] + c * poses[:, 1]
    return float(np.sqrt(np.mean((x - truth[:, 0]) ** 2 + (y - truth[:, 1]) ** 2)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("stream", help="write a figure's first variant's observation log")
    p.add_argument("figure")
    p.add_argument("out")
    p.add_argument("--camera")
    p = sub.add_parser("time", help="time the pose graph over an observation log")
    p.add_argument("log")
    p.add_argument("figure", help="the figure whose configuration the pose graph gets")
    p.add_argument("--camera", help="the log is a camera stream of this kind")
    p.add_argument("--ticks", type=int, default=10**12)
    p.add_argument("--profile", help="write cProfile statistics here")
    p.add_argument("--drop-wrong-closures", type=float, metavar="D", help="diagnostic, reads ground truth")
    args = parser.parse_args()
    if args.command == "stream":
        build_stream(args.figure, args.out, args.camera)
    else:
        log = ObservationLog.read_csv(args.log)
        if args.drop_wrong_closures is not None:
            _drop_wrong_closures(log, args.drop_wrong_closures)
        print(json.dumps(time_stream(log, figure_config(args.figure, log, args.camera), args.ticks, args.profile)))


if __name__ == "__main__":
    main()
