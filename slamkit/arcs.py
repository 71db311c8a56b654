"""Exact circular-arc integration of wheel-odometry ticks (shared by the yaw-bias search and the
pose graph's odometry factors).

Each tick k reports a forward speed v_k (m/s) and a yaw rate w_k (rad/s) held for dt_k seconds.
The tick moves the robot by the SE(2) exponential of the twist (v_k dt_k, 0, (w_k - b) dt_k): an
exact circular arc, b a yaw-rate bias (0 unless one is known).
"""

from __future__ import annotations

import math

import numpy as np

SMALL_TURN = 1e-6
"""Below this turn (rad) per tick, the arc's sin/cos terms use their series."""


def check_tick(dt: float, v_trans: float, v_rot: float) -> None:
    """A ValueError for a tick no odometry can be integrated from: a non-finite value or a
    negative dt (both systems' ``step`` call it)."""
    if not (math.isfinite(dt) and math.isfinite(v_trans) and math.isfinite(v_rot)):
        raise ValueError(f"step: non-finite input dt={dt}, v_trans={v_trans}, v_rot={v_rot}")
    if dt < 0.0:
        raise ValueError(f"step: dt must be non-negative, got {dt}")


def tick_increments(dt: np.ndarray, v: np.ndarray, w: np.ndarray, bias: float = 0.0):
    """Per-tick motion (dx, dy, dtheta), each in the frame at the start of its tick."""
    a = v * dt
    phi = (w - bias) * dt
    small = np.abs(phi) < SMALL_TURN
    if not small.any():  # every tick turns: the closed forms alone (the same values, half the calls)
        return a * (np.sin(phi) / phi), a * ((1.0 - np.cos(phi)) / phi), phi
    safe = np.where(small, 1.0, phi)
    sin_term = np.where(small, 1.0 - phi * phi / 6.0, np.sin(safe) / safe)
    cos_term = np.where(small, phi / 2.0 - phi**3 / 24.0, (1.0 - np.cos(safe)) / safe)
    return a * sin_term, a * cos_term, phi


def cumulative_poses(dt: np.ndarray, v: np.ndarray, w: np.ndarray, bias: float = 0.0) -> np.ndarray:
    """Poses (n, 3) after each tick, relative to the pose before the first tick."""
    dx, dy, phi = tick_increments(dt, v, w, bias)
    theta = np.cumsum(phi)
    before = theta - phi
    c, s = np.cos(before), np.sin(before)
    x = np.cumsum(c * dx - s * dy)
    y = np.cumsum(s * dx + c * dy)
    return np.stack([x, y, theta], axis=1)


def integrate(dt: np.ndarray, v: np.ndarray, w: np.ndarray, bias: float = 0.0) -> np.ndarray:
    """Relative pose (x, y, theta) after all ticks (theta not wrapped)."""
    if len(dt) == 0:
        return np.zeros(3)
    return cumulative_poses(dt, v, w, bias)[-1]
