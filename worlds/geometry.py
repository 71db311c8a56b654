"""Vectorised 2D geometry on wall segments: distances and crossings.

Segments are arrays of shape (N, 2, 2): ``seg[i] = [[x0, y0], [x1, y1]]``.
"""

from __future__ import annotations

import numpy as np


def rectangle_outline(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """The four sides of an axis-aligned rectangle as segments, shape (4, 2, 2)."""
    c = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    return np.array([[c[i], c[(i + 1) % 4]] for i in range(4)], dtype=float)


def polyline_segments(points) -> np.ndarray:
    """Consecutive vertex pairs of a polyline as segments, shape (len-1, 2, 2)."""
    p = np.asarray(points, dtype=float)
    return np.stack([p[:-1], p[1:]], axis=1)


def point_segment_distance(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distance from each point (P, 2) to each segment (S, 2, 2); returns (P, S)."""
    p = np.asarray(points, dtype=float)[:, None, :]
    a = segments[None, :, 0, :]
    ab = segments[None, :, 1, :] - a
    denom = np.maximum(np.einsum("psk,psk->ps", ab, ab), 1e-300)
    u = np.clip(np.einsum("psk,psk->ps", p - a, ab) / denom, 0.0, 1.0)
    closest = a + u[..., None] * ab
    return np.linalg.norm(p - closest, axis=-1)


def segments_cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether each segment of ``a`` (A, 2, 2) properly or touchingly intersects each of ``b`` (B, 2, 2).

    Returns a boolean (A, B) matrix. Collinear overlaps count as crossings.
    """

    def orient(p, q, r):
        return np.sign(
            (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0])
        )

    def on_segment(p, q, r):  # r collinear with p-q: does it lie within the bounding box?
        return (
            (np.minimum(p[..., 0], q[..., 0]) <= r[..., 0] + 1e-12)
            & (r[..., 0] <= np.maximum(p[..., 0], q[..., 0]) + 1e-12)
            & (np.minimum(p[..., 1], q[..., 1]) <= r[..., 1] + 1e-12)
            & (r[..., 1] <= np.maximum(p[..., 1], q[..., 1]) + 1e-12)
        )

    p1, q1 = a[:, None, 0], a[:, None, 1]
    p2, q2 = b[None, :, 0], b[None, :, 1]
    o1, o2 = orient(p1, q1, p2), orient(p1, q1, q2)
    o3, o4 = orient(p2, q2, p1), orient(p2, q2, q1)
    proper = (o1 != o2) & (o3 != o4) & (o1 != 0) & (o2 != 0) & (o3 != 0) & (o4 != 0)
    touching = (
        ((o1 == 0) & on_segment(p1, q1, p2))
        | ((o2 == 0) & on_segment(p1, q1, q2))
        | ((o3 == 0) & on_segment(p2, q2, p1))
        | ((o4 == 0) & on_segment(p2, q2, q1))
    )
    return proper | touching


def wrap_angle(a):
    """Wrap angles to [-pi, pi)."""
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi
