"""The pixels of a raw ``sensor_msgs/Image`` message as 8-bit grey levels, refused in one line
where they cannot be read (a compressed image is a PNG or JPEG stream: :func:`worlds.images.read_grey`).

:func:`decode_raw` reads the encodings :data:`RAW_ENCODINGS`, honouring ``step`` (the bytes of a
row with its padding) and ``is_bigendian`` for 16-bit grey; the declared size is checked by
:func:`worlds.images.check_size` (the one bound on image sizes) before the data is touched.

Grey levels as :mod:`worlds.images` makes them from files: colour is turned to luma with ITU-R 601
weights (as Pillow's ``convert("L")``, so a raw ``rgb8`` image and the same image compressed give
the same grey levels), alpha is dropped; 16-bit grey keeps its high byte.
"""

from __future__ import annotations

import numpy as np

from .images import ImageReadError, check_size

RAW_ENCODINGS = {"mono8": 1, "mono16": 2, "rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4}
"""``sensor_msgs/Image`` encodings read, with their bytes per pixel."""


def check_encoding(encoding: str, where: str) -> None:
    """Refuse an encoding not in :data:`RAW_ENCODINGS`."""
    if encoding not in RAW_ENCODINGS:
        raise ImageReadError(f"{where}: encoding {encoding!r} not read (read: {', '.join(RAW_ENCODINGS)})")


def _luma(rgb: np.ndarray) -> np.ndarray:
    """ITU-R 601 luma of (..., 3) uint8, rounded as Pillow's ``convert("L")``."""
    r, g, b = (rgb[..., i].astype(np.uint32) for i in range(3))
    return ((r * 19595 + g * 38470 + b * 7471 + 0x8000) >> 16).astype(np.uint8)


def decode_raw(encoding: str, height: int, width: int, step: int, is_bigendian: bool, data, where: str) -> np.ndarray:
    """A ``sensor_msgs/Image``'s pixels as (height, width) grey levels (uint8)."""
    check_encoding(encoding, where)
    height, width, step = int(height), int(width), int(step)
    check_size(width, height, where)
    bpp = RAW_ENCODINGS[encoding]
    if step < width * bpp:
        raise ImageReadError(f"{where}: step {step} is less than width x bytes per pixel ({width} x {bpp})")
    buf = np.frombuffer(memoryview(data), dtype=np.uint8) if not isinstance(data, np.ndarray) else data.view(np.uint8)
    if buf.size < step * height:
        raise ImageReadError(f"{where}: {buf.size} bytes of data, step x height needs {step * height} (truncated)")
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
