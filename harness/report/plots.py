"""PNG panels mirroring the paper's figures.

(a) the world with the ground-truth and odometry paths; (b) the pose-cell peak path in cell
coordinates on a 4 x 4-cell grid, wrap-arounds and snaps drawn as thin lines; (c) the
experience map (experiences and transitions); (d) the GTSAM estimate. Estimates are drawn after
SE(2) alignment to ground truth so that they can be read against the walls.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection

from worlds import World
from worlds.plot import draw_world, save_figure

from . import metrics


def aligned(est_xy: np.ndarray, ref_xy: np.ndarray, apply_to: np.ndarray | None = None) -> np.ndarray:
    """``apply_to`` (default ``est_xy``) moved by the SE(2) alignment of ``est_xy`` onto ``ref_xy``."""
    pts = est_xy if apply_to is None else apply_to
    if len(est_xy) < 2:
        return pts
    R, t, _ = metrics.align_se2(est_xy, ref_xy)
    return pts @ np.asarray(R).T + t


def _world_axes(world: World | None, title: str, frame_xy: np.ndarray):
    """Axes showing ``world`` (walls, obstacles) or, for a log without a world, framed on
    ``frame_xy`` (the ground-truth path) with a 5% margin."""
    if world is not None:
        w, h = world.size
        fig, ax = plt.subplots(figsize=(min(12.0, 2.0 + w * 0.3), min(8.0, 1.6 + h * 0.3)))
        draw_world(ax, world, route=False)
    else:
        frame_xy = frame_xy.reshape(-1, 2)
        lo, hi = (frame_xy.min(axis=0), frame_xy.max(axis=0)) if len(frame_xy) else (np.zeros(2), np.zeros(2))
        pad = 0.05 * max(float(np.max(hi - lo)), 1.0)
        w, h = (hi - lo) + 2 * pad
        scale = 8.0 / max(w, h)
        fig, ax = plt.subplots(figsize=(max(4.0, 1.5 + w * scale), max(3.0, 1.2 + h * scale)))
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    ax.set_title(title, fontsize=10)
    return fig, ax


def panel_world(world: World | None, gt: np.ndarray, odometry: np.ndarray, fp_xy: np.ndarray, path):
    """(a) World (if any), ground truth and (aligned) raw odometry."""
    fig, ax = _world_axes(
        world,
        "(a) world, ground truth and odometry" if world is not None else "(a) ground truth and odometry",
        gt[:, :2],
    )
    odo = aligned(odometry[:, :2], gt[:, :2])
    ax.plot(odo[:, 0], odo[:, 1], color="tab:orange", lw=0.6, alpha=0.8, label="odometry (aligned)")
    ax.plot(gt[:, 0], gt[:, 1], color="k", lw=0.6, alpha=0.6, label="ground truth")
    if len(fp_xy):
        ax.plot(fp_xy[:, 0], fp_xy[:, 1], "x", color="magenta", ms=4, label="false-positive scene")
    ax.legend(loc="upper right", fontsize=7)
    return save_figure(fig, path)


def panel_pose_cells(peak_cells: np.ndarray, snapped: np.ndarray, grid_shape, path, system: str = "RatSLAM"):
    """(b) Pose-cell peak path in (x', y') cells; jumps (snaps, wrap-arounds) as thin lines."""
    nx, ny = grid_shape[:2]
    fig, ax = plt.subplots(figsize=(6.0, 6.0 * ny / nx + 0.4))
    p = peak_cells[:, :2]
    seg = np.stack([p[:-1], p[1:]], axis=1)
    step = p[1:] - p[:-1]
    wrapped = (np.abs(step[:, 0]) > nx / 2) | (np.abs(step[:, 1]) > ny / 2)
    jump = snapped[1:] | wrapped
    # the path as one line broken at the jumps (one path to draw, not a path per tick)
    ax.plot(*np.insert(p.astype(float), np.flatnonzero(jump) + 1, np.nan, axis=0).T, color="tab:blue", lw=1.2)
    ax.add_collection(
        LineCollection(seg[jump & ~wrapped], colors="tab:red", linewidths=0.4, label=f"snaps ({int(snapped.sum())})")
    )
    ax.set_xlim(0, nx)
    ax.set_ylim(0, ny)
    ax.set_xticks(np.arange(0, nx + 1, 4))
    ax.set_yticks(np.arange(0, ny + 1, 4))
    ax.tick_params(labelsize=6)
    ax.grid(True, lw=0.3, color="0.8")
    ax.set_aspect("equal")
    ax.set_xlabel("x' (cells)")
    ax.set_ylabel("y' (cells)")
    ax.set_title(f"(b) {system}: pose-cell peak path (4 x 4-cell grid)", fontsize=10)
    ax.legend(loc="upper right", fontsize=7)
    return save_figure(fig, path)


def panel_experience_map(
    world: World | None,
    exp_xy: np.ndarray,
    exp_gt_xy: np.ndarray,
    links: np.ndarray,
    path,
    system: str = "RatSLAM",
    gt_xy: np.ndarray | None = None,
):
    """(c) Experience map: experiences (dots) and transitions (lines), aligned to ground truth,
    on a 1 m grid, with the ground-truth path ``gt_xy`` (if given) beneath it in grey."""
    xy = aligned(exp_xy, exp_gt_xy)
    fig, ax = _world_axes(world, f"(c) {system}: experience map (aligned, 1 m grid)", np.vstack([xy, exp_gt_xy]))
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    ax.set_xticks(np.arange(np.floor(x0), np.ceil(x1) + 1, 1.0), minor=True)
    ax.set_yticks(np.arange(np.floor(y0), np.ceil(y1) + 1, 1.0), minor=True)
    ax.grid(True, which="minor", lw=0.3, color="0.85")
    if gt_xy is not None:
        ax.plot(gt_xy[:, 0], gt_xy[:, 1], color="0.6", lw=0.5, alpha=0.6, label="ground truth")
    if len(links):
        ax.add_collection(LineCollection(xy[links], colors="tab:green", linewidths=0.5, alpha=0.7))
    ax.plot(xy[:, 0], xy[:, 1], ".", color="tab:green", ms=2.5, label=f"{len(xy)} experiences")
    ax.legend(loc="upper right", fontsize=7)
    return save_figure(fig, path)


def panel_gtsam(
    world: World | None, kf_xy: np.ndarray, kf_gt_xy: np.ndarray, closures: np.ndarray, accepted: np.ndarray, path
):
    """(d) GTSAM keyframes, accepted (green) and rejected (red) loop closures, aligned to ground truth."""
    xy = aligned(kf_xy, kf_gt_xy)
    fig, ax = _world_axes(world, "(d) GTSAM pose graph (aligned to ground truth)", np.vstack([xy, kf_gt_xy]))
    ax.plot(xy[:, 0], xy[:, 1], "-", color="tab:purple", lw=0.6, label=f"{len(xy)} keyframes")
    closures = np.asarray(closures, dtype=int)
    if len(closures):
        acc = np.asarray(accepted, dtype=bool)
        ax.add_collection(
            LineCollection(
                xy[closures[acc]], colors="tab:green", linewidths=0.4, label=f"accepted closures ({int(acc.sum())})"
            )
        )
        ax.add_collection(
            LineCollection(
                xy[closures[~acc]], colors="tab:red", linewidths=0.4, label=f"rejected closures ({int((~acc).sum())})"
            )
        )
    ax.legend(loc="upper right", fontsize=7)
    return save_figure(fig, path)
