"""Camera streams: a simulated run's images written as a camera log, and a camera log's images
turned into template numbers and rotations by the view matcher, for both systems.

A camera log (:mod:`worlds.observation_log`) names each tick's image file in its ``image``
column, relative to the log. :func:`write_images` writes a run's frames as PNGs into a folder next
to the log (all or nothing: :func:`worlds.image_log.staged_images`); :func:`match_camera_log` reads them
in order through :class:`ratslam.view_matcher.ViewMatcher` and returns the log with ``scene_id``
= the matched template and ``view_rotation`` = its rotation, which :func:`harness.run.runner.run_stream`
hands to ``step`` (the pose graph gets the same template numbers). The images and the templates
they matched travel on as :class:`CameraViews` for the recording, and :func:`camera_configs` gives
the settings a camera stream gets in place of those sized for scene numbers.
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from collections.abc import Callable, Collection, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from baselines import PoseGraphConfig
from ratslam import RatSLAMConfig, ViewConfig
from ratslam.view_matcher import ViewMatcher
from worlds import ObservationLog, World
from worlds.camera import Camera, to_uint8
from worlds.image_log import (
    CAMERA_FILE,
    CameraDescription,
    check_field_of_view,
    images_folder,
    read_camera_description,
    staged_images,
)
from worlds.images import ImageReadError, image_size, read_grey
from worlds.observation_log import ObservationLogError

from ..run.directory import OutputError
from ..run.scale import REFERENCE_LABEL_LENGTH_M, ladder, measure_log

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


def write_images(images: np.ndarray, log_path, camera: CameraDescription | None = None) -> np.ndarray:
    """Write frames (N, rows, columns) in [0, 1] as 8-bit PNGs ``000001.png`` ... into
    :func:`images_folder` of ``log_path`` (replacing a previous one whole), with the sidecar
    describing ``camera`` if given; returns each frame's path relative to the log's folder, for the
    log's ``image`` column."""
    try:
        with staged_images(log_path, (to_uint8(frame) for frame in images), len(images), camera) as names:
            return names
    except OSError as e:
        raise OutputError(f"{images_folder(log_path)}: cannot write the camera images ({e.strerror or e})") from None


def simulated_camera(world: World, kind: str) -> CameraDescription:
    """The description of the simulator's camera of ``kind`` in ``world`` (a camera log's sidecar)."""
    fov = 360.0 if kind == "panoramic" else float(world.camera.fov_deg)
    return CameraDescription(fov, kind, "ratslam-harness simulate")


def read_image(log_path, line: int, name: str, expected_size=None, draft_to=None) -> np.ndarray:
    """One tick's image (rows, columns) as 8-bit grey levels (:func:`worlds.images.read_grey`:
    any PNG or JPEG, colour or grey); a one-line error naming the log, the line and the file if it
    cannot be read, is a decompression bomb or is not ``expected_size`` (columns, rows)."""
    try:
        return read_grey(
            Path(log_path).parent / name,
            f"{log_path}: line {line}, column image: {name}",
            expected_size=expected_size,
            draft_to=draft_to,
        )
    except ImageReadError as e:
        raise ObservationLogError(str(e)) from None


READ_AHEAD = 16
"""Images decoded ahead of the matcher, on :data:`READ_THREADS` threads (decoding releases the GIL)."""
READ_THREADS = 2


def _images(log: ObservationLog, log_path, size: tuple[int, int], draft_to) -> Iterator[np.ndarray]:
    """The log's images in order, decoded ahead on threads; the first bad one (in log order) raises."""
    assert log.image is not None
    names = list(log.image)
    with ThreadPoolExecutor(READ_THREADS) as pool:
        ahead: deque[Future] = deque()
        for k in range(len(names)):
            while len(ahead) < READ_AHEAD and k + len(ahead) < len(names):
                j = k + len(ahead)
                ahead.append(pool.submit(read_image, log_path, j + 2, names[j], size, draft_to))
            future = ahead.popleft()
            try:
                yield future.result()
            except BaseException:
                for f in ahead:
                    f.cancel()
                raise


def _draft_to(config: ViewConfig) -> tuple[int, int] | None:
    """The template size a JPEG may be decoded down towards (nothing cropped: crops count pixels of
    the full image)."""
    crops = (config.crop_top, config.crop_bottom, config.crop_left, config.crop_right)
    return None if any(crops) else (config.template_width, config.template_height)


def match_camera_views(
    log: ObservationLog, log_path, config: ViewConfig, progress: Callable[[int, int], None] | None = None
) -> tuple[ObservationLog, CameraViews | None]:
    """The camera log with each tick's template number as its scene number and the view's rotation
    relative to the template, matched in order, and its views for the recording (:class:`CameraViews`;
    a log without images is returned as it is, with None). Every image must have the first one's
    size; a JPEG several times the template's size is decoded at a reduced scale when nothing is
    cropped (:func:`worlds.images.read_grey`). Views wider than :data:`RECORDED_COLUMNS` are kept
    for the recording averaged down to about that width."""
    if log.image is None:
        return log, None
    vm = ViewMatcher(config)
    n = len(log)
    size = image_size(Path(log_path).parent / log.image[0], f"{log_path}: line 2, column image: {log.image[0]}")
    draft_to = _draft_to(config)
    scene, rotation = np.empty(n, dtype=np.int64), np.empty(n)
    recorded = []
    for k, image in enumerate(_images(log, log_path, size, draft_to)):
        try:
            m = vm.match(image)
        except ValueError as e:
            raise ObservationLogError(f"{log_path}: line {k + 2}, column image: {log.image[k]}: {e}") from None
        recorded.append(_for_recording(image))
        scene[k], rotation[k] = m.template, m.rotation
        if progress is not None:
            progress(k + 1, n)
    views = CameraViews(recorded, _templates(vm))
    return dataclasses.replace(log, scene_id=scene, view_rotation=rotation), views


RECORDED_COLUMNS = 160
"""A user's view wider than this is recorded averaged down by a whole factor (a long log of large
images would otherwise be held whole in memory for the recording)."""


def _for_recording(image: np.ndarray) -> np.ndarray:
    f = -(-image.shape[1] // RECORDED_COLUMNS)
    if f <= 1:
        return image
    rows, cols = (image.shape[0] // f) * f, (image.shape[1] // f) * f
    blocks = image[:rows, :cols].reshape(rows // f, f, cols // f, f)
    return blocks.mean(axis=(1, 3)).round().astype(np.uint8)


FORWARD_TEMPLATE_WIDTH = 32
"""Template columns derived for a forward camera (the default matcher's, 1.6 degrees each at 50)."""
MAX_TEMPLATE_HEIGHT = 16
"""The most template rows derived from an image's aspect."""


def derived_template_size(columns: int, rows: int, panoramic: bool, width: int | None = None) -> tuple[int, int]:
    """The template (columns, rows) for a cropped image of ``columns`` x ``rows``: ``width`` if
    given, else half the image's columns, at most :data:`FORWARD_TEMPLATE_WIDTH` (forward) or
    :data:`PANORAMIC_TEMPLATE_WIDTH` (panoramic); and rows in the image's aspect, between 1 and
    :data:`MAX_TEMPLATE_HEIGHT` (and at most the image's rows). The simulator's 64x16 forward and
    128x16 panoramic images get the defaults, 32x8 and 64x8."""
    if width is None:
        cap = PANORAMIC_TEMPLATE_WIDTH if panoramic else FORWARD_TEMPLATE_WIDTH
        width = max(2, min(columns // 2, cap))
    height = max(1, min(round(width * rows / columns), MAX_TEMPLATE_HEIGHT, rows))
    return width, height


SELF_SIMILAR_WINDOW_S = 60.0
"""The stretch at the start of a log whose views set the match threshold."""
SELF_SIMILAR_TRAVEL_M = 0.3
"""Each view in that stretch is compared with the view this much odometry travel before it."""
SELF_SIMILAR_SCALE = 0.9
"""The threshold is this times the median of those differences: on the simulator's default
forward camera (small loop, seed 0; median 0.0441) that is 0.0397, about the fixed default 0.04
(docs/your-camera.md measures the rule on other sizes, noise, light and worlds)."""
SELF_SIMILAR_MIN_PAIRS = 20
"""Fewer pairs than this (a robot that hardly moved) keep the configured threshold."""


def self_similarity(frame: Callable[[int], np.ndarray], log: ObservationLog, config: ViewConfig) -> tuple[float, int]:
    """The median least difference (over the matcher's shifts, with ``config``'s template)
    between each view of the log's first :data:`SELF_SIMILAR_WINDOW_S` seconds and the view
    :data:`SELF_SIMILAR_TRAVEL_M` of odometry travel before it, and the number of such pairs
    (NaN, 0 if none). ``frame(k)`` is tick ``k``'s image."""
    window = np.flatnonzero(log.t <= log.t[0] + SELF_SIMILAR_WINDOW_S)
    travel = np.cumsum(np.abs(log.v_trans * log.dt))
    matcher = ViewMatcher(config)
    plain = dataclasses.replace(  # compares templates as they are: no crop, no normalisation again
        config,
        crop_top=0,
        crop_bottom=0,
        crop_left=0,
        crop_right=0,
        global_normalisation=False,
        patch_normalisation_radius=0,
    )
    templates: dict[int, np.ndarray] = {}

    def template(k: int) -> np.ndarray:
        if k not in templates:
            templates[k] = matcher.template_of(frame(k))
        return templates[k]

    diffs = []
    for k in window:
        j = int(np.searchsorted(travel, travel[k] - SELF_SIMILAR_TRAVEL_M, side="right")) - 1
        if j < 0:
            continue
        probe = ViewMatcher(plain)
        probe.store(template(j))
        d, _ = probe.differences(template(int(k)))
        diffs.append(float(d[0]))
    return (float(np.median(diffs)), len(diffs)) if diffs else (math.nan, 0)


def self_similar_threshold(frame: Callable[[int], np.ndarray], log: ObservationLog, config: ViewConfig):
    """The match threshold from the first minute's self-similarity (:data:`SELF_SIMILAR_SCALE`
    times :func:`self_similarity`), or None where there are fewer than
    :data:`SELF_SIMILAR_MIN_PAIRS` pairs; and the line saying how it was derived."""
    median, pairs = self_similarity(frame, log, config)
    if pairs < SELF_SIMILAR_MIN_PAIRS:
        return None, (
            f"match threshold {config.match_threshold:g} as configured: only {pairs} views of the first "
            f"{SELF_SIMILAR_WINDOW_S:g} s lie {SELF_SIMILAR_TRAVEL_M:g} m of travel after another"
        )
    threshold = SELF_SIMILAR_SCALE * median
    return threshold, (
        f"match threshold {threshold:.4g} = {SELF_SIMILAR_SCALE:g} x {median:.4g}, the median difference of the "
        f"first {SELF_SIMILAR_WINDOW_S:g} s's views to those {SELF_SIMILAR_TRAVEL_M:g} m of travel before "
        f"({pairs} pairs)"
    )


def log_camera_view(
    log: ObservationLog, log_path, view: ViewConfig, given: Collection[str] = (), fov_deg: float | None = None
) -> tuple[ViewConfig, str]:
    """The matcher's settings for a camera log: ``view`` with the fields not in ``given`` (the
    ``[ratslam.view]`` keys a configuration file set) derived from the log, and a line saying what
    was derived. The field of view: ``fov_deg`` (``--fov``), else the configuration file's, else
    the log's camera description (:data:`worlds.image_log.CAMERA_FILE`), else a one-line error
    saying how to give it. The template size: :func:`derived_template_size` of the first image's
    cropped size. The match threshold: :func:`self_similar_threshold` of the log's first minute
    (docs/your-camera.md measures it against the fixed default)."""
    assert log.image is not None
    said = []
    if fov_deg is not None:
        fov = check_field_of_view(fov_deg, "--fov")
        said.append(f"field of view {fov:g} deg from --fov")
    elif "field_of_view_deg" in given:
        fov = view.field_of_view_deg
    else:
        described = read_camera_description(log_path, log.image[0])
        if described is None:
            raise ObservationLogError(
                f"{log_path}: the camera's horizontal field of view is unknown: give it with --fov DEG "
                "(or field_of_view_deg under [ratslam.view] in a --config file; 360 for a panoramic camera)"
            )
        fov = described.field_of_view_deg
        said.append(f"field of view {fov:g} deg from {Path(log.image[0]).parent / CAMERA_FILE}")
    view = dataclasses.replace(view, field_of_view_deg=fov)
    where = f"{log_path}: line 2, column image: {log.image[0]}"
    size = image_size(Path(log_path).parent / log.image[0], where)
    if not {"template_width", "template_height"} <= set(given):
        columns, rows = size
        cropped = (columns - view.crop_left - view.crop_right, rows - view.crop_top - view.crop_bottom)
        if min(cropped) < 1:
            raise ObservationLogError(f"{where}: {columns}x{rows} pixels, nothing left after view.crop_*")
        given_width = view.template_width if "template_width" in given else None
        width, height = derived_template_size(*cropped, view.panoramic, given_width)
        if "template_height" in given:
            height = view.template_height
        view = dataclasses.replace(view, template_width=width, template_height=height)
        said.append(f"template {width}x{height} from the {cropped[0]}x{cropped[1]} (cropped) images")
    if "match_threshold" not in given:
        draft_to = _draft_to(view)
        names = log.image

        def frame(k: int) -> np.ndarray:
            return read_image(log_path, k + 2, names[k], size, draft_to)

        threshold, line = self_similar_threshold(frame, log, view)
        if threshold is not None:
            view = dataclasses.replace(view, match_threshold=threshold)
        said.append(line)
    return view, ("View matcher: " + "; ".join(said) + ".") if said else ""


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
      scaled as :func:`harness.run.scale.derive_configs` scales it for any log's labels: by the ratio of
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
