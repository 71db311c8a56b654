"""Camera streams: a simulated run's images written as a camera log, and a camera log's images
turned into template numbers and rotations by the view matcher, for both systems.

A camera log (:mod:`worlds.observation_log`) names each tick's image file in its ``image``
column, relative to the log. :func:`write_images` writes a run's frames as PNGs into a folder next
to the log (all or nothing: a staging folder moved into place); :func:`match_camera_log` reads them
in order through :class:`ratslam.view_matcher.ViewMatcher` and returns the log with ``scene_id``
= the matched template and ``view_rotation`` = its rotation, which :func:`harness.runner.run_stream`
hands to ``step`` (the pose graph gets the same template numbers). The images and the templates
they matched travel on as :class:`CameraViews` for the recording, and :func:`camera_configs` gives
the settings a camera stream gets in place of those sized for scene numbers.
"""

from __future__ import annotations

import dataclasses
import math
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from baselines import PoseGraphConfig
from ratslam import RatSLAMConfig, ViewConfig
from ratslam.view_matcher import ViewMatcher
from worlds import ObservationLog, World
from worlds.camera import Camera, to_uint8
from worlds.observation_log import ObservationLogError

from .run_dir import OutputError
from .scale import REFERENCE_LABEL_LENGTH_M, ladder, measure_log

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


@dataclass(frozen=True)
class CameraViews:
    """What the camera showed and what the matcher matched, for the recording: each tick's image
    (rows, columns; an array (N, rows, columns) or a list) and the stored templates (n,
    template_height, template_width), both as 8-bit grey levels; tick k matched template
    ``log.scene_id[k]``."""

    images: np.ndarray | list[np.ndarray]
    templates: np.ndarray


def _templates(vm: ViewMatcher) -> np.ndarray:
    return (
        to_uint8(vm.templates)
        if len(vm)
        else np.zeros((0, vm.config.template_height, vm.config.template_width), np.uint8)
    )


def camera_views(
    world: World, log: ObservationLog, kind: str, seed: int, config: ViewConfig
) -> tuple[ObservationLog, CameraViews]:
    """A simulated log seen through the camera: each tick rendered at its true pose (``seed``: the
    sensor noise) and matched in order; scene numbers become template numbers with their rotations,
    and no tick is labelled a false positive (wrong matches are the camera's own). Also returns
    the images and templates (:class:`CameraViews`)."""
    frames = Camera(world, kind, seed=seed).render_poses(log.ground_truth(), log.t)
    vm = ViewMatcher(config)
    matches = [vm.match(frame) for frame in frames]
    log = dataclasses.replace(
        log,
        scene_id=np.array([m.template for m in matches], dtype=np.int64),
        view_rotation=np.array([m.rotation for m in matches]),
        false_positive=np.zeros(len(log), dtype=bool),
    )
    return log, CameraViews(to_uint8(frames), _templates(vm))


def camera_observations(world: World, log: ObservationLog, kind: str, seed: int, config: ViewConfig) -> ObservationLog:
    """The log of :func:`camera_views` without the images."""
    return camera_views(world, log, kind, seed, config)[0]


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


def match_camera_views(
    log: ObservationLog, log_path, config: ViewConfig, progress: Callable[[int, int], None] | None = None
) -> tuple[ObservationLog, CameraViews | None]:
    """The camera log with each tick's template number as its scene number and the view's rotation
    relative to the template, matched in order, and its images and templates (a log without
    images is returned as it is, with None)."""
    if log.image is None:
        return log, None
    vm = ViewMatcher(config)
    n = len(log)
    scene, rotation = np.empty(n, dtype=np.int64), np.empty(n)
    images = []
    for k, name in enumerate(log.image):
        image = read_image(log_path, k + 2, name)
        try:
            m = vm.match(image)
        except ValueError as e:
            raise ObservationLogError(f"{log_path}: line {k + 2}, column image: {name}: {e}") from None
        images.append(image)
        scene[k], rotation[k] = m.template, m.rotation
        if progress is not None:
            progress(k + 1, n)
    return dataclasses.replace(log, scene_id=scene, view_rotation=rotation), CameraViews(images, _templates(vm))


def match_camera_log(
    log: ObservationLog, log_path, config: ViewConfig, progress: Callable[[int, int], None] | None = None
) -> ObservationLog:
    """The log of :func:`match_camera_views` without the images."""
    return match_camera_views(log, log_path, config, progress)[0]


def match_heading_sigma(view: ViewConfig) -> float:
    """How well a match gives the heading (rad), from the matcher's settings alone: the view can be
    anywhere within the shifts searched, uniformly: +-``max_shift_deg`` for a forward camera
    (2 x 20 deg / sqrt(12) = 11.5 deg), the whole circle for a panoramic one (104 deg). The
    analogue of the scene numbers' one 90 deg sector, (pi / 2) / sqrt(6)."""
    span = 2.0 * math.pi if view.panoramic else 2.0 * math.radians(min(view.max_shift_deg, view.field_of_view_deg))
    return span / math.sqrt(12.0)


def camera_configs(
    log: ObservationLog,
    view: ViewConfig,
    ratslam: RatSLAMConfig | None = None,
    gtsam: PoseGraphConfig | None = None,
    *,
    scale_position: bool = True,
) -> tuple[RatSLAMConfig, PoseGraphConfig, str]:
    """RatSLAM and pose-graph configurations for a camera stream: ``ratslam`` / ``gtsam`` (default:
    the defaults) with the settings sized for scene numbers re-derived from the matcher's settings
    (``view``) and the stream of template numbers (``log``: its ``dt``, ``v_trans`` and
    ``scene_id`` only, never the ground truth). The measurements behind each decision are in
    docs/camera.md.

    - Changed: the heading a match gives (the pose graph's ``closures.sigma_theta_rad``, RatSLAM's
      ``yaw_bias.revisit_sigma_heading_deg``), from the matcher's settings
      (:func:`match_heading_sigma`).
    - Changed: the position a match gives (``closures.sigma_xy_m``, ``yaw_bias.revisit_sigma_xy_m``),
      scaled as :func:`harness.scale.derive_configs` scales it for any log's labels: by the ratio of
      the template's label length to a 1 m scene cell's, on the ladder of powers of sqrt(2)
      (``scale_position=False`` where ``derive_configs`` has already done so: a replay).
    - Kept: the path between revisits, ``local_view.min_age_ticks`` and the habituation
      (``local_view.fatigue_rate``, ``fatigue_recovery``).
    """
    rs, pg = ratslam or RatSLAMConfig(), gtsam or PoseGraphConfig()
    m = measure_log(log)
    run_ticks = m.label_length / m.step if m.step > 0 and math.isfinite(m.label_length) else float("nan")
    k_xy = ladder(m.label_length / REFERENCE_LABEL_LENGTH_M) if scale_position else 1.0
    sigma_theta = match_heading_sigma(view)
    rs = rs.replace(
        yaw_bias={
            "revisit_sigma_heading_deg": round(math.degrees(sigma_theta), 3),
            "revisit_sigma_xy_m": rs.yaw_bias.revisit_sigma_xy_m * k_xy,
        }
    )
    pg = pg.replace(closures={"sigma_theta_rad": sigma_theta, "sigma_xy_m": pg.closures.sigma_xy_m * k_xy})
    text = (
        f"Camera stream: a template lasts {m.label_length:.2f} m, {run_ticks:.1f} ticks (measured from its template "
        f"numbers, no ground truth): a match gives the position to closures.sigma_xy_m {pg.closures.sigma_xy_m:.3f} m "
        + (
            f"(x{k_xy:g} of a {REFERENCE_LABEL_LENGTH_M} m label's; yaw_bias.revisit_sigma_xy_m the same). "
            if scale_position
            else "(scaled to the label length above). "
        )
        + "From the "
        f"matcher's settings, the heading to {math.degrees(sigma_theta):.1f} deg (closures.sigma_theta_rad "
        f"{sigma_theta:.4f}, yaw_bias.revisit_sigma_heading_deg {math.degrees(sigma_theta):.3f}). The rest as for "
        "scene numbers."
    )
    return rs, pg, text
