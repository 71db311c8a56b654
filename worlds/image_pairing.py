"""Which image each odometry tick gets, for every image importer (an image folder, a bag's image
topic, a video's frames): the one pairing rule.

Each tick gets the latest image taken at or before its time (an image up to ``slack`` seconds
after the tick counts as at it: time stamps rounded to microseconds, or a container's frame times
rounded to its time base). The log keeps the ticks the images cover: from the first tick with an
image at or before it, to the last one no later than the last image plus twice the larger of the
median image interval and the median tick (a camera that started later or stopped earlier than
the odometry); the ticks outside are dropped, not paired with a stale image.

:func:`images_per_tick` then reads a stream of images once, in order, converting only the images
some tick uses and holding each only until its last tick has had it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from .observation_log import ObservationLog

T = TypeVar("T")


@dataclass(frozen=True)
class TickPairing:
    """``latest``: per tick, the index of its image (-1 before the first); the log keeps the ticks
    ``first:end``, each with image ``latest[first:end]``."""

    latest: np.ndarray
    first: int
    end: int

    @property
    def images(self) -> np.ndarray:
        """The image index of each kept tick."""
        return self.latest[self.first : self.end]

    def dropped(self) -> tuple[int, int]:
        """The ticks dropped before the first image and after the last."""
        return self.first, len(self.latest) - self.end

    def kept(self, odometry: ObservationLog) -> ObservationLog:
        """The ticks ``first:end`` of ``odometry`` (one row a tick of the pairing), every column."""
        return odometry.ticks(self.first, self.end)


def pair_ticks(image_t: np.ndarray, tick_t: np.ndarray, dt: np.ndarray, slack: float = 1e-6) -> TickPairing:
    """Pair ticks (times ``tick_t``, lengths ``dt``) with images (times ``image_t``, in order):
    the module's rule."""
    image_t, tick_t = np.asarray(image_t, dtype=np.float64), np.asarray(tick_t, dtype=np.float64)
    latest = np.searchsorted(image_t, tick_t + slack, side="right") - 1
    first = int(np.searchsorted(latest, 0))  # non-decreasing: ticks before the first image have -1
    interval = float(np.median(np.diff(image_t))) if len(image_t) > 1 else 0.0
    reach = image_t[-1] + 2.0 * max(interval, float(np.median(dt)) if len(dt) else 0.0)
    end = int(np.searchsorted(tick_t, reach, side="right"))
    return TickPairing(latest, first, max(first, end))


def images_per_tick(
    stream: Iterable[T],
    picks: np.ndarray,
    convert: Callable[[int, T], np.ndarray],
    ended: Callable[[int, int], Exception],
) -> Iterator[np.ndarray]:
    """Per tick, ``convert(k, item)`` of item ``picks[tick]`` of ``stream`` (items numbered from 0
    in the stream's order), reading the stream once and no further than the last item needed;
    consecutive ticks with one item get the same array (:func:`worlds.image_log.write_image_log`
    writes it once). A stream that ends before an item needed raises ``ended(item, items read)``."""
    picks = np.asarray(picks)
    last_use = {int(m): i for i, m in enumerate(picks.tolist())}
    held: dict[int, np.ndarray] = {}
    i, n, read = 0, len(picks), 0
    if n == 0:
        return
    for k, item in enumerate(stream):
        read = k + 1
        if k in last_use:
            held[k] = convert(k, item)
        while i < n and int(picks[i]) in held:
            m = int(picks[i])
            yield held[m]
            if last_use[m] == i:
                del held[m]
            i += 1
        if i == n:
            return
    raise ended(int(picks[i]), read)
