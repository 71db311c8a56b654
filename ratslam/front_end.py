"""RatSLAM's front end: what the stream alone drives, which several systems may share.

Each tick the yaw-rate bias search (:mod:`ratslam.yaw_bias_correction`) takes the odometry, the
scene's view cell injects energy into the pose cells, the pose cells iterate and path-integrate,
and the view cell learns (the first half of :meth:`ratslam.RatSLAM.step`). None of it reads the
experience map, so RatSLAMs whose configurations agree on the sections it reads
(:func:`front_end_key`) compute the same front end tick for tick; stepped on one stream they can
share one :class:`FrontEnd` (:func:`shared_front_ends`): the first to take a tick advances it, the
others read its outputs and step only their own view gate and experience map. The values are the
same bit for bit; the work of the pose cells and view cells is done once.

When the search adopts a bias and the system rebuilds (``yaw_bias.rebuild``), the front end
replays every tick kept with the bias taken off and keeps each replayed tick's outputs
(:class:`Rebuild`), from which each system sharing it replays its own map.
"""

from __future__ import annotations

import contextlib
import copy
import math
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .columns import Growable
from .config import RatSLAMConfig
from .local_view import LocalView
from .pose_cells import PoseCells
from .snaps import snapped
from .yaw_bias_correction import YawBiasCorrection

if TYPE_CHECKING:
    from .pipeline import RatSLAM


def front_end_key(config: RatSLAMConfig) -> tuple:
    """The configuration sections the front end reads: systems with equal keys can share one."""
    return (config.pose_cells, config.local_view, config.yaw_bias)


def _input_columns() -> Growable:
    """Each tick's inputs as stepped (the yaw rate as logged, before any bias is taken off)."""
    return Growable(
        {
            "dt": ((), float),
            "v_trans": ((), float),
            "v_rot": ((), float),
            "scene": ((), np.int64),
            "rotation": ((), float),
        }
    )


class Output(NamedTuple):
    """What the front end hands the experience map for one tick: the yaw rate with the bias found
    so far taken off, the pose-cell peak after the tick and whether it snapped."""

    v_rot: float
    peak: np.ndarray
    snapped: bool


@dataclass(frozen=True)
class Adoption:
    """The search adopted a yaw-rate bias: ``change`` rad/s more than before, ``settle_map``
    whether the map is to be solved to its fixed point (a change that turns it by a lot over its
    span), ``rebuilt`` whether the front end replayed the ticks before it (``yaw_bias.rebuild``;
    the replay is :attr:`FrontEnd.replay` during that tick)."""

    change: float
    settle_map: bool
    rebuilt: bool


@dataclass(frozen=True)
class Rebuild:
    """The front end's replay of ticks ``0 .. n - 1`` after an adopted bias: each tick's
    :class:`Output`, for the experience maps to replay from (with the first ``n`` ticks of
    :attr:`FrontEnd.history`, the inputs)."""

    v_rot: np.ndarray  # (n,)
    peak: np.ndarray  # (n, 3)
    snapped: np.ndarray  # (n,) bool


class FrontEnd:
    """The yaw-rate bias search, the view cells and the pose cells of one configuration (module
    doc), with the ticks kept for a rebuild."""

    def __init__(self, config: RatSLAMConfig):
        self.config = config
        self._bias = math.radians(config.pose_cells.path_integration_bias_deg_s)
        self._grid = tuple(float(v) for v in config.shape)
        self.yaw_bias = YawBiasCorrection(config)
        yb = config.yaw_bias
        # the ticks taken, kept while a rebuild may need them
        self.history = _input_columns() if yb.search and yb.rebuild else None
        self.adoptions: list[Adoption] = []
        """Every bias the search adopted, in order (systems sharing the front end each act on them)."""
        self.replay: Rebuild | None = None
        """The latest tick's rebuild (None if that tick adopted no bias or rebuilt nothing)."""
        self._reset_network()
        self.inputs: tuple | None = None  # the latest tick's, as given to :meth:`advance`
        self.output: Output | None = None  # and what it gave
        self.seconds = 0.0
        """Wall time of the latest :meth:`advance` (a rebuild's replay included)."""

    def _reset_network(self) -> None:
        """Fresh pose cells and view cells at tick 0."""
        self.pose_cells = PoseCells(self.config)
        self.local_view = LocalView(self.config)
        self.tick = 0
        self.snapped = False

    def advance(self, dt: float, v_trans: float, v_rot: float, scene_id: int, view_rotation: float) -> Output:
        """Take the next tick (inputs checked by the caller): the search first (an adopted bias is
        recorded in :attr:`adoptions`, after the replay of a rebuild), then the tick through the
        view cells and pose cells with the bias found so far taken off the yaw rate."""
        t0 = time.perf_counter()
        self.inputs = (dt, v_trans, v_rot, scene_id, view_rotation)
        self.replay = None
        adopted = self.yaw_bias.adopt(dt, v_trans, v_rot, scene_id)
        if adopted is not None:
            change, settle_map = adopted
            if self.history is not None:
                self.replay = self._rebuild(self.yaw_bias.bias)
            self.adoptions.append(Adoption(change, settle_map, self.replay is not None))
        unbiased = v_rot - self.yaw_bias.bias
        if self.history is not None:
            self.history.append(dt=dt, v_trans=v_trans, v_rot=v_rot, scene=scene_id, rotation=view_rotation)
        self.output = self._step(dt, v_trans, unbiased, scene_id, view_rotation)
        self.seconds = time.perf_counter() - t0
        return self.output

    def _step(self, dt: float, v_trans: float, v_rot: float, scene_id: int, view_rotation: float) -> Output:
        """One tick through the view cells and pose cells, ``v_rot`` the yaw rate with the bias
        found so far taken off."""
        pc, k = self.pose_cells, self.tick
        old_peak = pc.peak
        self.local_view.inject(scene_id, k, pc, view_rotation)
        pc.step(v_trans * dt, (v_rot + self._bias) * dt)
        self.local_view.learn(k, pc)
        new_peak = pc.peak
        self.snapped = snapped(old_peak, new_peak, self._grid, self.config.pose_cells.snap_threshold_cells)
        self.tick = k + 1
        return Output(v_rot, new_peak, self.snapped)

    def _rebuild(self, bias: float) -> Rebuild:
        """Fresh pose cells and view cells stepped through every tick so far with ``bias`` (rad/s)
        taken off the yaw rate, as if it had been known from the first tick."""
        assert self.history is not None
        self._reset_network()
        h = self.history
        n = h.n
        peaks, snaps, rates = np.zeros((n, 3)), np.zeros(n, dtype=bool), np.zeros(n)
        rows = zip(*(h.view(k).tolist() for k in ("dt", "v_trans", "v_rot", "scene", "rotation")))
        for k, (dt, v, w, scene, rotation) in enumerate(rows):
            out = self._step(dt, v, w - bias, scene, rotation)
            rates[k], peaks[k], snaps[k] = out.v_rot, out.peak, out.snapped
        return Rebuild(rates, peaks, snaps)

    # ------------------------------------------------------------------ persistence
    def get_state(self) -> dict[str, np.ndarray]:
        """The pose cells', view cells' and search's arrays and the ticks kept."""
        arrays = {**self.pose_cells.get_state(), **self.local_view.get_state(), **self.yaw_bias.get_state()}
        if self.history is not None:
            arrays.update(self.history.state("rs_history_"))
        return arrays

    def set_state(self, s: dict[str, np.ndarray], tick: int, snapped_now: bool) -> None:
        """Restore :meth:`get_state`'s arrays at step count ``tick``."""
        self.pose_cells.set_state(s)
        self.local_view.set_state(s)
        self.yaw_bias.set_state(s)
        if self.history is not None:
            self.history.load_state(s, "rs_history_")
        self.tick, self.snapped = tick, snapped_now


def _same_state(a: FrontEnd, b: FrontEnd) -> bool:
    """Whether two front ends hold the same arrays (both fresh, or set alike before stepping)."""
    x, y = a.get_state(), b.get_state()
    return x.keys() == y.keys() and all(np.array_equal(x[k], y[k]) for k in x)


@contextlib.contextmanager
def shared_front_ends(systems: Iterable[RatSLAM]) -> Iterator[list[RatSLAM]]:
    """While the block runs, the systems that have not stepped yet, whose configurations agree on
    the front end (:func:`front_end_key`) and whose front ends hold the same state share one; they
    must then step the same ticks. Yields the systems that read another's front end. On leaving,
    each of those gets a copy of its own back, so that it can be stepped on alone."""
    leaders: dict[tuple, list[RatSLAM]] = {}
    followers = []
    for system in systems:
        if system.tick != 0:
            continue
        group = leaders.setdefault(front_end_key(system.config), [])
        leader = next((s for s in group if _same_state(s.front_end, system.front_end)), None)
        if leader is None:
            group.append(system)
        elif leader is not system:
            system.front_end = leader.front_end
            followers.append(system)
    try:
        yield followers
    finally:
        for system in followers:
            own = copy.deepcopy(system.front_end)
            own.config = own.yaw_bias.config = own.pose_cells.config = own.local_view.config = system.config
            system.front_end = own
