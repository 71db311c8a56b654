"""One sweep run: simulate a condition once and step every configured system through that stream
in one pass of the stream loop (:func:`harness.stream.step_stream`).

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
from typing import Any

import numpy as np

from baselines import PoseGraphConfig, PoseGraphSLAM
from ratslam import RatSLAM, RatSLAMConfig
from slamkit.config_fields import from_dict
from worlds import load_world, simulate

from . import metrics
from .evaluate import CLOSURE_TRUE_DISTANCE, closure_quality
from .runner import dead_reckon
from .stream import Trace, step_stream


def condition_world(world_name: str, condition: dict, lookalikes: bool = True):
    """The world with the condition's scene and odometry values (and the simulate() arguments);
    ``condition`` has a value for every axis; ``lookalikes`` False gives the world's look-alike
    regions their own scenes."""
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
    return float(metrics.ate_rmse(est, gt)) if len(est) >= 2 else math.nan


def _build(kind: str, config_fields: dict) -> RatSLAM | PoseGraphSLAM:
    """A system of ``kind`` ("ratslam" or "gtsam") with the given configuration fields."""
    if kind == "ratslam":
        return RatSLAM(from_dict(RatSLAMConfig, config_fields))
    return PoseGraphSLAM(from_dict(PoseGraphConfig, config_fields))


def _measure(trace: Trace, gt: np.ndarray) -> dict[str, Any]:
    """One system's run over the whole log: accuracy (online and map), sizes, wall time."""
    system = trace.system
    if isinstance(system, RatSLAM):
        ticks = system.experience_first_tick
        map_poses = system.experience_poses
        closure_precision = closure_recall = None
    else:
        ticks = system.keyframe_ticks
        map_poses = system.keyframe_poses
        lc = closure_quality(system, gt, CLOSURE_TRUE_DISTANCE)
        closure_precision, closure_recall = lc.precision, lc.recall
    return {
        "ate_online": _ate(trace.pose, gt),
        "wall_s": trace.wall_s,
        "ate_map": _ate(map_poses, gt[ticks]),
        "nodes": int(len(ticks)),
        "snaps": None if trace.snapped is None else int(trace.snapped.sum()),
        "closure_precision": closure_precision,
        "closure_recall": closure_recall,
    }


def run_one(task: dict) -> dict:
    """Simulate the task's condition once and run every system on that stream. Never raises: a
    failure is returned as a one-line ``error`` (the sweep records it and goes on)."""
    start = time.perf_counter()
    try:
        world, sim_args = condition_world(task["world"], task["condition"], task.get("lookalikes", True))
        log = simulate(world, duration=task["duration"], seed=task["seed"], **sim_args)
        gt = log.ground_truth()
        traces, _ = step_stream(log, {s["name"]: _build(s["kind"], s["config"]) for s in task["systems"]})
        systems = {s["name"]: {"kind": s["kind"], **_measure(traces[s["name"]], gt)} for s in task["systems"]}
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
