"""PNG of a world: walls, obstacles, route network and a simulated path."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.patches import Rectangle

from .files import atomic_path
from .world import World


def draw_world(ax, world: World, route: bool = True):
    """Walls (black), obstacles (grey) and optionally the route network (dashed) onto ``ax``."""
    for x0, y0, x1, y1 in world.obstacles:
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, color="0.75", zorder=1))
    ax.add_collection(LineCollection(list(world.walls), colors="k", linewidths=1.5, zorder=3))
    if route:
        ax.add_collection(
            LineCollection(
                list(world.edge_segments()), colors="tab:blue", linewidths=0.8, linestyles="--", alpha=0.6, zorder=2
            )
        )
        xy = np.array(list(world.nodes.values()))
        ax.plot(xy[:, 0], xy[:, 1], "o", color="tab:blue", ms=3, zorder=2)
    ax.set_xlim(-0.5, world.size[0] + 0.5)
    ax.set_ylim(-0.5, world.size[1] + 0.5)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def save_figure(fig, path) -> Path:
    """Save a matplotlib figure atomically (see :mod:`worlds.files`) and close it."""
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110, bbox_inches="tight")
    finally:
        plt.close(fig)
    return Path(path)


def plot_run(
    world: World, gt_xy: np.ndarray | None, path, title: str | None = None, false_positive_xy: np.ndarray | None = None
) -> Path:
    """Write a PNG of ``world`` with the ground-truth path ``gt_xy`` (N, 2) drawn over it."""
    w, h = world.size
    fig, ax = plt.subplots(figsize=(min(14.0, 2.0 + w * 0.35), min(9.0, 1.5 + h * 0.35 + 0.8)))
    draw_world(ax, world)
    if gt_xy is not None and len(gt_xy):
        ax.plot(gt_xy[:, 0], gt_xy[:, 1], color="tab:red", lw=0.6, alpha=0.7, label="simulated path")
        ax.plot(*gt_xy[0], "g^", ms=8, label="start")
    if false_positive_xy is not None and len(false_positive_xy):
        ax.plot(
            false_positive_xy[:, 0], false_positive_xy[:, 1], "x", color="magenta", ms=4, label="false-positive scene"
        )
    ax.set_title(title or world.name)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.8)
    return save_figure(fig, path)
