"""Loop-closure candidates from repeated scene numbers.

A keyframe carries the scene number seen on its tick (-1, "nothing
recognisable", is never a scene).  When a new keyframe's scene number was seen
at earlier keyframes, those earlier keyframes are candidates for a closure,
except the ones the robot left less than ``closure_min_travel`` metres of
odometric path ago (the same visit, already tied by odometry).  The most recent
``closure_candidate_window`` sightings are ranked by their distance to the new
keyframe in the current estimate and the nearest ``closure_max_candidates`` are
linked (ties go to the earlier keyframe).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import math


class SceneIndex:
    """Scene number -> keyframes that saw it, in creation order."""

    def __init__(self, min_travel: float, max_candidates: int, window: int, tolerance: float = 0.0) -> None:
        self._tolerance = tolerance
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
        eligible = [i for i in seen[-self._window:] if path_length[i] <= limit]
        if not eligible:
            return []
        nx, ny = new_xy
        ranked = []
        for i in eligible:
            x, y = estimate_xy(i)
            ranked.append((math.hypot(x - nx, y - ny), i))
        ranked.sort()
        if self._tolerance > 0.0:
            # Sightings about as near as the nearest: prefer the most recent.
            limit_d = ranked[0][0] + self._tolerance
            near = sorted((i for d, i in ranked if d <= limit_d), reverse=True)
            far = [i for d, i in ranked if d > limit_d]
            return (near + far)[: self._max_candidates]
        return [i for _, i in ranked[: self._max_candidates]]
