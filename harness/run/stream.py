"""The one stream loop: any set of SLAM systems stepped through an observation log, tick by tick.

Every system gets exactly the same inputs, ``step(dt, v_trans, v_rot, scene_id)`` per tick (the
step contract; from a camera stream, each view's ``view_rotation`` too) and never any ground
truth, and has a ``pose`` (and, if it says what the pose hangs from, an ``anchor``: the node, an
experience or keyframe, and the offset from it). Figures, replays, sweeps and navigation's exploration all step their
systems through :func:`step_stream`; what each needs afterwards is in the returned
:class:`Trace` of each system: the online pose at every tick, the wall time spent in the system,
and, for a system with pose cells (RatSLAM), the peak and snaps at every tick.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ratslam import RatSLAM
from ratslam.front_end import shared_front_ends
from slamkit.poses import place
from worlds import ObservationLog
from worlds.errors import InputError


class TickError(InputError):
    """A tick of the log that a SLAM system refuses (one line: the tick and the problem)."""

    def __init__(self, tick: int, problem: str):
        super().__init__(f"tick {tick} (line {tick + 2} of the log): {problem}")
        self.tick, self.problem = tick, problem

    def __reduce__(self):  # pickled back from a worker process with its own arguments
        return (type(self), (self.tick, self.problem))


@dataclass
class Trace:
    """One system's run over a stream. ``pose`` (N, 3): its online estimate after each tick;
    ``wall_s``: seconds spent in its steps (and its ``finalize``; a RatSLAM whose front end another
    computed for it: its map's steps and that front end's, :func:`step_stream`); for a system with pose cells,
    ``peak_cells`` / ``peak_metres`` (N, 3) and ``snapped`` (N,) after each tick, else None."""

    system: Any
    pose: np.ndarray
    wall_s: float
    peak_cells: np.ndarray | None = None
    peak_metres: np.ndarray | None = None
    snapped: np.ndarray | None = None
    anchor_node: np.ndarray | None = None
    anchor_offset: np.ndarray | None = None

    def final_pose(self, node_poses: np.ndarray) -> np.ndarray | None:
        """Each tick's pose as the final map places it (None for a system without an ``anchor``):
        the final pose of the node the tick's pose hung from (``node_poses``: RatSLAM's experience
        poses, the pose graph's keyframe poses, after the last tick) composed with the offset the
        system had from it then; before the first node, the offset from the origin. A system whose
        nodes are renumbered during the run (the pose graph rebuilt after a yaw-rate bias is
        adopted) gives each tick's anchor in its final graph (``final_anchors``), used instead."""
        if self.anchor_node is None or self.anchor_offset is None:
            return None
        node, off = self.anchor_node, self.anchor_offset
        final = getattr(self.system, "final_anchors", None)  # a system that renumbers its nodes
        if final is not None and len(final[0]) == len(node):
            node, off = final
        return place(np.asarray(node_poses, dtype=float).reshape(-1, 3), node, off)


OnTick = Callable[[int, Mapping[str, Any]], None]
"""``on_tick(k, systems)``: called after every system has taken tick ``k`` (a recorder, a
navigation experiment's bookkeeping)."""


def _has_pose_cells(system: Any) -> bool:
    return hasattr(system, "peak_metres") and hasattr(system, "snapped")


def step_stream(
    log: ObservationLog,
    systems: Mapping[str, Any],
    *,
    on_tick: OnTick | None = None,
    progress: Callable[[int, int], None] | None = None,
    finalize: bool = True,
) -> tuple[dict[str, Trace], float]:
    """Step every system of ``systems`` (name -> system) through ``log``, in the mapping's order
    within each tick. ``on_tick`` sees every tick; ``progress(done, total)`` is called about 200
    times; ``finalize``: a system with a ``finalize`` method (the pose graph's last optimisation)
    has it called after the last tick. A tick a system refuses (a ``ValueError``) is a
    :class:`TickError` naming the tick. Returns each system's :class:`Trace` and the seconds spent
    outside the systems (``on_tick`` and bookkeeping).

    RatSLAMs that have not stepped yet and are configured alike in the yaw-rate search, view
    cells and pose cells share one front end while they step (:func:`ratslam.front_end.shared_front_ends`:
    computed once, the same values bit for bit). Each is timed as if it ran alone: the others
    are charged the front end's time of each tick besides their own maps' (so the systems' times
    add up to more than the pass took)."""
    n = len(log)
    names = list(systems)
    stepping = [systems[s] for s in names]
    poses = [np.zeros((n, 3)) for _ in names]
    cells = [
        (np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n, dtype=bool)) if _has_pose_cells(s) else None for s in stepping
    ]
    anchors = [(np.full(n, -1, dtype=np.int64), np.zeros((n, 3))) if hasattr(s, "anchor") else None for s in stepping]
    wall = [0.0] * len(names)
    other = 0.0
    clock = time.perf_counter
    report_every = max(1, n // 200)
    columns = [log.dt.tolist(), log.v_trans.tolist(), log.v_rot.tolist(), log.scene_id.tolist()]
    if log.view_rotation is not None:  # a camera stream: each view's rotation against its template
        columns.append(log.view_rotation.tolist())
    with shared_front_ends(s for s in stepping if isinstance(s, RatSLAM)) as followers:  # each computed once
        charged = [any(system is f for f in followers) for system in stepping]
        for k, row in enumerate(zip(*columns)):
            for i, system in enumerate(stepping):
                t0 = clock()
                try:
                    system.step(*row)
                except ValueError as e:
                    raise TickError(k, str(e)) from None
                wall[i] += clock() - t0
                if charged[i]:  # timed as if alone: the front end's time of the tick too
                    wall[i] += system.front_end.seconds
            t0 = clock()
            for i, system in enumerate(stepping):
                poses[i][k] = system.pose
                peak = cells[i]
                if peak is not None:
                    peak[0][k] = system.peak
                    peak[1][k] = system.peak_metres
                    peak[2][k] = system.snapped
                anchor = anchors[i]
                if anchor is not None:
                    anchor[0][k], anchor[1][k] = system.anchor
            if on_tick is not None:
                on_tick(k, systems)
            if progress is not None and (k + 1) % report_every == 0:
                progress(k + 1, n)
            other += clock() - t0
    if finalize:
        for i, system in enumerate(stepping):
            if hasattr(system, "finalize"):
                t0 = clock()
                system.finalize()
                wall[i] += clock() - t0
    traces = {}
    for i, name in enumerate(names):
        peak = cells[i]
        traces[name] = Trace(
            stepping[i],
            poses[i],
            wall[i],
            *(peak if peak is not None else (None, None, None)),
            *(anchors[i] or (None, None)),
        )
    return traces, other
