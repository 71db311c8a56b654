"""Reading a camera's images safely: grey levels from a PNG or JPEG (a file or the bytes of a
recorded message; colour or grey, any size), with every problem one line naming where it came from.

:func:`open_image` is the one header check, for every source of images (an image log's files at
replay, an image folder's files at import, a bag's compressed images): the header is read first
(Pillow opens lazily) and an image declaring no pixels or more than :data:`MAX_IMAGE_PIXELS` (a
decompression bomb: a small file that would decode to gigapixels) is refused before anything is
decoded; :func:`check_size` is the same bound for sizes declared elsewhere (a raw message's
fields, a video stream's), and refuses a frame of another size than the stream's first. A missing,
unreadable, truncated or corrupt image is refused when it is decoded (Pillow's
``LOAD_TRUNCATED_IMAGES`` stays off, so a short file is an error, not grey padding).

A JPEG much larger than the view matcher's template may be decoded at a reduced scale
(``draft``: the decoder's own 1/2, 1/4 or 1/8 DCT scaling), which is several times faster and
keeps at least twice the template's rows and columns.
"""

from __future__ import annotations

import io
import os
import warnings
import zlib
from pathlib import Path

import numpy as np
from PIL import Image, ImageFile

from .errors import InputError

MAX_IMAGE_PIXELS = 40_000_000
"""An image declaring more pixels than this (e.g. 8000 x 5000) is refused from its header: a
camera's frames are far smaller, and a decoded frame this size is 40 MB of grey levels."""

FORMATS = ("PNG", "JPEG")
"""The image formats read."""

ImageFile.LOAD_TRUNCATED_IMAGES = False  # a truncated file is an error, never padded

_DECODE_ERRORS = (OSError, ValueError, SyntaxError, EOFError, zlib.error, Image.DecompressionBombError)


class ImageReadError(InputError):
    """An image that cannot be used (one line: where, file, problem)."""


def check_size(width: int, height: int, where: str, first: tuple[int, int] | None = None, first_is: str = "") -> None:
    """Refuse a declared image size that is empty or beyond :data:`MAX_IMAGE_PIXELS`, or, with
    ``first`` (columns, rows), of another size than the stream's first image (``first_is`` names
    it; default "the first image")."""
    if width <= 0 or height <= 0:
        raise ImageReadError(f"{where}: empty image ({width}x{height} pixels)")
    if width * height > MAX_IMAGE_PIXELS:
        raise ImageReadError(
            f"{where}: declares {width}x{height} pixels, more than {MAX_IMAGE_PIXELS:,} (a decompression bomb?); "
            "refused before decoding"
        )
    if first is not None and (width, height) != tuple(first):
        raise ImageReadError(
            f"{where}: {width}x{height} pixels, but {first_is or 'the first image'} is {first[0]}x{first[1]}; "
            "every frame must have one size"
        )


def open_image(source: str | os.PathLike | bytes, where: str = "") -> Image.Image:
    """A PNG or JPEG file (a path) or stream (bytes) opened lazily, its header read and its size
    checked (:func:`check_size`), nothing decoded; close it. ``where`` heads the error message
    (default: the path)."""
    where = where or str(source)
    try:
        with warnings.catch_warnings():  # the bound here says it in one line; beyond twice its own
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # limit Pillow refuses at once
            im = Image.open(io.BytesIO(source) if isinstance(source, bytes) else Path(source), formats=FORMATS)
    except _DECODE_ERRORS as e:
        raise ImageReadError(f"{where}: {_problem(e)}") from None
    try:
        check_size(*im.size, where)
    except ImageReadError:
        im.close()
        raise
    return im


def image_size(source, where: str = "") -> tuple[int, int]:
    """(columns, rows) from the image's header (checked by :func:`open_image`), without decoding it."""
    with open_image(source, where) as im:
        return im.size


def read_grey(
    source,
    where: str = "",
    expected_size: tuple[int, int] | None = None,
    draft_to: tuple[int, int] | None = None,
) -> np.ndarray:
    """An image file (a path) or stream (bytes) as grey levels (rows, columns) uint8. ``where``
    heads the error message (default: the path). ``expected_size`` (columns, rows): a frame of
    another size is refused from its header. ``draft_to`` (columns, rows): a JPEG at least twice
    this size either way may be decoded at a reduced scale that keeps it at least twice this size."""
    where = where or str(source)
    with open_image(source, where) as im:
        if expected_size is not None:
            check_size(*im.size, where, first=expected_size)
        try:
            if draft_to is not None and im.format == "JPEG":
                im.draft("L", (2 * draft_to[0], 2 * draft_to[1]))
            im.load()
            grey = im if im.mode == "L" else _to_grey(im)
            return np.asarray(grey)
        except _DECODE_ERRORS as e:
            raise ImageReadError(f"{where}: {_problem(e)}") from None


def _to_grey(im: Image.Image) -> Image.Image:
    """Grey levels of any mode: colour by ITU-R 601 luma (Pillow's ``convert("L")``), 16-bit grey
    by its high byte (the full 16-bit range onto 8 bits, as a raw ``mono16`` message), transparency
    ignored."""
    if im.mode in ("I;16", "I;16B", "I;16L", "I"):
        grey16 = np.clip(np.asarray(im, dtype=np.int64), 0, 65535)
        return Image.fromarray((grey16 >> 8).astype(np.uint8), mode="L")
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
