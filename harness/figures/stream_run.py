"""One stream into a run directory: which RatSLAMs run, their configuration files, the TUM
trajectories and maps.npz, and every system's metrics.

A replay steps its systems here (:func:`run_single_stream`); a figure's variants step theirs in
jobs (:mod:`harness.figures.streams`) and are written by the same :func:`finish_stream`.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from baselines import PoseGraphConfig
from ratslam import RatSLAMConfig
from ratslam.published import departures
from worlds import ObservationLog, World
from worlds.files import atomic_open, write_tum

from ..report.evaluate import CLOSURE_TRUE_DISTANCE, evaluate_stream
from ..report.results import VariantResult
from ..run.config_file import write_config_toml
from ..run.progress import Progress
from ..run.runner import StreamResult, dead_reckon, run_stream

if TYPE_CHECKING:
    from ..camera.stream import CameraViews
    from ..record.recorder import StreamRecorder
    from .registry import ExtraMetrics

RecorderFactory = Callable[[Path, World | None, ObservationLog, RatSLAMConfig, np.ndarray], "StreamRecorder"]
"""``(run directory, world or None, observation log, RatSLAM's configuration) -> StreamRecorder``
(e.g. :func:`harness.record.recorder.recorder_factory`)."""

RatSLAMChoice = Literal["defaults", "published", "both"]
"""Which RatSLAM a run steps: the project's ``defaults``, the paper's algorithm (``published``:
:meth:`ratslam.RatSLAMConfig.published`), or ``both`` on the same stream (the defaults primary)."""

PUBLISHED = "published"


def progress_bar(log: ObservationLog, label: str, show: bool, redraw: bool | None = None) -> Progress:
    """A progress bar over ``log``'s ticks (its rate in simulated time from the median tick)."""
    return Progress(len(log), label, float(np.median(log.dt)), enabled=show, redraw=redraw)


def alternative_names(choice: RatSLAMChoice) -> tuple[str, ...]:
    """The RatSLAMs :func:`ratslam_settings` runs beside the run's own for ``choice``."""
    return (PUBLISHED,) if choice == "both" else ()


def ratslam_settings(
    rs_cfg: RatSLAMConfig, choice: RatSLAMChoice, derivation: str = ""
) -> tuple[RatSLAMConfig, dict[str, RatSLAMConfig], dict[str, str]]:
    """The run's RatSLAM configuration, the alternatives run beside it, and the derivation text
    of each (key "" for the run's own): for the published preset it also names the values, set
    by the log's derivation or by a configuration file, that the preset's fixed values replace
    (none is overwritten silently)."""
    if choice == "defaults":
        return rs_cfg, {}, {"": derivation}
    published = RatSLAMConfig.published(rs_cfg)
    replaced = [d for d in departures(rs_cfg, inert=False) if d not in departures(RatSLAMConfig(), inert=False)]
    published_derivation = derivation
    if replaced:
        published_derivation = (derivation + "\n" if derivation else "") + (
            "The published preset fixes the paper's values over those derived or given: " + "; ".join(replaced) + "."
        )
    if choice == "published":
        return published, {}, {"": published_derivation}
    return rs_cfg, {PUBLISHED: published}, {"": derivation, PUBLISHED: published_derivation}


def write_configs(
    run_dir: Path,
    ratslam_config: RatSLAMConfig,
    gtsam_config: PoseGraphConfig,
    alternatives: dict[str, RatSLAMConfig],
    header: str,
) -> None:
    """The run's effective ``config.toml`` (headed by ``header``) and a ``config_NAME.toml`` for
    each RatSLAM alternative run beside it."""
    write_config_toml(run_dir / "config.toml", ratslam_config, gtsam_config, header)
    for name, config in alternatives.items():
        write_config_toml(
            run_dir / f"config_{name}.toml",
            config,
            gtsam_config,
            header + f"\nRatSLAM here: the {name!r} configuration run beside it on the same stream.",
        )


def finish_stream(
    run_dir: Path,
    log: ObservationLog,
    res: StreamResult,
    ratslam_config: RatSLAMConfig,
    alternatives: dict[str, RatSLAMConfig],
    closure_true_distance: float = CLOSURE_TRUE_DISTANCE,
    extra_metrics: ExtraMetrics | None = None,
) -> tuple[VariantResult, dict[str, VariantResult]]:
    """A stepped stream's TUM trajectories and maps.npz into ``run_dir``, and its metrics (with the
    ``extra_metrics`` of a figure that has them): the run's, and each alternative's measured the
    same way (the pose graph's metrics are shared)."""
    write_stream_outputs(run_dir, log, res)

    def measured(stream: StreamResult, config: RatSLAMConfig) -> VariantResult:
        result = evaluate_stream(stream, log, closure_true_distance=closure_true_distance)
        if extra_metrics is not None:
            result = dataclasses.replace(result, extras=extra_metrics(stream, log, config))
        return result

    return measured(res, ratslam_config), {
        name: measured(res.with_ratslam(name), config) for name, config in alternatives.items()
    }


def run_single_stream(
    run_dir: Path,
    log: ObservationLog,
    ratslam_config: RatSLAMConfig,
    gtsam_config: PoseGraphConfig,
    *,
    config_header: str,
    progress: Progress,
    world: World | None = None,
    recorder_factory: RecorderFactory | None = None,
    closure_true_distance: float = CLOSURE_TRUE_DISTANCE,
    extra_metrics: ExtraMetrics | None = None,
    alternatives: dict[str, RatSLAMConfig] | None = None,
    camera: CameraViews | None = None,
) -> tuple[VariantResult, dict[str, VariantResult]]:
    """One stream through both systems (and the ``alternatives``: name -> another RatSLAM
    configuration, on the same stream in the same pass) into ``run_dir``: its configuration files
    (:func:`write_configs`), the recording (if a ``recorder_factory`` is given; removed if the run
    fails), and :func:`finish_stream`'s outputs and metrics (the caller adds the configuration
    record). ``camera``: a camera stream's views and templates, for the recording."""
    alternatives = alternatives or {}
    write_configs(run_dir, ratslam_config, gtsam_config, alternatives, config_header)
    odometry = dead_reckon(log)  # once: the runner and the recorder share it
    shown = {} if camera is None else {"camera": camera}  # a scene-number run's factory call as ever
    recorder = recorder_factory(run_dir, world, log, ratslam_config, odometry, **shown) if recorder_factory else None
    with recorder if recorder is not None else contextlib.nullcontext():
        on_tick = recorder.on_tick if recorder is not None else None
        res = run_stream(
            log,
            ratslam_config,
            gtsam_config,
            on_tick=on_tick,
            progress=progress,
            odometry=odometry,
            alternatives=alternatives,
        )
    return finish_stream(run_dir, log, res, ratslam_config, alternatives, closure_true_distance, extra_metrics)


def write_stream_outputs(run_dir: Path, log: ObservationLog, res: StreamResult) -> None:
    """TUM trajectories and maps.npz (everything the report's panels need) of one stream."""
    traj = run_dir / "trajectories"
    traj.mkdir(parents=True, exist_ok=True)
    t = log.t
    if log.has_ground_truth:
        write_tum(traj / "ground_truth.tum", t, *log.ground_truth().T)
    write_tum(traj / "odometry.tum", t, *res.odometry.T)
    write_tum(traj / "ratslam.tum", t, *res.ratslam_pose.T)
    write_tum(traj / "gtsam.tum", t, *res.gtsam_pose.T)
    for name, final in (("ratslam_final", res.ratslam_final), ("gtsam_final", res.gtsam_final)):
        if final is not None:  # each tick as the final map places it
            write_tum(traj / f"{name}.tum", t, *final.T)
    rs, pg = res.ratslam, res.gtsam
    order = np.argsort(rs.experience_first_tick)
    write_tum(traj / "ratslam_experiences.tum", t[rs.experience_first_tick[order]], *rs.experience_poses[order].T)
    if len(pg.keyframe_ticks):
        write_tum(traj / "gtsam_keyframes.tum", t[pg.keyframe_ticks], *pg.keyframe_poses.T)
    maps: dict[str, Any] = {
        "grid_shape": np.array(rs.config.shape),
        "peak_cells": res.peak_cells,
        "snapped": res.snapped,
        "experience_poses": rs.experience_poses,
        "experience_cells": rs.experience_cells,
        "experience_last_tick": rs.experience_last_tick,
        "experience_first_tick": rs.experience_first_tick,
        "links": rs.links,
        "keyframe_poses": pg.keyframe_poses,
        "keyframe_ticks": pg.keyframe_ticks,
        "loop_closures": pg.loop_closures,
        "closure_accepted": np.asarray(pg.closure_accepted, dtype=bool),
    }
    if log.has_ground_truth:  # the panels' references, so that a report is redrawn from maps.npz alone
        maps |= {"false_positive": log.false_positive, "ground_truth": log.ground_truth(), "odometry": res.odometry}
    for name, trace in res.alternatives.items():  # other RatSLAM configurations, e.g. the published one
        alt = trace.system
        write_tum(traj / f"ratslam_{name}.tum", t, *trace.pose.T)
        final = trace.final_pose(alt.experience_poses)
        if final is not None:
            write_tum(traj / f"ratslam_{name}_final.tum", t, *final.T)
        order = np.argsort(alt.experience_first_tick)
        write_tum(
            traj / f"ratslam_{name}_experiences.tum",
            t[alt.experience_first_tick[order]],
            *alt.experience_poses[order].T,
        )
        maps |= {
            f"{name}_peak_cells": trace.peak_cells,
            f"{name}_snapped": trace.snapped,
            f"{name}_experience_poses": alt.experience_poses,
            f"{name}_experience_first_tick": alt.experience_first_tick,
            f"{name}_links": alt.links,
        }
    with atomic_open(run_dir / "maps.npz", "wb") as f:
        np.savez_compressed(f, **maps)
