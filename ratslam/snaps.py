"""Snaps: the pose-cell activity peak jumping further than ``snap_cells`` in one tick.

Defined once here, in two forms that do the same operations in the same order (tested bit for
bit): :class:`ratslam.RatSLAM` reports ``snapped`` each tick with :func:`snapped` (one pair of
peaks, scalar arithmetic) and ``harness.report.metrics.snap_mask`` counts snaps over a stored peak
path with :func:`is_snap` (arrays).
"""

from __future__ import annotations

import math

import numpy as np


def peak_jump(old_peak, new_peak, grid_shape) -> np.ndarray:
    """Distance (cells) between peaks ``(..., D)``: Euclidean over the D axes, each difference
    taken the short way round the torus of ``grid_shape`` (D,) cells."""
    n = np.asarray(grid_shape, dtype=float)
    d = np.mod(np.abs(np.asarray(new_peak, dtype=float) - np.asarray(old_peak, dtype=float)), n)
    d = np.minimum(d, n - d)
    return np.sqrt((d * d).sum(axis=-1))


def is_snap(old_peak, new_peak, grid_shape, snap_cells: float) -> np.ndarray:
    """Whether the peak moved more than ``snap_cells`` cells (:func:`peak_jump`), per row."""
    return peak_jump(old_peak, new_peak, grid_shape) > snap_cells


def snapped(old_peak, new_peak, grid_shape, snap_cells: float) -> bool:
    """:func:`is_snap` for one pair of peaks, in scalar arithmetic (the same operations in the
    same order: the step's check, one pair per tick)."""
    s = 0.0
    for o, p, n in zip(old_peak, new_peak, grid_shape):
        d = abs(float(p) - float(o)) % n
        d = min(d, n - d)
        s += d * d
    return math.sqrt(s) > snap_cells
