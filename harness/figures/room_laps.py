"""Fig 11's own metric: where two laps of one room sit in the pose cells and in the experience map."""

from __future__ import annotations

from typing import Any

import numpy as np

from ratslam import RatSLAMConfig
from worlds import ObservationLog

from ..report.metrics import wrap_cells
from ..run.runner import StreamResult

ROOM_GH = (22.0, 7.5, 30.0, 13.0)  # full_floor's twice-lapped room (Fig 11, loops G and H): x0, y0, x1, y1


def room_laps(
    res: StreamResult,
    log: ObservationLog,
    room: tuple[float, float, float, float],
    cell_size: float,
    grid_shape: tuple[int, ...],
) -> dict[str, Any]:
    """Where the first two laps of a room sit in the pose cells and in the experience map.

    Returns the distances between the two laps' centres, in the pose cells (wrap-aware, metres)
    and in the experience map (online pose); NaN distances when the run has fewer than two laps.
    """
    gt = log.ground_truth()
    x0, y0, x1, y1 = room
    inside = (gt[:, 0] > x0) & (gt[:, 0] < x1) & (gt[:, 1] > y0) & (gt[:, 1] < y1)
    edges = np.diff(np.concatenate([[0], inside.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    visits = [(a, b) for a, b in zip(starts, ends) if b - a > 20][:2]
    if len(visits) < 2:
        return {
            "laps_found": len(visits),
            "pose_cell_separation_m": float("nan"),
            "experience_map_separation_m": float("nan"),
        }
    n = np.array(grid_shape[:2], dtype=float)

    def circular_centre(cells):
        ang = cells[:, :2] / n * 2 * np.pi
        return np.arctan2(np.sin(ang).mean(0), np.cos(ang).mean(0)) / (2 * np.pi) * n

    (a0, a1), (b0, b1) = visits
    dc = wrap_cells(circular_centre(res.peak_cells[a0:a1]) - circular_centre(res.peak_cells[b0:b1]), n)
    de = res.ratslam_pose[a0:a1, :2].mean(0) - res.ratslam_pose[b0:b1, :2].mean(0)
    return {
        "laps_found": 2,
        "lap_ticks": [[int(a0), int(a1)], [int(b0), int(b1)]],
        "pose_cell_separation_m": float(np.hypot(*dc) * cell_size),
        "experience_map_separation_m": float(np.hypot(*de)),
    }


def room_gh_metrics(res: StreamResult, log: ObservationLog, config: RatSLAMConfig) -> dict[str, Any]:
    """Fig 11's extra metrics (:attr:`harness.figures.registry.Figure.extra_metrics`): the laps of room G/H."""
    return {"rooms": room_laps(res, log, ROOM_GH, config.pose_cells.cell_size_m, tuple(config.shape))}
