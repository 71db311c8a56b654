"""Observation logs written to a file: the output check, and a world simulated into a CSV and PNG.

What ``ratslam-harness simulate`` (and the ``import`` commands' output check) do, as functions
of the library so that the command line stays a thin layer over it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from worlds import ObservationLog, load_world, simulate
from worlds.camera import Camera
from worlds.plot import plot_run

from .progress import Progress
from .run_dir import OutputError


def check_writable(path) -> Path:
    """``path`` as a file to write: its directory created if missing; a one-line
    :class:`~harness.run_dir.OutputError` if it cannot be."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if parent.exists() and not parent.is_dir():
        raise OutputError(f"{path}: output directory {parent} is not a directory")
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"{path}: cannot create output directory ({e.strerror})") from None
    if path.is_dir():
        raise OutputError(f"{path}: is a directory, expected a file name")
    return path


@dataclass(frozen=True)
class SimulatedLog:
    """A simulated run written out: its observation log, the CSV and the PNG of the route."""

    log: ObservationLog
    csv: Path
    png: Path


def simulate_to_files(
    world,
    out,
    png=None,
    duration: float | None = None,
    seed: int = 0,
    bias_deg_s: float | None = None,
    fp_rate: float | None = None,
    show_progress: bool = True,
    camera: str | None = None,
) -> SimulatedLog:
    """Simulate ``world`` (a shipped world's name or a world file) and write its observation log
    to ``out`` (CSV) and a plot of the true route with the false positives to ``png`` (default:
    next to the log). ``None`` arguments take the world's defaults. ``camera`` ("forward" or
    "panoramic"): a camera log instead, each tick's image rendered from the true pose and written
    as a PNG into ``<out stem>_images/`` next to the log, named in the log's ``image`` column in
    place of the scene numbers (:mod:`harness.camera_stream`)."""
    world = load_world(world)
    out = check_writable(out)
    png = check_writable(png) if png else out.with_suffix(".png")  # both checked before either is written
    duration = world.duration if duration is None else duration
    progress = Progress(
        int(round(duration * world.tick_rate)), f"simulate {world.name}", world.dt, enabled=show_progress
    )
    log = simulate(world, duration=duration, seed=seed, bias_deg_s=bias_deg_s, fp_rate=fp_rate, progress=progress)
    if camera is not None:
        from .camera_stream import write_images

        frames = Camera(world, camera, seed=seed).render_poses(log.ground_truth(), log.t)
        log = dataclasses.replace(log, image=write_images(frames, out))
    log.write_csv(out)
    gt = log.ground_truth()
    plot_run(
        world,
        gt[:, :2],
        png,
        title=f"{world.name}: {len(log)} ticks, seed {seed}",
        false_positive_xy=gt[log.false_positive, :2],
    )
    return SimulatedLog(log, out, png)
