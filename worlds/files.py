"""Reading and writing the project's files: atomic writes, text, TUM trajectories and JSON.

Every file is written under a temporary name in its destination's directory and moved onto
the destination only once complete (``os.replace``, atomic on one file system), so a reader or
an interrupted writer never sees half a file; on an exception the temporary file is removed
and the destination is left as it was. Files are not fsync'ed: the move protects against an
interrupted process, not against a power cut.

* :func:`atomic_path` -- a temporary path to hand to writers that take a path (``savefig``).
* :func:`atomic_open` -- a temporary file object (``np.savez``, ``np.savetxt``, ``json.dump``).
* :func:`atomic_write_text`, :func:`atomic_write_bytes`, :func:`read_text` (missing/unreadable: one line).
* :func:`write_tum`, :func:`read_tum` -- TUM trajectories (``t x y z qx qy qz qw``), so
  ``evo_ape tum ground_truth.tum ratslam.tum -a`` works on a run directory.
* :func:`write_json`, :func:`read_json` -- JSON with numpy scalars and arrays as plain values.
"""

from __future__ import annotations

import json
import os
import tempfile
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

import numpy as np

__all__ = [
    "atomic_open",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "read_json",
    "read_text",
    "read_tum",
    "write_json",
    "write_tum",
]


@contextmanager
def atomic_path(path) -> Iterator[Path]:
    """Yield a temporary path next to ``path`` (same suffix, so writers that infer the format
    from it still do); when the block ends normally it is moved onto ``path``, on an exception
    it is removed. The parent directory is created if needed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}", dir=path.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        _publish(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


@contextmanager
def atomic_open(path, mode: str = "w") -> Iterator[IO[Any]]:
    """Yield a file opened with ``mode`` ("w" or "wb") on a temporary path; it is closed and
    moved onto ``path`` when the block ends normally, removed on an exception."""
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open: mode must be 'w' or 'wb', got {mode!r}")
    with atomic_path(path) as tmp, open(tmp, mode) as f:
        yield f


def _publish(tmp: Path, path: Path) -> None:
    """Move a finished temporary file onto ``path`` with the usual permissions (``mkstemp``
    creates files readable only by their owner)."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    os.replace(tmp, path)


def atomic_write_text(path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically. Returns ``path``."""
    with atomic_open(path, "w") as f:
        f.write(text)
    return Path(path)


def atomic_write_bytes(path, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically. Returns ``path``."""
    with atomic_open(path, "wb") as f:
        f.write(data)
    return Path(path)


def read_text(path, error: type[Exception] = OSError) -> str:
    """A text file's contents; a missing or unreadable file raises ``error`` with one line
    naming the file and the problem."""
    path = Path(path)
    try:
        return path.read_text()
    except FileNotFoundError:
        raise error(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError) as e:
        raise error(f"{path}: cannot be read ({e})") from None


# --------------------------------------------------------------------------------------- TUM
_TUM_ROW = "%.6f %.6f %.6f %.0f %.0f %.0f %.9f %.9f\n"


def write_tum(path, t, x, y, theta) -> Path:
    """Write a TUM trajectory (``t x y z qx qy qz qw`` per line, z = 0, rotation θ about z).

    Atomic (see the module). Times and positions are written with 6 decimals (µs, µm), the
    quaternion with 9.
    """
    t, x, y, theta = (np.asarray(a, dtype=float).ravel() for a in (t, x, y, theta))
    if not (len(t) == len(x) == len(y) == len(theta)):
        raise ValueError(
            f"write_tum: t, x, y, theta have different lengths ({len(t)}, {len(x)}, {len(y)}, {len(theta)})"
        )
    zero = np.zeros_like(t)
    data = np.column_stack([t, x, y, zero, zero, zero, np.sin(theta / 2), np.cos(theta / 2)])
    with atomic_open(path, "w") as fh:
        fh.write("# timestamp x y z qx qy qz qw\n")
        fh.write((_TUM_ROW * len(data)) % tuple(data.ravel().tolist()))  # np.savetxt's lines, at once
    return Path(path)


def read_tum(path) -> tuple[np.ndarray, np.ndarray]:
    """Read a TUM trajectory: ``(t (N,), poses (N, 3) x, y, θ)``; θ is the quaternion's yaw.

    Lines starting with ``#`` and blank lines are skipped; a malformed file raises
    ``ValueError`` naming the file and the problem.
    """
    path = Path(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # an empty trajectory is handled below
            data = np.loadtxt(path, comments="#", dtype=float, ndmin=2)
    except ValueError as e:
        raise ValueError(f"{path}: not a TUM trajectory ({e})") from None
    if data.size == 0:
        return np.zeros(0), np.zeros((0, 3))
    if data.shape[1] != 8:
        raise ValueError(f"{path}: TUM lines need 8 columns (t x y z qx qy qz qw), found {data.shape[1]}")
    qx, qy, qz, qw = data[:, 4:8].T
    yaw = np.arctan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy**2 + qz**2))
    return data[:, 0].copy(), np.column_stack([data[:, 1], data[:, 2], yaw])


# -------------------------------------------------------------------------------------- JSON
def _json_default(o):
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, np.bool_):
        return bool(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (tuple, set)):
        return list(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def write_json(path, data) -> Path:
    """Write ``data`` as indented JSON (numpy scalars and arrays as plain numbers and lists;
    NaN and infinities as JSON's ``NaN``/``Infinity``) atomically. Returns ``path``."""
    return atomic_write_text(path, json.dumps(data, indent=2, default=_json_default, allow_nan=True) + "\n")


def read_json(path):
    """The JSON value stored in ``path``."""
    return json.loads(Path(path).read_text())
