"""One sweep run: simulate a condition once and step every configured system through that stream
in one pass of the stream loop (:func:`harness.run.stream.step_stream`).

:func:`run_one` is a pure function of its task (same task, same result, bit for bit); it is what
executors ship to workers. This module, the SLAM packages, the simulator and the metrics are what
a run's result depends on, so their source is hashed into every run id
(:func:`harness.sweeps.run.code_version`); the driver and the executors are not.
"""

from __future__ import annotations

import math
import os
import time
import traceback
from pathlib import Path
from typing import Any

import numpy as np

from baselines import PoseGraphConfig, PoseGraphSLAM
from ratslam import RatSLAM, RatSLAMConfig
from slamkit.config_fields import from_dict, replace
from worlds import ObservationLog, load_world, simulate

from ..report import metrics
from ..report.evaluate import CLOSURE_TRUE_DISTANCE, closure_quality
from ..run.conditions import condition_scenes, condition_world
from ..run.config_file import with_preset
from ..run.runner import dead_reckon
from ..run.scale import derive_configs
from ..run.stream import Trace, step_stream


def condition_log(task: dict) -> ObservationLog:
    """The task's stream: simulated in its world (seen through its camera, if any), or the real
    log's odometry with place labels synthesised under the condition (the seed: the labels')."""
    condition, seed = task["condition"], task["seed"]
    if "log" in task:
        from worlds.real_data import PLAZA_SCENES

        from .base_log import read_base_log, relabelled

        base = read_base_log(task["log"], task["duration"])
        return relabelled(base, condition_scenes(PLAZA_SCENES, condition), seed)
    world = condition_world(load_world(task["world"]), {"lookalikes": task.get("lookalikes", True), **condition})
    log = simulate(world, duration=task["duration"], seed=seed)
    if task.get("camera") is not None:
        from ratslam import ViewConfig

        from ..camera.stream import camera_observations

        log = camera_observations(world, log, task["camera"], seed, from_dict(ViewConfig, task["view"]))
    return log


def system_configs(task: dict, log: ObservationLog) -> dict[str, RatSLAM | PoseGraphSLAM]:
    """The task's systems, built: with their configurations as given, or, for a real log, derived
    from the labelled log as ``replay`` derives them (no ground truth), a RatSLAM preset applied
    to the derived configuration (as ``replay --ratslam published``) and the spec's fields on top."""
    out: dict[str, RatSLAM | PoseGraphSLAM] = {}
    derived = None
    for s in task["systems"]:
        if "fields" not in s:
            out[s["name"]] = _build(s["kind"], s["config"])
            continue
        derived = derived or derive_configs(log)
        if s["kind"] == "ratslam":
            out[s["name"]] = RatSLAM(replace(with_preset(derived[0], s.get("preset")), s["fields"]))
        else:
            out[s["name"]] = PoseGraphSLAM(replace(derived[1], s["fields"]))
    return out


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
        log = condition_log(task)
        gt = log.ground_truth()
        traces, _ = step_stream(log, system_configs(task, log))
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
