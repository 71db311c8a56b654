"""The settings sized for scene numbers, measured on camera streams (docs/camera.md).

    python bench/camera_defaults.py --figure fig7 fig13 --camera forward panoramic [--variants default wheel_errors]
        [--duration S] [--only "scene defaults" "camera (derived)" ...]

For each figure variant's simulated stream (seed 0, the figure's duration) seen through the camera:

1. the stream's statistics against ground truth (for the record only): how long a label lasts
   (median run, ticks and metres), and how well a revisit places the robot: every onset of a label
   paired with the latest earlier onset of it at least 4 m of path back (as the pose graph picks
   closure candidates), the true displacement between the two, per axis (robust sigma of the
   pairs within 3 m, and the share within 3 m), and the true heading change (without and with the
   view's rotation);
2. RatSLAM (the project's defaults) and GTSAM run on it with each setting of :func:`settings`:
   the scene-number defaults, :func:`harness.camera.stream.camera_configs` (what camera runs
   use), that derivation with each of its changes undone, and with each rule measured and not
   adopted added to it alone (a habituation giving a template a scene number's injection per
   tick; ``min_age_ticks`` halved and doubled).

The scene-number stream of the same variant is measured the same way, as the reference.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time

import numpy as np

from baselines import PoseGraphConfig
from harness.camera.stream import camera_configs, camera_observations, camera_view_config
from harness.figures.registry import get_figure
from harness.figures.streams import variant_configs, variant_log, variant_world
from harness.report.evaluate import evaluate_stream
from harness.run.runner import run_stream
from harness.run.scale import REFERENCE_LABEL_LENGTH_M, REFERENCE_STEP_M, measure_log
from ratslam import RatSLAMConfig
from worlds import load_world

REFERENCE_RUN_TICKS = REFERENCE_LABEL_LENGTH_M / REFERENCE_STEP_M
"""Ticks a scene number of the simulator's 1 m cells lasts (0.9 m at 0.043 m per tick: 21)."""


def injected_per_tick(run_ticks: float, fatigue_rate: float) -> float:
    """Energy (in units of the injection strength) a view cell injects per tick over a run of
    ``run_ticks`` ticks in view, from rested: its activity ``1 - fatigue`` summed over the run,
    divided by the run."""
    n = max(1, round(run_ticks))
    k = np.arange(n)
    return float(np.maximum(1.0 - fatigue_rate * k, 0.0).sum() / n)


def habituation_rate(run_ticks: float, reference_rate: float) -> float:
    """The fatigue rate at which a view of ``run_ticks`` ticks injects as much per tick as a scene
    number of :data:`REFERENCE_RUN_TICKS` ticks does at ``reference_rate`` (bisection; never below
    ``reference_rate``)."""
    target = injected_per_tick(REFERENCE_RUN_TICKS, reference_rate)
    if injected_per_tick(run_ticks, reference_rate) <= target:
        return reference_rate
    lo, hi = reference_rate, 1.0
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if injected_per_tick(run_ticks, mid) > target else (lo, mid)
    return round(hi, 3)


def label_stats(log) -> dict:
    """Runs and revisit scatter of a stream's labels, against ground truth."""
    s = np.asarray(log.scene_id)
    gt = log.ground_truth()
    step = np.r_[0.0, np.hypot(np.diff(gt[:, 0]), np.diff(gt[:, 1]))]
    path = np.cumsum(step)
    start = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
    end = np.r_[start[1:], s.size]
    keep = s[start] >= 0
    runs_ticks = (end - start)[keep]
    runs_m = (path[end - 1] - path[start])[keep]
    rot = np.zeros(len(s)) if log.view_rotation is None else np.asarray(log.view_rotation)
    seen: dict[int, list[int]] = {}
    d, dth, dth_rot = [], [], []
    for j in start[keep]:
        earlier = seen.setdefault(int(s[j]), [])
        ok = [i for i in earlier if path[i] <= path[j] - 4.0]
        earlier.append(int(j))
        if not ok:
            continue
        i = ok[-1]
        d.append(gt[j, :2] - gt[i, :2])
        a = gt[j, 2] - gt[i, 2]
        dth.append(math.remainder(a, 2 * math.pi))
        dth_rot.append(math.remainder(a - rot[j], 2 * math.pi))
    d = np.asarray(d).reshape(-1, 2)
    near = np.hypot(d[:, 0], d[:, 1]) < 3.0
    mad = 1.4826 * np.median(np.abs(d[near]), axis=0) if near.any() else np.full(2, np.nan)
    rms = np.sqrt(np.mean(d[near] ** 2)) if near.any() else float("nan")
    th = np.asarray(dth)[near]
    th_r = np.asarray(dth_rot)[near]
    return {
        "labels": int(s.max()) + 1,
        "run_ticks": float(np.median(runs_ticks)),
        "run_m": float(np.median(runs_m)),
        "pairs": len(d),
        "within_3m": float(near.mean()) if len(d) else float("nan"),
        "sigma_xy_mad": float(mad.mean()),
        "sigma_xy_rms": float(rms),
        "sigma_th_deg": float(np.degrees(np.sqrt(np.mean(th**2)))) if th.size else float("nan"),
        "sigma_th_rot_deg": float(np.degrees(np.sqrt(np.mean(th_r**2)))) if th_r.size else float("nan"),
    }


def settings(log, kind: str, view) -> dict[str, tuple[RatSLAMConfig, PoseGraphConfig]]:
    """Named (RatSLAM, pose graph) settings to run: the defaults, the derivation, and the
    derivation with each rule measured and not adopted added to it (or one change undone)."""
    rs0, pg0 = RatSLAMConfig(view=view), PoseGraphConfig()
    rs, pg, _ = camera_configs(log, view, rs0, pg0)
    m = measure_log(log)
    out = {"scene defaults": (rs0, pg0), "camera (derived)": (rs, pg)}
    out["derived, heading sigmas as scenes"] = (
        rs.replace(yaw_bias={"revisit_sigma_heading_deg": rs0.yaw_bias.revisit_sigma_heading_deg}),
        pg.replace(closures={"sigma_theta_rad": pg0.closures.sigma_theta_rad}),
    )
    out["derived, position sigmas as scenes"] = (
        rs.replace(yaw_bias={"revisit_sigma_xy_m": rs0.yaw_bias.revisit_sigma_xy_m}),
        pg.replace(closures={"sigma_xy_m": pg0.closures.sigma_xy_m}),
    )
    rate = habituation_rate(m.label_length / m.step, rs.local_view.fatigue_rate)
    out[f"+ fatigue_rate {rate:g} (same injection per tick)"] = (rs.replace(local_view={"fatigue_rate": rate}), pg)
    for age in (35, 140):
        out[f"+ min_age_ticks {age}"] = (rs.replace(local_view={"min_age_ticks": age}), pg)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--figure", nargs="+", default=["fig7", "fig13"])
    ap.add_argument("--camera", nargs="+", default=["forward"])
    ap.add_argument("--variants", nargs="+", default=None, help="default: every variant of the figure")
    ap.add_argument("--duration", type=float, default=None)
    ap.add_argument("--stats-only", action="store_true")
    ap.add_argument("--only", nargs="+", default=None, help="run only the settings whose label starts so")
    args = ap.parse_args()
    for name in args.figure:
        fig = get_figure(name)
        world0 = load_world(fig.world)
        for variant in fig.variants:
            if args.variants and variant.name not in args.variants:
                continue
            world = variant_world(fig, world0, variant)
            log = variant_log(fig, world, args.duration or fig.duration, fig.seed)
            base_rs, _, _ = variant_configs(fig, variant, log)
            st = label_stats(log)
            print(f"\n## {name} {variant.name}: scene numbers {st}", flush=True)
            for kind in args.camera:
                view = camera_view_config(kind)
                clog = camera_observations(world, log, kind, fig.seed, view)
                st = label_stats(clog)
                print(f"### {name} {variant.name} {kind}: {st}", flush=True)
                if args.stats_only:
                    continue
                for label, (rs, pg) in settings(clog, kind, view).items():
                    if args.only and not any(label.startswith(o) for o in args.only):
                        continue
                    rs = rs.replace(pose_cells=dataclasses.asdict(base_rs.pose_cells))
                    t0 = time.perf_counter()
                    res = run_stream(clog, rs, pg)
                    r = evaluate_stream(res, clog)
                    print(
                        f"{name:5} {variant.name:14} {kind:9} {label:36} exp_map {r.ate.experience_map:.3f}"
                        f"  gtsam {r.ate.gtsam:.3f}  odo {r.ate.odometry:.3f}  experiences "
                        f"{len(res.ratslam.experience_poses):4d}  snaps {int(res.snapped.sum()):3d}"
                        f"  ({time.perf_counter() - t0:.1f} s)",
                        flush=True,
                    )


if __name__ == "__main__":
    main()
