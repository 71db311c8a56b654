"""Reading a camera's image files safely: grey levels from a PNG or JPEG (colour or grey, any
size), with every problem one line naming the file.

The header is read first (Pillow opens lazily): an image declaring more than
:data:`MAX_IMAGE_PIXELS` pixels (a decompression bomb: a small file that would decode to
gigapixels) or of another size than the stream's first image is refused before anything is
decoded. A missing, unreadable, truncated or corrupt file is refused when it is decoded (Pillow's
``LOAD_TRUNCATED_IMAGES`` stays off, so a short file is an error, not grey padding).

A JPEG much larger than the view matcher's template may be decoded at a reduced scale
(``draft``: the decoder's own 1/2, 1/4 or 1/8 DCT scaling), which is several times faster and
keeps at least twice the template's rows and columns.
"""

from __future__ import annotations

import warnings
import zlib
from pathlib import Path

import numpy as np
from PIL import Image, ImageFile

from .errors import InputError

MAX_IMAGE_PIXELS = 40_000_000
"""An image declaring more pixels than this (e.g. 8000 x 5000) is refused from its header: a
camera's frames are far smaller, and a decoded frame this size is 40 MB of grey levels."""

ImageFile.LOAD_TRUNCATED_IMAGES = False  # a truncated file is an error, never padded

_DECODE_ERRORS = (OSError, ValueError, SyntaxError, EOFError, zlib.error, Image.DecompressionBombError)


class ImageReadError(InputError):
    """An image that cannot be used (one line: where, file, problem)."""


def image_size(path, where: str = "") -> tuple[int, int]:
    """(columns, rows) from the image's header, without decoding it."""
    try:
        with _open(Path(path)) as im:
            return im.size
    except _DECODE_ERRORS as e:
        raise ImageReadError(f"{where or path}: {_problem(e)}") from None


def read_grey(
    path,
    where: str = "",
    expected_size: tuple[int, int] | None = None,
    draft_to: tuple[int, int] | None = None,
) -> np.ndarray:
    """An image file as grey levels (rows, columns) uint8. ``where`` heads the error message
    (default: the path). ``expected_size`` (columns, rows): a frame of another size is refused
    from its header. ``draft_to`` (columns, rows): a JPEG at least twice this size either way may
    be decoded at a reduced scale that keeps it at least twice this size."""
    path = Path(path)
    where = where or str(path)
    try:
        with _open(path) as im:
            w, h = im.size
            if w * h > MAX_IMAGE_PIXELS:
                raise ImageReadError(
                    f"{where}: declares {w}x{h} pixels, more than {MAX_IMAGE_PIXELS:,} (a decompression bomb?); "
                    "refused before decoding"
                )
            if expected_size is not None and (w, h) != tuple(expected_size):
                ew, eh = expected_size
                raise ImageReadError(
                    f"{where}: {w}x{h} pixels, but the first image is {ew}x{eh}; every frame must have one size"
                )
            if draft_to is not None and im.format == "JPEG":
                im.draft("L", (2 * draft_to[0], 2 * draft_to[1]))
            im.load()
            grey = im if im.mode == "L" else _to_grey(im)
            return np.asarray(grey)
    except ImageReadError:
        raise
    except _DECODE_ERRORS as e:
        raise ImageReadError(f"{where}: {_problem(e)}") from None


def _open(path: Path) -> Image.Image:
    """Pillow's lazy open (the header only), without its own bomb warning: the bound here says it
    in one line, and beyond twice its own limit Pillow refuses at once."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)
        return Image.open(path)


def _to_grey(im: Image.Image) -> Image.Image:
    """Grey levels of any mode: colour by ITU-R 601 luma (Pillow's ``convert("L")``), 16-bit and
    float images scaled from their own range, transparency ignored."""
    if im.mode in ("I;16", "I;16B", "I;16L", "I", "F"):
        a = np.asarray(im, dtype=np.float64)
        top = 65535.0 if im.mode.startswith("I;16") or (im.mode == "I" and a.max(initial=0) > 255) else 255.0
        if im.mode == "F":
            top = 1.0 if a.max(initial=0) <= 1.0 else 255.0
        return Image.fromarray(np.clip(np.rint(a * (255.0 / top)), 0, 255).astype(np.uint8), mode="L")
    if im.mode in ("RGBA", "LA", "PA") or (im.mode == "P" and "transparency" in im.info):
        im = im.convert("RGBA").convert("RGB")
    return im.convert("L")


def _problem(e: BaseException) -> str:
    if isinstance(e, FileNotFoundError):
        return "no such file"
    if isinstance(e, IsADirectoryError):
        return "is a directory, not an image"
    if isinstance(e, PermissionError):
        return "permission denied"
    if isinstance(e, Image.DecompressionBombError):
        return f"declares more than {MAX_IMAGE_PIXELS:,} pixels (a decompression bomb?); refused before decoding"
    if isinstance(e, Image.UnidentifiedImageError):
        return "not a PNG or JPEG image (unrecognised format)"
    text = str(e).splitlines()[0] if str(e) else type(e).__name__
    if "truncated" in text or isinstance(e, EOFError):
        return f"truncated image ({text})"
    return f"not a readable image ({text})"
