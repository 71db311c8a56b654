"""Loop-closure candidates from repeated scene numbers.

A keyframe carries the scene number seen on its tick (-1, "nothing
recognisable", is never a scene).  When a new keyframe's scene number was seen
at earlier keyframes, those earlier keyframes are candidates for a closure,
except the ones the robot left less than ``closures.min_travel_m`` metres of
odometric path ago (the same visit, already tied by odometry).  The most recent
``closures.candidate_window`` sightings are ranked by their distance to the new
keyframe in the current estimate and the nearest ``closures.max_candidates`` are
linked (ties go to the earlier keyframe).  Optionally, sightings within a
tolerance of the nearest count as equally near and the most recent
(``closures.recent_tolerance_m``) or the earliest (``closures.early_tolerance_m``) of
them is linked (a positive ``closures.recent_tolerance_m`` takes precedence); when
preferring the earliest, the window holds the earliest
half-window and the most recent half-window of sightings.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence


class SceneIndex:
    """Scene number -> keyframes that saw it, in creation order."""

    def __init__(
        self, min_travel: float, max_candidates: int, window: int, tolerance: float = 0.0, early_tolerance: float = 0.0
    ) -> None:
        self._tolerance = tolerance
        self._early_tolerance = early_tolerance
        self._min_travel = min_travel
        self._max_candidates = max_candidates
        self._window = window
        self._sightings: dict[int, list[int]] = {}

    def add(self, scene_id: int, keyframe: int) -> None:
        """Record that ``keyframe`` saw ``scene_id`` (ignored for -1)."""
        if scene_id != -1:
            self._sightings.setdefault(scene_id, []).append(keyframe)

    def candidates(
        self,
        scene_id: int,
        path_length: Sequence[float],
        new_path: float,
        new_xy: tuple[float, float],
        estimate_xy: Callable[[int], tuple[float, float]],
    ) -> list[int]:
        """Earlier keyframes to close a loop with, nearest first.

        ``path_length[i]`` is the odometric path length at keyframe i,
        ``new_path``/``new_xy`` those of the new keyframe, ``estimate_xy(i)`` the
        current estimate of keyframe i's position.
        """
        if scene_id == -1:
            return []
        seen = self._sightings.get(scene_id)
        if not seen:
            return []
        limit = new_path - self._min_travel
        early = self._early_tolerance > 0.0 and self._tolerance <= 0.0  # recent takes precedence
        if early and len(seen) > self._window:
            # Earliest-preferring: rank the earliest sightings (what the map is anchored
            # to) and the most recent ones, half the window each.
            half = self._window // 2
            pool = seen[:half] + seen[-(self._window - half) :]
        else:
            pool = seen[-self._window :]
        eligible = [i for i in pool if path_length[i] <= limit]
        if not eligible:
            return []
        nx, ny = new_xy
        ranked = []
        for i in eligible:
            x, y = estimate_xy(i)
            ranked.append((math.hypot(x - nx, y - ny), i))
        ranked.sort()
        if self._tolerance > 0.0 or early:
            # Sightings about as near as the nearest count as equally near: prefer the
            # most recent (``tolerance``) or the earliest (``early_tolerance``) of them.
            recent = self._tolerance > 0.0
            limit_d = ranked[0][0] + (self._tolerance if recent else self._early_tolerance)
            near = sorted((i for d, i in ranked if d <= limit_d), reverse=recent)
            far = [i for d, i in ranked if d > limit_d]
            return (near + far)[: self._max_candidates]
        return [i for _, i in ranked[: self._max_candidates]]


class ClosureChains:
    """Consecutive closures between the same two passages, counted as one chain.

    A closure (i, j) -- earlier keyframe i, new keyframe j -- continues a chain when the chain's
    last closure (i', j') has 0 < j - j' <= ``gap`` and |i - i'| <= ``gap`` + (j - j'): both
    passages moved on by about as many keyframes.  Such closures share the offset between the two
    passages; with a share ``correlation`` (rho) of each closure's variance common to its chain,
    the k-th closure of a chain is given the variance sigma^2 (1 + (k - 1) rho): a chain of n
    equicorrelated closures tells what its mean tells, variance sigma^2 (1 + (n - 1) rho) / n.
    Each closure is weighed when it is added, knowing only its place in the chain so far, so a
    chain's total weight grows with n (as log n for large n) rather than staying at its mean's: less
    than n independent closures, somewhat more than their mean.  rho = 0: every closure
    independent, scale 1.
    """

    def __init__(self, correlation: float, gap: int) -> None:
        self._rho = correlation
        self._gap = gap
        self._tails: list[list[int]] = []  # [i, j, closures so far] of chains still open

    def scale(self, i: int, j: int) -> float:
        """Sigma multiplier of the new closure (i, j): sqrt(1 + (k - 1) rho), k its place in its chain."""
        if self._rho <= 0.0:
            return 1.0
        gap = self._gap
        self._tails = [t for t in self._tails if j - t[1] <= gap]
        chain = next((t for t in self._tails if j > t[1] and abs(i - t[0]) <= gap + (j - t[1])), None)
        if chain is None:
            chain = [i, j, 0]
            self._tails.append(chain)
        chain[0], chain[1], chain[2] = i, j, chain[2] + 1
        return math.sqrt(1.0 + (chain[2] - 1) * self._rho)
