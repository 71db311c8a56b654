"""The yaw-rate bias correction (``yaw_bias.search``, on by default; not in the paper).

The search (:mod:`slamkit.yaw_bias`, shared with the pose graph) finds a constant yaw-rate
(gyro) bias from revisited scene numbers. :class:`YawBiasCorrection` runs it on RatSLAM's
stream (:class:`ratslam.front_end.FrontEnd`) and, once it adopts a bias, the bias is taken off
every later tick's yaw rate and out of what was built so far: by a rebuild (``yaw_bias.rebuild``,
the default: the system stepped again from its first tick, :class:`ratslam.pipeline.RatSLAM`) or,
without one, out of the experience map's transitions (:func:`remove_yaw_bias`, acting on the
map's arrays; the pose cells and view cells keep the places where the biased odometry laid them).
Without either the transitions each carry the bias's turn and the relaxation (eqs 12-14) cannot
take it out.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy.sparse import coo_matrix, identity
from scipy.sparse.linalg import factorized

from slamkit.poses import wrap_angle
from slamkit.yaw_bias import YawBiasSearch

from .config import RatSLAMConfig

if TYPE_CHECKING:
    from .experience_map import ExperienceMap


def bias_search(config: RatSLAMConfig) -> YawBiasSearch:
    """The yaw-rate bias search of ``config.yaw_bias``: revisits scored with its ``revisit_*``
    fields (how far apart, how well a scene places the robot)."""
    yb = config.yaw_bias
    return yb.bias_search(yb.revisit_min_travel_m, yb.revisit_sigma_xy_m, math.radians(yb.revisit_sigma_heading_deg))


class YawBiasCorrection:
    """The search of ``config.yaw_bias`` (none with ``search`` off: the paper's odometry as it
    comes), which says when it adopts a bias (:meth:`adopt`)."""

    def __init__(self, config: RatSLAMConfig):
        self.config = config
        self.search = bias_search(config) if config.yaw_bias.search else None

    @property
    def bias(self) -> float:
        """The yaw-rate bias (rad/s) taken off the odometry: 0 until the search adopts one."""
        return self.search.bias if self.search is not None else 0.0

    def adopt(self, dt: float, v_trans: float, v_rot: float, scene_id: int) -> tuple[float, bool] | None:
        """Feed one tick to the search. When it adopts a new bias: ``(change, settle_map)``, the
        bias's change (rad/s) and whether the map is to be solved to its fixed point afterwards
        (the change turns it by more than ``yaw_bias.settle_turn_deg`` over its span so far);
        otherwise None. The tick's yaw rate less :attr:`bias` is what the system steps."""
        search = self.search
        if search is None:
            return None
        before = search.bias
        if search.add(dt, v_trans, v_rot, scene_id) is None:
            return None
        change = search.bias - before
        elapsed = search.time - dt  # the map's span before this tick
        return change, abs(change) * elapsed > math.radians(self.config.yaw_bias.settle_turn_deg)

    def get_state(self) -> dict:
        """The search's arrays (its adopted bias among them); none with the search off."""
        return self.search.get_state() if self.search is not None else {}

    def set_state(self, s: dict) -> None:
        """Restore :meth:`get_state`'s arrays (a state saved without them: the search afresh)."""
        if self.search is not None and "yb_scalars" in s:
            self.search.set_state(s)


def remove_yaw_bias(em: ExperienceMap, change: float, settle_map: bool = True) -> None:
    """The odometry's yaw rate was found to carry ``change`` rad/s more bias than assumed so
    far (:mod:`slamkit.yaw_bias`); the caller feeds the corrected rate from now on. Every
    transition of ``em`` loses the bias's turn over its elapsed time dt_ij: φ_ij by change·dt_ij,
    the bearing θ_ij by half that (the path turned gradually). With ``settle_map`` (a change that
    turns the map by a lot over its span: the turn grows along the whole map, which the per-tick
    correction, eqs 12-14, a local relaxation, takes thousands of passes to spread) the
    correction is solved to its fixed point at once (:func:`settle`). The re-entries' innovation
    statistics start afresh: they measured the biased odometry."""
    turn = change * em.link_column("dt")
    phi, theta = em.link_column("phi"), em.link_column("theta")
    phi -= turn
    theta -= 0.5 * turn
    if settle_map:
        turn_along_creation(em, turn)
        settle(em)
    em.reentry.restart_innovations()


def turn_along_creation(em: ExperienceMap, turn: np.ndarray) -> None:
    """Turn every experience's heading by the transitions' heading corrections ``turn``
    (one per link) summed along the links that created the experiences, the current
    experience held: a start for :func:`settle` within a fraction of a turn of its solution
    even where the bias turned the map by more than half a turn between two visits of a
    place (the settle's residuals are wrapped about the current headings: a loop closure
    whose residual had grown past half a turn was closed the wrong way round)."""
    n = em.size
    f, t = em.link_column("from"), em.link_column("to")
    m = len(f)
    delta = np.zeros(n)
    placed = np.zeros(n, dtype=bool)
    for k in range(m):  # the first link to reach an experience created it (eqs 10-11) ...
        placed[f[k]] = True  # ... unless it left it first (the first experience: a root)
        j = t[k]
        if not placed[j]:
            placed[j] = True
            delta[j] = delta[f[k]] - turn[k]
    anchor = em.current if em.current >= 0 else 0
    th = em.experience_column("th")
    th[:] = wrap_angle(th + delta - delta[anchor])


def settle(em: ExperienceMap, heading_passes: int = 3) -> None:
    """The map correction (eqs 12-14, ``correction="stable"``) run to its fixed point, solved
    directly. At the fixed point every experience's link residuals sum to zero: the normal
    equations of least squares over the links, first for the headings (eq 12 does not
    involve the positions; residuals wrapped about the current headings, re-linearised
    ``heading_passes`` times), then for the positions given the headings (eqs 13-14 are
    linear in them). The current experience stays where it is (the residuals fix the map only
    up to a rigid motion), so the robot's pose does not jump."""
    n = em.size
    f, t = em.link_column("from"), em.link_column("to")
    m = len(f)
    if n < 2 or m == 0:
        return
    rows = np.arange(m)
    inc = coo_matrix((np.r_[np.ones(m), -np.ones(m)], (np.r_[rows, rows], np.r_[t, f])), shape=(m, n)).tocsr()
    anchor = em.current if em.current >= 0 else 0
    free = np.flatnonzero(np.arange(n) != anchor)
    a = inc[:, free]
    normal = (a.T @ a).tocsc() + 1e-12 * identity(len(free), format="csc")  # a map in pieces stays solvable
    solve = factorized(normal)
    th = em.experience_column("th")
    phi, theta, d = em.link_column("phi"), em.link_column("theta"), em.link_column("d")
    for _ in range(heading_passes):
        r = wrap_angle(th[t] - th[f] - phi)
        th[free] -= solve(a.T @ r)
    ang = th[f] + theta
    for col, step in (("x", d * np.cos(ang)), ("y", d * np.sin(ang))):
        p = em.experience_column(col)
        r = p[t] - p[f] - step
        p[free] -= solve(a.T @ r)
