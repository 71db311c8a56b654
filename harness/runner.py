"""Drive RatSLAM and the GTSAM baseline on the same observation stream, tick by tick.

The runner hands both systems exactly the same inputs (``dt, v_trans, v_rot, scene_id``) and
never any ground truth; it collects what the metrics, plots and recording need.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from baselines import PoseGraphConfig, PoseGraphSLAM
from ratslam import RatSLAM, RatSLAMConfig
from worlds import ObservationLog
from worlds.errors import InputError


class TickError(InputError):
    """A tick of the log that a SLAM system refuses (one line: the tick and the problem)."""

    def __init__(self, tick: int, problem: str):
        super().__init__(f"tick {tick} (line {tick + 2} of the log): {problem}")
        self.tick, self.problem = tick, problem

    def __reduce__(self):  # pickled back from a worker process with its own arguments
        return (type(self), (self.tick, self.problem))


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


@dataclass
class StreamResult:
    """Per-tick estimates and final maps of both systems on one stream."""

    t: np.ndarray
    odometry: np.ndarray  # (N, 3) dead reckoning
    ratslam_pose: np.ndarray  # (N, 3) online experience-map pose
    peak_cells: np.ndarray  # (N, 3) pose-cell peak, cell coordinates
    peak_metres: np.ndarray  # (N, 3) pose-cell peak, metres/radians (wrapped)
    snapped: np.ndarray  # (N,) bool
    gtsam_pose: np.ndarray  # (N, 3) online pose-graph estimate
    ratslam: RatSLAM
    gtsam: PoseGraphSLAM
    wall: dict = field(default_factory=dict)  # seconds per system


def run_stream(
    log: ObservationLog,
    ratslam_config: RatSLAMConfig | None = None,
    gtsam_config: PoseGraphConfig | None = None,
    on_tick=None,
    progress=None,
    odometry: np.ndarray | None = None,
) -> StreamResult:
    """Run both systems over ``log``; ``on_tick(k, ratslam, gtsam)`` (e.g. the recorder) sees every
    tick. ``odometry`` is :func:`dead_reckon` of ``log`` when the caller already has it (the
    recorder draws it too); otherwise it is computed here."""
    rs = RatSLAM(ratslam_config or RatSLAMConfig())
    pg = PoseGraphSLAM(gtsam_config or PoseGraphConfig())
    n = len(log)
    if odometry is None:
        odometry = dead_reckon(log)
    out = {k: np.zeros((n, 3)) for k in ("ratslam_pose", "peak_cells", "peak_metres", "gtsam_pose")}
    snapped = np.zeros(n, dtype=bool)
    rows = zip(log.dt.tolist(), log.v_trans.tolist(), log.v_rot.tolist(), log.scene_id.tolist())
    t_rs = t_pg = t_rec = 0.0
    clock = time.perf_counter
    report_every = max(1, n // 200)
    for k, (dt, v, w, scene) in enumerate(rows):
        t0 = clock()
        try:
            rs.step(dt, v, w, scene)
            t1 = clock()
            pg.step(dt, v, w, scene)
        except ValueError as e:
            raise TickError(k, str(e)) from None
        t2 = clock()
        out["ratslam_pose"][k] = rs.pose
        out["peak_cells"][k] = rs.peak
        out["peak_metres"][k] = rs.peak_metres
        snapped[k] = rs.snapped
        out["gtsam_pose"][k] = pg.pose
        if on_tick is not None:
            on_tick(k, rs, pg)
        t3 = clock()
        t_rs, t_pg, t_rec = t_rs + (t1 - t0), t_pg + (t2 - t1), t_rec + (t3 - t2)
        if progress is not None and (k + 1) % report_every == 0:
            progress(k + 1, n)
    t0 = clock()
    pg.finalize()
    t_pg += clock() - t0
    return StreamResult(
        t=log.t,
        odometry=odometry,
        snapped=snapped,
        ratslam=rs,
        gtsam=pg,
        wall={"ratslam_s": t_rs, "gtsam_s": t_pg, "recording_and_bookkeeping_s": t_rec},
        **out,
    )
