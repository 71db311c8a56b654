"""Relocalisation on a fixed experience map from a sequence of scene onsets (not in the paper).

A filter that tracks the robot's pose on a map by gating scene matches around its prediction is
lost for good once its prediction drifts farther than the gate: every scene that would correct it
is refused. What tells a lost robot where it is, is the *sequence* of scenes it has seen, laid out
as its own odometry says they were (as sequence-based place recognition does, e.g. SeqSLAM): one
scene number is ambiguous (aliasing, look-alike rooms), a dozen at the right distances from each
other are not.

:class:`OnsetWindow` keeps the latest scene onsets whose view the map knows, with the dead-reckoned
pose (the odometry integrated alone, in its own frame) at each. A hypothesis is a rigid transform
from that frame into the map's; its *support* is how many onsets of the window it puts within
``inlier_m`` of an experience of the same view facing the same way (within 90 deg: a scene number
is seen from one heading sector). :func:`best_alignment` draws hypotheses from pairs of onsets
(the latest and an earlier one) matched to pairs of experiences of their views a like distance
apart, scores them all, refines the best on its inliers (least squares, 2-D Procrustes) and
reports its support with that of the best hypothesis placing the robot elsewhere, so that a caller
can refuse an ambiguous answer.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace

import numpy as np

from .experience_map import wrap_angle

SAME_SECTOR_RAD = math.pi / 2  # a scene number is seen facing within one of 4 heading sectors


@dataclass(frozen=True)
class Alignment:
    """A rigid transform from the dead-reckoning frame into the map's (``p_map = R(phi) p + t``)
    and how many onsets of the window it explains."""

    phi: float
    t: tuple[float, float]
    support: int
    spread_m2: float = 0.0
    """Sum of the squared distances of the inliers it was fitted on from their centroid (0: not
    fitted): how well the onsets fix its rotation (:meth:`heading_sigma`)."""

    def apply(self, pose) -> np.ndarray:
        """The dead-reckoned ``pose`` (x, y, θ) in the map's frame."""
        c, s = math.cos(self.phi), math.sin(self.phi)
        x, y, th = pose
        return np.array([c * x - s * y + self.t[0], s * x + c * y + self.t[1], wrap_angle(th + self.phi)])

    def heading_sigma(self, position_sigma_m: float) -> float:
        """First-order standard error (rad) of :attr:`phi` for inliers each placed within
        ``position_sigma_m`` per axis: sigma / sqrt(spread). Onsets bunched in a few metres (a
        robot going to and fro) leave the rotation loose; inf if not fitted."""
        return position_sigma_m / math.sqrt(self.spread_m2) if self.spread_m2 > 0.0 else math.inf

    def as_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(phi (1,), t (1, 2)): this transform as a batch of one hypothesis."""
        return np.array([self.phi]), np.array([self.t])

    def fitted(self, src: np.ndarray, dst: np.ndarray) -> Alignment:
        """The rigid transform taking points ``src`` (K, 2) onto ``dst`` by least squares (2-D
        Procrustes), with this one's support and the spread of ``src``."""
        ms, md = src.mean(axis=0), dst.mean(axis=0)
        a, b = src - ms, dst - md
        phi = math.atan2(float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])), float(np.sum(a * b)))
        c, s = math.cos(phi), math.sin(phi)
        t = md - np.array([c * ms[0] - s * ms[1], s * ms[0] + c * ms[1]])
        return Alignment(phi, (float(t[0]), float(t[1])), self.support, float(np.sum(a * a)))

    @classmethod
    def between(cls, map_pose, dr_pose, support: int = 0) -> Alignment:
        """The transform that takes dead-reckoned ``dr_pose`` onto ``map_pose``."""
        phi = float(wrap_angle(map_pose[2] - dr_pose[2]))
        c, s = math.cos(phi), math.sin(phi)
        t = (map_pose[0] - (c * dr_pose[0] - s * dr_pose[1]), map_pose[1] - (s * dr_pose[0] + c * dr_pose[1]))
        return cls(phi, t, support)


class OnsetWindow:
    """The latest ``size`` scene onsets whose view the map knows, no more than ``length_m`` of
    dead-reckoned path old: scene numbers and dead-reckoned poses."""

    def __init__(self, size: int, length_m: float):
        self.size, self.length_m = int(size), float(length_m)
        self._onsets: deque[tuple[int, float, float, float, float]] = deque(maxlen=self.size)

    def add(self, scene: int, dr_pose, path_m: float) -> None:
        """An onset of ``scene`` at dead-reckoned ``dr_pose`` after ``path_m`` m of path."""
        self._onsets.append((int(scene), float(dr_pose[0]), float(dr_pose[1]), float(dr_pose[2]), float(path_m)))
        while self._onsets and path_m - self._onsets[0][4] > self.length_m:
            self._onsets.popleft()

    def __len__(self) -> int:
        return len(self._onsets)

    @property
    def scenes(self) -> np.ndarray:
        """(N,) scene numbers, oldest first."""
        return np.array([o[0] for o in self._onsets], dtype=np.int64)

    @property
    def poses(self) -> np.ndarray:
        """(N, 3) dead-reckoned poses, oldest first."""
        return np.array([o[1:4] for o in self._onsets], dtype=float).reshape(-1, 3)


class ViewIndex:
    """The map's experiences grouped by view: which experiences each scene number may be."""

    def __init__(self, poses: np.ndarray, views: np.ndarray):
        self.poses = np.asarray(poses, dtype=float)
        order = np.argsort(views, kind="stable")
        v = np.asarray(views)[order]
        starts = np.flatnonzero(np.r_[True, v[1:] != v[:-1]]) if len(v) else np.zeros(0, dtype=np.int64)
        ends = np.r_[starts[1:], len(v)]
        self._of = {int(v[a]): order[a:b] for a, b in zip(starts, ends)}

    def of(self, scene: int) -> np.ndarray:
        """Indices of the experiences with view ``scene`` (empty if none)."""
        return self._of.get(int(scene), np.zeros(0, dtype=np.int64))


def support(phi: np.ndarray, t: np.ndarray, window: OnsetWindow, index: ViewIndex, inlier_m: float) -> np.ndarray:
    """For hypotheses (``phi`` (H,), ``t`` (H, 2)): how many onsets of ``window`` each puts within
    ``inlier_m`` of an experience of that onset's view facing the same sector."""
    c, s = np.cos(phi), np.sin(phi)
    count = np.zeros(len(phi), dtype=np.int64)
    for scene, (x, y, th) in zip(window.scenes.tolist(), window.poses):
        exp = index.poses[index.of(scene)]
        if not len(exp):
            continue
        qx, qy = c * x - s * y + t[:, 0], s * x + c * y + t[:, 1]
        near = np.hypot(qx[:, None] - exp[None, :, 0], qy[:, None] - exp[None, :, 1]) < inlier_m
        facing = np.abs(wrap_angle(th + phi[:, None] - exp[None, :, 2])) < SAME_SECTOR_RAD
        count += np.any(near & facing, axis=1)
    return count


def best_alignment(
    window: OnsetWindow, index: ViewIndex, inlier_m: float, min_baseline_m: float = 1.5, max_pairs: int = 20000
) -> tuple[Alignment, int] | None:
    """The best-supported transform of ``window`` onto the map (refined on its inliers) and the
    support of the best hypothesis that puts the robot's latest onset elsewhere (more than
    ``2 * inlier_m`` away or facing another sector); None without a hypothesis. Hypotheses: the
    latest onset and each earlier one at least ``min_baseline_m`` away (dead-reckoned), matched to
    experiences of their views whose distance apart agrees within ``2 * inlier_m``."""
    poses, scenes = window.poses, window.scenes
    if len(poses) < 2:
        return None
    last = poses[-1]
    cand_last = index.of(int(scenes[-1]))
    if not len(cand_last):
        return None
    phis, ts = [], []
    for j in range(len(poses) - 1):
        d_dr = poses[j, :2] - last[:2]
        base = math.hypot(*d_dr)
        cand = index.of(int(scenes[j]))
        if base < min_baseline_m or not len(cand):
            continue
        ea = index.poses[cand_last]
        eb = index.poses[cand]
        d_map = eb[None, :, :2] - ea[:, None, :2]  # (A, B, 2)
        ok = np.abs(np.hypot(d_map[..., 0], d_map[..., 1]) - base) < 2.0 * inlier_m
        ia, ib = np.nonzero(ok)
        if not len(ia):
            continue
        phi = wrap_angle(np.arctan2(d_map[ia, ib, 1], d_map[ia, ib, 0]) - math.atan2(d_dr[1], d_dr[0]))
        c, s = np.cos(phi), np.sin(phi)
        t = ea[ia, :2] - np.stack((c * last[0] - s * last[1], s * last[0] + c * last[1]), axis=1)
        phis.append(phi)
        ts.append(t)
        if sum(len(p) for p in phis) >= max_pairs:
            break
    if not phis:
        return None
    phi, t = np.concatenate(phis), np.concatenate(ts)
    score = support(phi, t, window, index, inlier_m)
    k = int(np.argmax(score))
    best = _refine(Alignment(float(phi[k]), (float(t[k, 0]), float(t[k, 1])), int(score[k])), window, index, inlier_m)
    # the latest onset's pose under each hypothesis, against the best's
    c, s = np.cos(phi), np.sin(phi)
    qx, qy = c * last[0] - s * last[1] + t[:, 0], s * last[0] + c * last[1] + t[:, 1]
    at = best.apply(last)
    elsewhere = (np.hypot(qx - at[0], qy - at[1]) > 2.0 * inlier_m) | (np.abs(wrap_angle(phi - best.phi)) > math.pi / 6)
    runner_up = int(score[elsewhere].max()) if np.any(elsewhere) else 0
    return best, runner_up


def _inliers(a: Alignment, window: OnsetWindow, index: ViewIndex, inlier_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The window's onsets that ``a`` places within ``inlier_m`` of an experience of their view
    facing the same sector, with the nearest such: dead-reckoned points (K, 2), experience points
    (K, 2)."""
    src, dst = [], []
    for scene, pose in zip(window.scenes.tolist(), window.poses):
        exp = index.poses[index.of(scene)]
        if not len(exp):
            continue
        q = a.apply(pose)
        d = np.hypot(exp[:, 0] - q[0], exp[:, 1] - q[1])
        d[np.abs(wrap_angle(q[2] - exp[:, 2])) >= SAME_SECTOR_RAD] = np.inf
        k = int(np.argmin(d))
        if d[k] < inlier_m:
            src.append(pose[:2])
            dst.append(exp[k, :2])
    return np.array(src).reshape(-1, 2), np.array(dst).reshape(-1, 2)


def _refine(a: Alignment, window: OnsetWindow, index: ViewIndex, inlier_m: float) -> Alignment:
    """Least-squares rigid fit of the window's inliers under ``a`` to their nearest experiences;
    kept only if it explains as many onsets."""
    src, dst = _inliers(a, window, index, inlier_m)
    if len(src) < 3:
        return a
    r = a.fitted(src, dst)
    n = int(support(*r.as_arrays(), window, index, inlier_m)[0])
    return replace(r, support=n) if n >= a.support else replace(a, spread_m2=r.spread_m2)
