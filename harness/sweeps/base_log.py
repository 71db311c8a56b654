"""A real odometry log as a sweep's base: read once, its place labels synthesised per condition.

The base is a shipped CMU Plaza data set (``"plaza1"``, ``"plaza2"``, :mod:`worlds.real_data`) or
a user's observation log with ground truth (:class:`worlds.ObservationLog`, as ``replay`` reads
it; a TUM trajectory with labels is first made one with ``ratslam-harness import tum``). The
recorded odometry is kept as it is; the labels are drawn again from the ground truth by the
simulator's scene model (:func:`worlds.real_data.labelled_log`), so only the place-label
conditions vary. The systems see the odometry and the labels, never the ground truth.
"""

from __future__ import annotations

import functools

import numpy as np

from worlds import ObservationLog
from worlds.real_data import PLAZA_SETS, RealDataError, labelled_log, load_plaza
from worlds.world import SceneSpec


@functools.lru_cache(maxsize=4)
def read_base_log(source: str, duration: float | None = None) -> ObservationLog:
    """The log ``source`` (a Plaza set's name or an observation log file), its first ``duration``
    seconds (None: all), read once per process (a sweep's runs share it; never modified: each run
    relabels a copy); one-line error if it cannot be read or has no ground truth."""
    if source.lower() in PLAZA_SETS:
        return load_plaza(source, duration=duration)
    log = ObservationLog.read_csv(source)
    if log.gt_x is None or log.gt_y is None or log.gt_theta is None:
        raise RealDataError(
            f"{source}: gt_x, gt_y, gt_theta: missing; place labels are synthesised from the ground truth"
        )
    if duration is not None:
        keep = np.cumsum(log.dt) <= duration + 1e-9
        if keep.sum() < 2:
            raise RealDataError(f"{source}: duration {duration:g} s keeps {int(keep.sum())} ticks; 2 are needed")
        log = log.ticks(0, int(keep.sum()))
    return log


def relabelled(log: ObservationLog, scenes: SceneSpec, seed: int) -> ObservationLog:
    """``log``'s odometry and ground truth with place labels synthesised by ``scenes`` (flicker
    and false positives drawn with ``seed``)."""
    return labelled_log(log.t, log.dt, log.v_trans, log.v_rot, log.gt_x, log.gt_y, log.gt_theta, scenes, seed)
