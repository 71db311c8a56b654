"""Poses in the plane (x, y, θ): wrapping angles, composing and relating poses, range and bearing.

Shared by RatSLAM's experience map and its layers, the pose graph and both navigators.
"""

from __future__ import annotations

import math

import numpy as np

_PI = math.pi


def wrap_angle(a):
    """Wrap radians into [-π, π]."""
    a = np.asarray(a)
    return a - (2.0 * _PI) * np.round(a * (1.0 / (2.0 * _PI)))


def wrap_scalar(a: float) -> float:
    """Wrap one angle (radians) into [-π, π)."""
    return (a + _PI) % (2.0 * _PI) - _PI


def triple(v) -> tuple[float, float, float]:
    """The first three entries of ``v`` as Python floats."""
    return (float(v[0]), float(v[1]), float(v[2]))


def compose(a, b) -> tuple[float, float, float]:
    """Pose ``b`` (in ``a``'s frame) in the frame ``a`` is in."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def between(a, b) -> tuple[float, float, float]:
    """Pose ``b`` in ``a``'s frame (both in one frame)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, b[2] - a[2])


def range_bearing(pose, xy) -> tuple[float, float]:
    """Range (m) and bearing (rad, relative to the heading, in [-π, π)) of point ``xy`` from
    ``pose`` = (x, y, θ): what a controller follows."""
    dx, dy = xy[0] - pose[0], xy[1] - pose[1]
    return math.hypot(dx, dy), wrap_scalar(math.atan2(dy, dx) - pose[2])


def place(nodes: np.ndarray, node: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Poses (N, 3) of ticks that hang from map nodes: node ``node[k]``'s pose in ``nodes``
    (K, 3) composed with ``offset[k]`` (N, 3); a tick with ``node[k] < 0`` (before the first
    node) is its offset from the origin."""
    base = np.zeros((len(node), 3))
    placed = node >= 0
    base[placed] = np.asarray(nodes, dtype=float).reshape(-1, 3)[node[placed]]
    c, s = np.cos(base[:, 2]), np.sin(base[:, 2])
    x = base[:, 0] + c * offset[:, 0] - s * offset[:, 1]
    y = base[:, 1] + s * offset[:, 0] + c * offset[:, 1]
    return np.column_stack([x, y, wrap_angle(base[:, 2] + offset[:, 2])])


def fit_se2(src: np.ndarray, dst: np.ndarray) -> tuple[float, float, float]:
    """The rotation and translation (no scale), as a pose (x, y, θ), that best map points
    ``src`` (N, 2) onto ``dst`` (least squares, Umeyama / Kabsch in 2D); identity below two
    points."""
    if len(src) < 2:
        return (0.0, 0.0, 0.0)
    ms, md = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - ms, dst - md
    angle = math.atan2(float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])), float(np.sum(a * b)))
    c, s = math.cos(angle), math.sin(angle)
    t = md - np.array([c * ms[0] - s * ms[1], s * ms[0] + c * ms[1]])
    return (float(t[0]), float(t[1]), angle)
