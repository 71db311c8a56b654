"""Writing a camera (image) log: odometry ticks, optional ground truth and one image per tick become
an observation log with an ``image`` column and its images folder, written all or nothing.

The log keeps DESIGN.md's CSV contract (``t,dt,v_trans,v_rot,image`` and the optional ground-truth
columns); the images go into ``<log stem>_images/`` next to it and the ``image`` column names them
relative to the log. The camera that took them, where it is known, is described by a sidecar
``camera.toml`` in that folder (:data:`CAMERA_FILE`)::

    # The camera that took the images in this folder (read by ratslam-harness replay).
    field_of_view_deg = 50.0
    kind = "forward"

``field_of_view_deg`` (the horizontal field of view, which turns a template shift into a rotation)
is the one key replay needs; ``kind`` and ``source`` are informative. The simulator writes it for
every camera log; an importer writes it when told the field of view. A log without it is replayed
with a field of view from ``--fov`` or the configuration file.

:func:`write_image_log` is the one writer, for every source of images (the simulator's frames,
an image folder, a bag's image topic, a video's frames).
"""

from __future__ import annotations

import dataclasses
import math
import os
import shutil
import tomllib
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from .errors import InputError
from .files import atomic_path, atomic_write_text
from .observation_log import ObservationLog

CAMERA_FILE = "camera.toml"
"""The sidecar describing the camera, in the folder of a log's images."""


class ImageLogError(InputError):
    """An image log that cannot be written (one line: what, tick or file, problem)."""


@dataclass(frozen=True)
class CameraDescription:
    """The camera that took a log's images: its horizontal field of view (degrees; 360 =
    panoramic), and optionally its kind ("forward", "panoramic") and what wrote the log."""

    field_of_view_deg: float
    kind: str | None = None
    source: str | None = None

    def toml(self) -> str:
        lines = [
            "# The camera that took the images in this folder (read by ratslam-harness replay).",
            f"field_of_view_deg = {float(self.field_of_view_deg)!r}",
        ]
        lines += [f'{k} = "{v}"' for k, v in (("kind", self.kind), ("source", self.source)) if v]
        return "\n".join(lines) + "\n"


def images_folder(log_path) -> Path:
    """Where an image log's images go: ``<log stem>_images`` next to the log."""
    log_path = Path(log_path)
    return log_path.with_name(f"{log_path.stem}_images")


def check_field_of_view(value: float, where: str) -> float:
    """A horizontal field of view in degrees, in (0, 360]; else a one-line error naming ``where``."""
    if not (isinstance(value, (int, float)) and math.isfinite(value) and 0.0 < value <= 360.0):
        raise ImageLogError(f"{where}: field of view must be in (0, 360] degrees, got {value!r}")
    return float(value)


def read_camera_description(log_path, first_image: str) -> CameraDescription | None:
    """The sidecar :data:`CAMERA_FILE` in the folder of the log's first image, or None if there is
    none; a malformed one is a one-line error naming it and the key."""
    path = (Path(log_path).parent / first_image).parent / CAMERA_FILE
    if not path.is_file():
        return None
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as e:
        raise ImageLogError(f"{path}: not a readable camera description ({e})") from None
    unknown = set(raw) - {"field_of_view_deg", "kind", "source"}
    if unknown:
        raise ImageLogError(f"{path}: unknown key {sorted(unknown)[0]!r} (allowed: field_of_view_deg, kind, source)")
    if "field_of_view_deg" not in raw:
        raise ImageLogError(f"{path}: field_of_view_deg: missing (the camera's horizontal field of view, degrees)")
    fov = raw["field_of_view_deg"]
    if isinstance(fov, bool) or not isinstance(fov, (int, float)):
        raise ImageLogError(f"{path}: field_of_view_deg: expected a number of degrees, got {fov!r}")
    check_field_of_view(float(fov), f"{path}: field_of_view_deg")
    for key in ("kind", "source"):
        if key in raw and not isinstance(raw[key], str):
            raise ImageLogError(f"{path}: {key}: expected a string, got {raw[key]!r}")
    return CameraDescription(float(fov), raw.get("kind"), raw.get("source"))


def write_image_log(
    out,
    odometry: ObservationLog,
    images: Iterable[np.ndarray | str | os.PathLike],
    camera: CameraDescription | None = None,
) -> ObservationLog:
    """Write an image log: ``odometry``'s ticks (``t``, ``dt``, ``v_trans``, ``v_rot`` and its
    ground-truth columns if it has them; its scene numbers are not written) with one image per
    tick, to CSV ``out`` and its images folder (:func:`images_folder`), with the sidecar
    :data:`CAMERA_FILE` if ``camera`` is given.

    ``images`` yields, per tick in order, either a grey image (2-D uint8 array), written as a PNG
    ``000001.png`` ..., or the path of an existing image file, copied into the folder under its
    own name (a file named by several ticks is copied once). Both are written under temporary names
    and moved into place at the end, so a failure leaves neither and an existing log and folder of
    that name are replaced whole. Returns the log as written (``image`` set)."""
    out = Path(out)
    final = images_folder(out)
    stage = final.with_name(f".{final.name}.tmp-{os.getpid()}")
    n = len(odometry)
    try:
        if stage.exists():
            shutil.rmtree(stage)
        stage.mkdir(parents=True)
        names = _stage_images(stage, final.name, images, n)
        if camera is not None:
            atomic_write_text(stage / CAMERA_FILE, camera.toml())
        log = dataclasses.replace(odometry, scene_id=np.full(n, -1, dtype=np.int64), image=names, view_rotation=None)
        with atomic_path(out) as tmp:
            log.write_csv(tmp)
            if final.exists():
                shutil.rmtree(final)
            stage.rename(final)
    except OSError as e:
        raise ImageLogError(f"{final}: cannot write the image log ({e.strerror or e})") from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return log


def _stage_images(stage: Path, folder: str, images: Iterable[np.ndarray | str | os.PathLike], n: int) -> np.ndarray:
    names: list[str] = []
    copied: dict[Path, str] = {}
    taken: set[str] = set()
    for k, item in enumerate(images):
        if k >= n:
            raise ImageLogError(f"images: more images than the {n} odometry ticks")
        if isinstance(item, (str, os.PathLike)):
            src = Path(item)
            if src not in copied and src.resolve().is_relative_to(stage.parent.resolve() / folder):
                raise ImageLogError(
                    f"{src}: tick {k + 1}: is in {folder}/, which the log's images replace; write the log elsewhere"
                )
            if src not in copied:
                name = src.name if src.name not in taken and src.name != CAMERA_FILE else f"{k + 1:06d}_{src.name}"
                try:
                    shutil.copyfile(src, stage / name)
                except OSError as e:
                    raise ImageLogError(f"{src}: tick {k + 1}: cannot copy the image ({e.strerror or e})") from None
                copied[src] = name
                taken.add(name)
            names.append(f"{folder}/{copied[src]}")
            continue
        a = np.asarray(item)
        if a.ndim != 2 or a.dtype != np.uint8:
            raise ImageLogError(f"images: tick {k + 1}: expected a grey image (2-D uint8), got {a.dtype} {a.shape}")
        name = f"{k + 1:06d}.png"
        Image.fromarray(a, mode="L").save(stage / name, optimize=False)
        taken.add(name)
        names.append(f"{folder}/{name}")
    if len(names) != n:
        raise ImageLogError(f"images: {len(names)} images for {n} odometry ticks (one per tick is needed)")
    return np.array(names, dtype=object)
