"""One sweep run: simulate a condition once and run every configured system on that stream.

:func:`run_one` is a pure function of its task (same task, same result, bit for bit); it is what
executors ship to workers. This module, the SLAM packages, the simulator and the metrics are what
a run's result depends on, so their source is hashed into every run id
(:func:`harness.sweep_run.code_version`); the driver and the executors are not.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
import traceback
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from baselines import PoseGraphSLAM
    from ratslam import RatSLAM


def condition_world(world_name: str, condition: dict, lookalikes: bool = True):
    """The world with the condition's scene and odometry values (and the simulate() arguments);
    ``condition`` has a value for every axis; ``lookalikes`` False gives the world's look-alike
    regions their own scenes."""
    from worlds import load_world

    world = load_world(world_name)
    scenes, odo = world.scenes, world.odometry
    scenes = dataclasses.replace(
        scenes,
        alias_rate=condition.get("alias_rate", scenes.alias_rate),
        blank_rate=condition.get("blank_rate", scenes.blank_rate),
        lookalikes=scenes.lookalikes if lookalikes else (),
    )
    scale = condition.get("odometry_noise_scale", 1.0)
    odo = dataclasses.replace(odo, noise_trans=odo.noise_trans * scale, noise_rot=odo.noise_rot * scale)
    world = dataclasses.replace(world, scenes=scenes, odometry=odo)
    return world, {"bias_deg_s": condition["odometric_bias"], "fp_rate": condition["fp_rate"]}


def _ate(est, gt) -> float:
    from . import metrics

    return float(metrics.ate_rmse(est, gt)) if len(est) >= 2 else math.nan


def _drive(system: RatSLAM | PoseGraphSLAM, log) -> tuple[np.ndarray, int, float]:
    """Step ``system`` through the whole log: its online pose per tick, the snaps of RatSLAM's
    pose cells (0 for the pose graph) and the wall time."""
    from ratslam import RatSLAM

    n = len(log)
    online = np.zeros((n, 3))
    snaps = 0
    rows = zip(log.dt.tolist(), log.v_trans.tolist(), log.v_rot.tolist(), log.scene_id.tolist())
    t0 = time.perf_counter()
    for k, (dt, v, w, scene) in enumerate(rows):
        system.step(dt, v, w, scene)
        online[k] = system.pose
        if isinstance(system, RatSLAM):
            snaps += system.snapped
    if not isinstance(system, RatSLAM):
        system.finalize()
    return online, snaps, time.perf_counter() - t0


def _run_system(kind: str, config_fields: dict, log, gt: np.ndarray) -> dict[str, Any]:
    """One system over the whole log: accuracy (online and map), sizes, wall time."""
    from baselines import PoseGraphConfig, PoseGraphSLAM
    from ratslam import RatSLAM, RatSLAMConfig
    from ratslam.config_fields import from_dict

    from .evaluate import CLOSURE_TRUE_DISTANCE, closure_quality

    if kind == "ratslam":
        rs = RatSLAM(from_dict(RatSLAMConfig, config_fields))
        online, snaps, wall = _drive(rs, log)
        ticks = rs.experience_first_tick
        return {
            "ate_online": _ate(online, gt),
            "wall_s": wall,
            "ate_map": _ate(rs.experience_poses, gt[ticks]),
            "nodes": int(len(ticks)),
            "snaps": int(snaps),
            "closure_precision": None,
            "closure_recall": None,
        }
    pg = PoseGraphSLAM(from_dict(PoseGraphConfig, config_fields))
    online, _, wall = _drive(pg, log)
    ticks = pg.keyframe_ticks
    lc = closure_quality(pg, gt, CLOSURE_TRUE_DISTANCE)
    return {
        "ate_online": _ate(online, gt),
        "wall_s": wall,
        "ate_map": _ate(pg.keyframe_poses, gt[ticks]),
        "nodes": int(len(ticks)),
        "snaps": None,
        "closure_precision": lc.precision,
        "closure_recall": lc.recall,
    }


def run_one(task: dict) -> dict:
    """Simulate the task's condition once and run every system on that stream. Never raises: a
    failure is returned as a one-line ``error`` (the sweep records it and goes on)."""
    start = time.perf_counter()
    try:
        from worlds import simulate

        from .runner import dead_reckon

        world, sim_args = condition_world(task["world"], task["condition"], task.get("lookalikes", True))
        log = simulate(world, duration=task["duration"], seed=task["seed"], **sim_args)
        gt = log.ground_truth()
        systems = {
            s["name"]: {"kind": s["kind"], **_run_system(s["kind"], s["config"], log, gt)} for s in task["systems"]
        }
        result = {"ate_odometry": _ate(dead_reckon(log), gt), "ticks": len(log), "systems": systems, "error": None}
    except Exception as e:
        where = traceback.extract_tb(e.__traceback__)[-1]
        result = {
            "error": f"{type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''} "
            f"({Path(where.filename).name}:{where.lineno})",
            "systems": {},
        }
    result["wall_s"] = time.perf_counter() - start
    result["pid"] = os.getpid()
    return result
