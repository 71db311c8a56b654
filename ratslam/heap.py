"""Keep freed memory in the process's heap, so that arrays made and dropped every tick reuse it.

Each tick the pose cells' kernels make and drop arrays of tens to hundreds of kilobytes (one per
linear operator applied to a box of activity). glibc's allocator, left to its defaults, maps an
array above its threshold (128 KiB at first) straight from the kernel and unmaps it when freed,
and it gives the top of the heap back to the kernel as soon as more than twice that threshold
lies free there; the next tick's arrays then touch fresh pages, one page fault each.
:func:`retain_freed_memory` raises both bounds, once per process: arrays below ``mmap_threshold``
come from the heap, and ``top_pad`` bytes stay at its top when it shrinks. The values computed are
unchanged (the same operations on the same numbers); only where the arrays live and how often the
kernel is asked for pages.

It changes nothing where the C library is not glibc, or where the user tuned glibc's allocator
(``MALLOC_TOP_PAD_``, ``MALLOC_MMAP_THRESHOLD_``, ``MALLOC_TRIM_THRESHOLD_``, ``MALLOC_MMAP_MAX_``
or ``glibc.malloc`` tunables in ``GLIBC_TUNABLES``: theirs stand).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys

MIB = 1 << 20
# glibc's mallopt parameters (malloc.h)
_M_TOP_PAD = -2
_M_MMAP_THRESHOLD = -3

_USER_TUNING = ("MALLOC_TOP_PAD_", "MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "MALLOC_MMAP_MAX_")

_done = False


def retain_freed_memory(mmap_threshold: int = 32 * MIB, top_pad: int = 32 * MIB) -> bool:
    """Set glibc's mmap threshold and top pad for this process (module doc), the first time it is
    called. Returns whether the allocator took both settings (False off glibc, when the user's own
    tuning stands, or on a later call)."""
    global _done
    if _done:
        return False
    _done = True
    tuned = any(k in os.environ for k in _USER_TUNING) or "glibc.malloc" in os.environ.get("GLIBC_TUNABLES", "")
    if not sys.platform.startswith("linux") or tuned:
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.gnu_get_libc_version  # noqa: B018 (glibc only: musl's mallopt does nothing)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, mmap_threshold)) and bool(mallopt(_M_TOP_PAD, top_pad))
