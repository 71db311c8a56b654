"""Offset transitions (``experience_map.offset_transitions``, on by default; not in the paper).

The paper switches to an experience anywhere within its zone of influence (eqs 2-9) and links
it, and places the robot, as if the robot stood on the experience itself. With offset
transitions the new link is measured to the experience's own place (the odometry composed with
the inverse of the peak's offset from the experience's cells) and the current pose starts at
that offset, so a consistent map neither gains an error nor makes the pose jump at a re-entry.

The map asks :class:`EntryOffset` where the robot stands in a re-entered experience's frame;
the paper's answer (the switch off) is on the experience: ``(0, 0, 0)``.
"""

from __future__ import annotations

import math

import numpy as np

from .config import RatSLAMConfig

ON_THE_EXPERIENCE = (0.0, 0.0, 0.0)


def peak_offset(cell: np.ndarray, peak_cell: np.ndarray, config: RatSLAMConfig) -> tuple[float, float, float]:
    """Where the pose-cell peak is relative to an experience's cells ``cell``, in the
    experience's frame: (forward m, left m, heading rad), from the wrap-aware cell difference."""
    cfg = config.pose_cells
    grid = np.array(config.shape, dtype=float)
    d = np.asarray(peak_cell, dtype=float) - cell
    d -= grid * np.round(d / grid)  # wrap-aware
    dx, dy = d[0] * cfg.cell_size_m, d[1] * cfg.cell_size_m
    c, s = math.cos(cell[2] * cfg.theta_cell_rad), math.sin(cell[2] * cfg.theta_cell_rad)
    return (c * dx + s * dy, -s * dx + c * dy, float(d[2]) * cfg.theta_cell_rad)


class EntryOffset:
    """Where the robot stands in the frame of an experience it re-enters: the peak's offset from
    the experience's cells (``offset_transitions``), or on the experience (the paper)."""

    def __init__(self, config: RatSLAMConfig):
        self.config = config
        self.enabled = config.experience_map.offset_transitions

    def __call__(self, cell: np.ndarray, peak_cell: np.ndarray) -> tuple[float, float, float]:
        """The robot's offset (forward m, left m, heading rad) in the frame of the experience whose
        pose-cell coordinates are ``cell``, the pose-cell peak being at ``peak_cell``."""
        return peak_offset(cell, peak_cell, self.config) if self.enabled else ON_THE_EXPERIENCE
