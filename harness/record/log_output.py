"""Observation logs written to a file: the output check, and a world simulated into a CSV and PNG.

What ``ratslam-harness simulate`` (and the ``import`` commands' output check) do, as functions
of the library so that the command line stays a thin layer over it.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass
from pathlib import Path

from worlds import ObservationLog, load_world, simulate
from worlds.camera import Camera
from worlds.files import atomic_path
from worlds.world import MAX_TICKS

from ..run.budget import check_ticks
from ..run.directory import OutputError, output_errors
from ..run.progress import Progress


def check_writable(path, inputs=()) -> Path:
    """``path`` as a file to write: its directory created if missing; a one-line
    :class:`~harness.run.directory.OutputError` if it cannot be, or if it is one of ``inputs`` (the
    files the command reads: an output never replaces its own input)."""
    path = Path(path)
    for f in inputs:
        if f is not None and _same_file(path, Path(f)):
            raise OutputError(f"{path}: is the input {f}; the command would replace it (choose another --out)")
    parent = path.parent if str(path.parent) else Path(".")
    for p in (parent, *parent.parents):
        if p.exists() or p.is_symlink():
            if not p.is_dir():
                raise OutputError(f"{path}: output directory {p} is not a directory")
            break
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"{path}: cannot create output directory ({e.strerror})") from None
    if path.is_dir():
        raise OutputError(f"{path}: is a directory, expected a file name")
    return path


def _same_file(a: Path, b: Path) -> bool:
    if a.exists() and b.exists():
        return os.path.samefile(a, b)
    return os.path.realpath(a) == os.path.realpath(b)


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
    yes: bool = False,
) -> SimulatedLog:
    """Simulate ``world`` (a shipped world's name or a world file) and write its observation log
    to ``out`` (CSV) and a plot of the true route with the false positives to ``png`` (default:
    next to the log). ``None`` arguments take the world's defaults. ``camera`` ("forward" or
    "panoramic"): a camera log instead, each tick's image rendered from the true pose and written
    as a PNG into ``<out stem>_images/`` next to the log, named in the log's ``image`` column in
    place of the scene numbers (:mod:`harness.camera.stream`).
    Neither may be the world file or the other; a stream beyond the size budget
    (:mod:`harness.run.budget`) needs ``yes``. Both are written under temporary names and moved into
    place together, so a failure leaves neither."""
    world = load_world(world)
    inputs = (world.path,) if getattr(world, "path", None) else ()
    out = check_writable(out, inputs)
    png = check_writable(png, inputs) if png else out.with_suffix(".png")  # both checked first
    if png.suffix.lower() != ".png":
        raise OutputError(f"{png}: the route's plot is a PNG; name it .png")
    if _same_file(png, out):
        raise OutputError(f"{png}: is also the log's name ({out}); give the PNG another name with --png")
    for f in inputs:
        if _same_file(png, Path(f)):
            raise OutputError(f"{png}: is the input {f}; the command would replace it (choose another --png)")
    duration = world.duration if duration is None else duration
    if math.isfinite(duration) and 0 < duration * world.tick_rate <= MAX_TICKS:  # beyond: the simulator says why
        check_ticks(f"--duration {duration:g}", duration * world.tick_rate, yes)
    progress = Progress(
        int(round(min(duration * world.tick_rate, MAX_TICKS + 1))),  # beyond: simulate() refuses it
        f"simulate {world.name}",
        world.dt,
        enabled=show_progress,
    )
    log = simulate(world, duration=duration, seed=seed, bias_deg_s=bias_deg_s, fp_rate=fp_rate, progress=progress)
    if camera is not None:
        from ..camera.stream import simulated_camera, write_images

        frames = Camera(world, camera, seed=seed).render_poses(log.ground_truth(), log.t)
        log = dataclasses.replace(log, image=write_images(frames, out, simulated_camera(world, camera)))
    from worlds.plot import plot_run  # matplotlib: loaded where it draws, not by every command

    gt = log.ground_truth()
    with output_errors(out), atomic_path(out) as csv_tmp, atomic_path(png) as png_tmp:
        log.write_csv(csv_tmp)
        plot_run(
            world,
            gt[:, :2],
            png_tmp,
            title=f"{world.name}: {len(log)} ticks, seed {seed}",
            false_positive_xy=gt[log.false_positive, :2],
        )
    return SimulatedLog(log, out, png)
