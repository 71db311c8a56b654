"""Camera images from recorded messages and files to 8-bit grey levels, refused in one line where
they cannot be read.

* :func:`decode_raw`: the fields of a ``sensor_msgs/Image`` (encodings :data:`RAW_ENCODINGS`,
  honouring ``step``, the bytes of a row with its padding, and ``is_bigendian`` for 16-bit grey).
* :func:`decode_compressed`: a ``sensor_msgs/CompressedImage`` or an image file's bytes, JPEG or
  PNG only; the size its header declares is checked against :data:`MAX_PIXELS` before anything is
  decoded, so a small file that would decode to gigapixels (a decompression bomb) costs nothing.

Grey levels: colour is turned to luma with ITU-R 601 weights (as Pillow's ``convert("L")``, so a
raw ``rgb8`` image and the same image compressed give the same grey levels), alpha is dropped;
16-bit grey keeps its high byte (the full 16-bit range mapped onto 8 bits).
"""

from __future__ import annotations

import io
import warnings

import numpy as np
from PIL import Image

from .errors import InputError

MAX_PIXELS = 2**24
"""The largest image accepted (16.8 million pixels, e.g. 4096 x 4096): a view matcher averages an
image down to a template of a few hundred pixels, so anything larger is a mistake or a bomb."""

RAW_ENCODINGS = {"mono8": 1, "mono16": 2, "rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4}
"""``sensor_msgs/Image`` encodings read, with their bytes per pixel."""

COMPRESSED_FORMATS = ("JPEG", "PNG")


class ImageDecodeError(InputError):
    """An image that cannot be read (the caller's message names where it came from)."""


def check_size(width: int, height: int, where: str) -> None:
    """Refuse a declared image size that is empty or beyond :data:`MAX_PIXELS`."""
    if width <= 0 or height <= 0:
        raise ImageDecodeError(f"{where}: empty image ({width} x {height})")
    if width * height > MAX_PIXELS:
        raise ImageDecodeError(
            f"{where}: declares {width} x {height} pixels, beyond the {MAX_PIXELS:,} accepted "
            "(a decompression bomb or a mistake); not decoded"
        )


def _luma(rgb: np.ndarray) -> np.ndarray:
    """ITU-R 601 luma of (..., 3) uint8, rounded as Pillow's ``convert("L")``."""
    r, g, b = (rgb[..., i].astype(np.uint32) for i in range(3))
    return ((r * 19595 + g * 38470 + b * 7471 + 0x8000) >> 16).astype(np.uint8)


def decode_raw(encoding: str, height: int, width: int, step: int, is_bigendian: bool, data, where: str) -> np.ndarray:
    """A ``sensor_msgs/Image``'s pixels as (height, width) grey levels (uint8)."""
    if encoding not in RAW_ENCODINGS:
        raise ImageDecodeError(f"{where}: encoding {encoding!r} not read (read: {', '.join(RAW_ENCODINGS)})")
    height, width, step = int(height), int(width), int(step)
    check_size(width, height, where)
    bpp = RAW_ENCODINGS[encoding]
    if step < width * bpp:
        raise ImageDecodeError(f"{where}: step {step} is less than width x bytes per pixel ({width} x {bpp})")
    buf = np.frombuffer(memoryview(data), dtype=np.uint8) if not isinstance(data, np.ndarray) else data.view(np.uint8)
    if buf.size < step * height:
        raise ImageDecodeError(f"{where}: {buf.size} bytes of data, step x height needs {step * height} (truncated)")
    rows = buf[: step * height].reshape(height, step)[:, : width * bpp]
    if encoding == "mono8":
        return np.ascontiguousarray(rows)
    if encoding == "mono16":
        grey16 = rows.copy().view(">u2" if is_bigendian else "<u2")
        return (grey16 >> 8).astype(np.uint8)
    pixels = rows.reshape(height, width, bpp)
    if encoding.startswith("bgr"):
        pixels = pixels[..., 2::-1]
    return _luma(pixels[..., :3])


def _open_compressed(raw: bytes, where: str) -> Image.Image:
    """A JPEG or PNG opened lazily (its header read, nothing decoded), its declared size checked."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", Image.DecompressionBombWarning)
            im = Image.open(io.BytesIO(raw), formats=list(COMPRESSED_FORMATS))
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as e:
        raise ImageDecodeError(f"{where}: {e}; not decoded") from None
    except (OSError, ValueError, SyntaxError) as e:
        raise ImageDecodeError(f"{where}: not a JPEG or PNG image ({type(e).__name__}: {e})") from None
    try:
        check_size(*im.size, where)
    except ImageDecodeError:
        im.close()
        raise
    return im


def compressed_size(data, where: str) -> tuple[int, int]:
    """The (width, height) a JPEG or PNG declares in its header, checked; nothing is decoded."""
    with _open_compressed(bytes(data), where) as im:
        return im.size


def decode_compressed(data, where: str) -> np.ndarray:
    """JPEG or PNG bytes as (height, width) grey levels (uint8); the declared size is checked
    before decoding, a truncated or invalid stream is refused."""
    with _open_compressed(bytes(data), where) as im:
        try:
            im.load()
        except (OSError, ValueError, SyntaxError) as e:
            raise ImageDecodeError(f"{where}: {im.format} image cannot be decoded ({e})") from None
        if im.mode in ("I;16", "I;16B", "I;16L", "I"):
            grey16 = np.asarray(im, dtype=np.int64)
            return (np.clip(grey16, 0, 65535) >> 8).astype(np.uint8)
        return np.asarray(im.convert("L"))
