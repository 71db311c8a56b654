"""RatSLAM and the GTSAM baseline (and other RatSLAM configurations) on one observation stream.

Built on the one stream loop (:func:`harness.run.stream.step_stream`): every system gets exactly
the same inputs (``dt, v_trans, v_rot, scene_id``) and never any ground truth; this module
collects what a figure's or a replay's metrics, plots and recording need.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from baselines import PoseGraphConfig, PoseGraphSLAM
from ratslam import RatSLAM, RatSLAMConfig
from worlds import ObservationLog

from .stream import TickError, Trace, step_stream

__all__ = ["PoseGraphMap", "StreamResult", "TickError", "dead_reckon", "run_stream"]


def dead_reckon(log: ObservationLog, start=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Integrate the logged odometry: poses (N, 3) after each tick, each tick's forward motion
    taken along its midpoint heading -- the inverse of how the simulator derives odometry from
    its poses (``worlds.simulator.odometry_from_poses``). The systems integrate the same ticks
    differently: RatSLAM's experience map moves along each tick's end heading
    (``ExperienceMap.integrate``: each step turned by a further half of the tick's turn φ), the
    pose graph along the exact arc (``baselines.odometry``: the midpoint chord, shorter by the
    factor sin(φ/2)/(φ/2))."""
    dtheta = log.v_rot * log.dt
    theta_end = start[2] + np.cumsum(dtheta)
    mid = theta_end - dtheta / 2
    step = log.v_trans * log.dt
    x = start[0] + np.cumsum(step * np.cos(mid))
    y = start[1] + np.cumsum(step * np.sin(mid))
    return np.column_stack([x, y, theta_end])


@dataclass(frozen=True)
class PoseGraphMap:
    """The pose graph's final map as the metrics, trajectories and panels read it (the attributes of
    :class:`baselines.PoseGraphSLAM` they use), detached from gtsam's objects: what a worker process
    hands back after stepping a pose graph (iSAM2 does not pickle)."""

    keyframe_poses: np.ndarray
    keyframe_ticks: np.ndarray
    loop_closures: np.ndarray
    closure_accepted: np.ndarray
    isam2_recoveries: int
    closures_dropped: int

    @classmethod
    def of(cls, pg: PoseGraphSLAM | PoseGraphMap) -> PoseGraphMap:
        """The final map of a pose graph that has taken its last tick."""
        if isinstance(pg, PoseGraphMap):
            return pg
        return cls(
            keyframe_poses=pg.keyframe_poses,
            keyframe_ticks=pg.keyframe_ticks,
            loop_closures=pg.loop_closures,
            closure_accepted=np.asarray(pg.closure_accepted, dtype=bool),
            isam2_recoveries=int(pg.isam2_recoveries),
            closures_dropped=int(pg.closures_dropped),
        )


@dataclass
class StreamResult:
    """Per-tick estimates and final maps of both systems on one stream; ``alternatives``: other
    RatSLAM configurations stepped on the same stream (e.g. the published preset), by name."""

    t: np.ndarray
    odometry: np.ndarray  # (N, 3) dead reckoning
    ratslam_pose: np.ndarray  # (N, 3) online experience-map pose
    peak_cells: np.ndarray  # (N, 3) pose-cell peak, cell coordinates
    peak_metres: np.ndarray  # (N, 3) pose-cell peak, metres/radians (wrapped)
    snapped: np.ndarray  # (N,) bool
    gtsam_pose: np.ndarray  # (N, 3) online pose-graph estimate
    ratslam: RatSLAM
    gtsam: PoseGraphSLAM | PoseGraphMap
    wall: dict = field(default_factory=dict)  # seconds per system
    alternatives: dict[str, Trace] = field(default_factory=dict)
    ratslam_final: np.ndarray | None = None  # (N, 3) each tick as RatSLAM's final map places it
    gtsam_final: np.ndarray | None = None  # (N, 3) each tick as the final pose graph places it

    @classmethod
    def from_traces(
        cls,
        log: ObservationLog,
        odometry: np.ndarray,
        ratslam: Trace,
        gtsam: Trace,
        alternatives: dict[str, Trace],
        other_s: float,
    ) -> StreamResult:
        """The result of a stream from its systems' traces (RatSLAM's, the pose graph's and the
        alternative RatSLAMs' by name), its dead reckoning and the seconds spent outside the systems."""
        assert ratslam.peak_cells is not None and ratslam.peak_metres is not None and ratslam.snapped is not None
        return cls(
            t=log.t,
            odometry=odometry,
            ratslam_pose=ratslam.pose,
            peak_cells=ratslam.peak_cells,
            peak_metres=ratslam.peak_metres,
            snapped=ratslam.snapped,
            gtsam_pose=gtsam.pose,
            ratslam=ratslam.system,
            gtsam=gtsam.system,
            wall={"ratslam_s": ratslam.wall_s, "gtsam_s": gtsam.wall_s, "recording_and_bookkeeping_s": other_s},
            alternatives=alternatives,
            ratslam_final=ratslam.final_pose(ratslam.system.experience_poses),
            gtsam_final=gtsam.final_pose(gtsam.system.keyframe_poses),
        )

    def with_ratslam(self, name: str) -> StreamResult:
        """The same stream's result with the alternative RatSLAM ``name`` in RatSLAM's place (the
        pose graph's and the odometry's unchanged), so that every metric of RatSLAM is measured
        the same way for each configuration."""
        trace = self.alternatives[name]
        assert trace.peak_cells is not None and trace.peak_metres is not None and trace.snapped is not None
        return dataclasses.replace(
            self,
            ratslam_pose=trace.pose,
            peak_cells=trace.peak_cells,
            peak_metres=trace.peak_metres,
            snapped=trace.snapped,
            ratslam=trace.system,
            wall={**self.wall, "ratslam_s": trace.wall_s},
            alternatives={},
            ratslam_final=trace.final_pose(trace.system.experience_poses),
        )


RATSLAM, GTSAM = "ratslam", "gtsam"


def run_stream(
    log: ObservationLog,
    ratslam_config: RatSLAMConfig | None = None,
    gtsam_config: PoseGraphConfig | None = None,
    on_tick=None,
    progress=None,
    odometry: np.ndarray | None = None,
    alternatives: dict[str, RatSLAMConfig] | None = None,
) -> StreamResult:
    """Run RatSLAM, the pose graph and any ``alternatives`` (name -> another RatSLAM
    configuration) over ``log`` in one pass of :func:`harness.run.stream.step_stream`;
    ``on_tick(k, ratslam, gtsam)`` (e.g. the recorder) sees every tick. ``odometry`` is
    :func:`dead_reckon` of ``log`` when the caller already has it (the recorder draws it too);
    otherwise it is computed here."""
    systems: dict[str, Any] = {
        RATSLAM: RatSLAM(ratslam_config or RatSLAMConfig()),
        GTSAM: PoseGraphSLAM(gtsam_config or PoseGraphConfig()),
    }
    for name, config in (alternatives or {}).items():
        if name in systems:
            raise ValueError(f"alternative RatSLAM named {name!r}: the name is taken")
        systems[name] = RatSLAM(config)
    if odometry is None:
        odometry = dead_reckon(log)
    tick_hook = None if on_tick is None else (lambda k, s: on_tick(k, s[RATSLAM], s[GTSAM]))
    traces, other_s = step_stream(log, systems, on_tick=tick_hook, progress=progress)
    return StreamResult.from_traces(log, odometry, traces.pop(RATSLAM), traces.pop(GTSAM), traces, other_s)
