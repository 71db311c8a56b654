"""Helpers shared by the test modules: the simulator's tick, the default pose-cell grid,
wrap-aware differences, a settled packet, and the CLI run as a user runs it."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from ratslam import RatSLAMConfig
from ratslam.pose_cells import PoseCells

DT = 1.0 / 7.0  # s: the paper's (and the simulator's) 7 Hz tick
CFG = RatSLAMConfig()
GRID = np.array(CFG.shape, dtype=float)  # pose-cell grid (x', y', θ') of the defaults


def wrapped_diff(a, b, n=GRID) -> np.ndarray:
    """Signed wrap-aware difference a - b on rings of sizes n (cells)."""
    d = (np.asarray(a, float) - np.asarray(b, float)) % n
    return np.where(d > np.asarray(n) / 2, d - n, d)


def settled(cfg: RatSLAMConfig = CFG, cell=None, ticks: int = 30) -> PoseCells:
    """Pose cells started at ``cell`` (default: the grid's centre) and left to settle, no motion."""
    pc = PoseCells(cfg, start_cell=cell)
    for _ in range(ticks):
        pc.step(0.0, 0.0)
    return pc


def cli(*args: str, cwd=None) -> subprocess.CompletedProcess:
    """``ratslam-harness ARGS`` in a fresh interpreter (exit code, stdout and stderr as text)."""
    return subprocess.run([sys.executable, "-m", "harness.cli", *args], capture_output=True, text=True, cwd=cwd)
