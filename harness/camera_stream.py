"""Camera streams: a simulated run's images written as a camera log, and a camera log's images
turned into template numbers and rotations by the view matcher, for both systems.

A camera log (:mod:`worlds.observation_log`) names each tick's image file in its ``image``
column, relative to the log. :func:`write_images` writes a run's frames as PNGs into a folder next
to the log (all or nothing: a staging folder moved into place); :func:`match_camera_log` reads them
in order through :class:`ratslam.view_matcher.ViewMatcher` and returns the log with ``scene_id``
= the matched template and ``view_rotation`` = its rotation, which :func:`harness.runner.run_stream`
hands to ``step`` (the pose graph gets the same template numbers).
"""

from __future__ import annotations

import dataclasses
import os
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
from PIL import Image

from ratslam import ViewConfig
from ratslam.view_matcher import ViewMatcher
from worlds import ObservationLog, World
from worlds.camera import Camera, to_uint8
from worlds.observation_log import ObservationLogError

from .run_dir import OutputError

PANORAMIC_TEMPLATE_WIDTH = 64
"""Template columns for the panoramic camera (5.6 degrees each)."""


def camera_view_config(kind: str, view: ViewConfig | None = None) -> ViewConfig:
    """The matcher's settings for a camera: ``view`` (default: the defaults, made for the forward
    camera) as it is for the forward camera; for the panoramic one with a 360 degree field of view
    and :data:`PANORAMIC_TEMPLATE_WIDTH` columns."""
    view = view or ViewConfig()
    if kind == "panoramic":
        return dataclasses.replace(view, field_of_view_deg=360.0, template_width=PANORAMIC_TEMPLATE_WIDTH)
    return view


def camera_observations(world: World, log: ObservationLog, kind: str, seed: int, config: ViewConfig) -> ObservationLog:
    """A simulated log seen through the camera: each tick rendered at its true pose (``seed``: the
    sensor noise) and matched in order; scene numbers become template numbers with their rotations,
    and no tick is labelled a false positive (wrong matches are the camera's own)."""
    frames = Camera(world, kind, seed=seed).render_poses(log.ground_truth(), log.t)
    vm = ViewMatcher(config)
    matches = [vm.match(frame) for frame in frames]
    return dataclasses.replace(
        log,
        scene_id=np.array([m.template for m in matches], dtype=np.int64),
        view_rotation=np.array([m.rotation for m in matches]),
        false_positive=np.zeros(len(log), dtype=bool),
    )


def images_folder(log_path) -> Path:
    """Where a camera log's images go: ``<log stem>_images`` next to the log."""
    log_path = Path(log_path)
    return log_path.with_name(f"{log_path.stem}_images")


def write_images(images: np.ndarray, log_path) -> np.ndarray:
    """Write frames (N, rows, columns) in [0, 1] as 8-bit PNGs ``000001.png`` ... into
    :func:`images_folder` of ``log_path`` (replacing a previous one whole); returns each frame's
    path relative to the log's folder, for the log's ``image`` column."""
    log_path = Path(log_path)
    final = images_folder(log_path)
    stage = final.with_name(f".{final.name}.tmp-{os.getpid()}")
    try:
        if stage.exists():
            shutil.rmtree(stage)
        stage.mkdir(parents=True)
        names = []
        for k, frame in enumerate(images):
            name = f"{k + 1:06d}.png"
            Image.fromarray(to_uint8(frame), mode="L").save(stage / name, optimize=False)
            names.append(f"{final.name}/{name}")
        if final.exists():
            shutil.rmtree(final)
        stage.rename(final)
    except OSError as e:
        shutil.rmtree(stage, ignore_errors=True)
        raise OutputError(f"{final}: cannot write the camera images ({e.strerror or e})") from None
    return np.array(names, dtype=object)


def read_image(log_path, line: int, name: str) -> np.ndarray:
    """One tick's image (rows, columns) as 8-bit grey levels; a one-line error naming the log, the
    line and the file if it cannot be read."""
    path = Path(log_path).parent / name
    try:
        with Image.open(path) as im:
            return np.asarray(im.convert("L"))
    except (OSError, ValueError) as e:
        problem = "no such file" if isinstance(e, FileNotFoundError) else f"not a readable image ({e})"
        raise ObservationLogError(f"{log_path}: line {line}, column image: {name}: {problem}") from None


def match_camera_log(
    log: ObservationLog, log_path, config: ViewConfig, progress: Callable[[int, int], None] | None = None
) -> ObservationLog:
    """The camera log with each tick's template number as its scene number and the view's rotation
    relative to the template, matched in order (a log without images is returned as it is)."""
    if log.image is None:
        return log
    vm = ViewMatcher(config)
    n = len(log)
    scene, rotation = np.empty(n, dtype=np.int64), np.empty(n)
    for k, name in enumerate(log.image):
        try:
            m = vm.match(read_image(log_path, k + 2, name))
        except ValueError as e:
            if isinstance(e, ObservationLogError):
                raise
            raise ObservationLogError(f"{log_path}: line {k + 2}, column image: {name}: {e}") from None
        scene[k], rotation[k] = m.template, m.rotation
        if progress is not None:
            progress(k + 1, n)
    return dataclasses.replace(log, scene_id=scene, view_rotation=rotation)
