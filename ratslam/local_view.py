"""Local view cells: one cell per scene number, Hebbian links to the pose cells.

* Scene ``-1`` means nothing recognisable: no view cell is active, nothing is learnt or injected.
* A view cell's activity is ``V = max(1 - fatigue, 0)``. Fatigue grows by
  ``local_view.fatigue_rate`` on every tick the scene is in view and recovers by
  ``local_view.fatigue_recovery`` on every tick it is not (capped at :data:`FATIGUE_CAP`). A scene that
  stays in view for a while therefore acts mostly at its onset; it cannot pin the packet.
* Learning (Hebbian, max form): ``β_v(c) <- max(β_v(c), λ · V · P(c))`` for the active pose cells
  ``c`` with ``P(c) >= learn_threshold · max P``.
* Injection: a familiar view adds ``δ · V · β_v(c)`` to pose cell ``c``, using only associations
  learnt at least ``min_age_ticks`` ago (a recently learnt view never drags the packet back
  to where it was just learnt).
* A view seen turned (a camera's view template matched at a horizontal shift, relative rotation
  ``r``, :mod:`ratslam.view_matcher`) is injected at the stored heading plus ``r``: every
  association's θ' is shifted by ``round(r / θ' cell)`` cells (the nearest whole cell; a view
  places the heading to within half a cell, as a cell is the pose cells' own resolution). Learning
  on that tick undoes the shift, so a view's associations stay in the frame of the heading at which
  it was first stored and a later rotation is always relative to that frame. ``r = 0`` (every
  stream of scene numbers) shifts nothing.
"""

from __future__ import annotations

import math

import numpy as np

from .config import RatSLAMConfig
from .pose_cells import PoseCells
from .view_kernels import merge_associations

FATIGUE_CAP = 2.0
"""Fatigue never exceeds this, so a view recovers within ``FATIGUE_CAP / fatigue_recovery``
ticks however long its scene was in view."""


class LocalView:
    """The local view cells and their associations with the pose cells."""

    def __init__(self, config: RatSLAMConfig):
        self.config = config
        self._scene_to_cell: dict[int, int] = {}
        self.scenes = np.zeros(0, dtype=np.int64)  # scene number of each view cell
        self.fatigue = np.zeros(0)  # per view cell
        # associations, one sorted-by-linear-index entry set per view cell
        self._assoc_lin: list[np.ndarray] = []
        self._assoc_w: list[np.ndarray] = []
        self._assoc_tick: list[np.ndarray] = []
        self.current = -1  # active view cell (-1: none)
        self.activity = 0.0  # V of the active view cell
        self.injected = 0.0  # total energy injected this tick
        self.theta_shift = 0  # θ' cells the current view is turned by (its rotation, rounded)
        n = config.shape
        self._strides = np.array([n[1] * n[2], n[2], 1], dtype=np.int64)

    def __len__(self) -> int:
        return int(self.scenes.size)

    def cell_of(self, scene_id: int) -> int:
        """View cell of a scene number, or -1 if the scene was never seen (or is -1)."""
        return self._scene_to_cell.get(int(scene_id), -1)

    def _new_cell(self, scene_id: int) -> int:
        v = len(self.scenes)
        self._scene_to_cell[int(scene_id)] = v
        self.scenes = np.append(self.scenes, np.int64(scene_id))
        self.fatigue = np.append(self.fatigue, 0.0)
        self._assoc_lin.append(np.zeros(0, dtype=np.int64))
        self._assoc_w.append(np.zeros(0))
        self._assoc_tick.append(np.zeros(0, dtype=np.int64))
        return v

    def theta_cells(self, rotation: float) -> int:
        """A relative rotation (rad) in whole θ' cells, rounded to the nearest (halves away from 0)."""
        x = rotation / self.config.pose_cells.theta_cell_rad
        return int(math.copysign(math.floor(abs(x) + 0.5), x))

    def _turned(self, lin: np.ndarray, cells: int) -> np.ndarray:
        """Linear pose-cell indices with θ' shifted by ``cells`` (wrapping)."""
        n_theta = self.config.pose_cells.n_theta
        th = lin % n_theta
        return lin - th + (th + cells) % n_theta

    def inject(self, scene_id: int, tick: int, pose_cells: PoseCells, rotation: float = 0.0) -> int:
        """Activate the view cell of ``scene_id`` (creating it if new) and, if it is familiar,
        inject energy into the pose cells, at its associations' headings plus ``rotation`` (rad:
        the view's rotation relative to its template, 0 for a scene number). Returns the active
        view cell (-1 for scene -1)."""
        cfg = self.config.local_view
        self.injected = 0.0
        self.theta_shift = self.theta_cells(rotation) if rotation != 0.0 else 0
        if scene_id < 0:
            self.current, self.activity = -1, 0.0
            return -1
        v = self.cell_of(scene_id)
        if v < 0:
            v = self._new_cell(scene_id)
        self.current = v
        self.activity = max(1.0 - float(self.fatigue[v]), 0.0)
        if self.activity > 0.0 and cfg.inject > 0.0 and self._assoc_lin[v].size:
            old = self._assoc_tick[v] <= tick - cfg.min_age_ticks
            if np.any(old):
                energy = (cfg.inject * self.activity) * self._assoc_w[v][old]
                lin = self._assoc_lin[v][old]
                if self.theta_shift:
                    lin = self._turned(lin, self.theta_shift)
                pose_cells.inject_linear(lin, energy)
                self.injected = float(energy.sum())
        return v

    def learn(self, tick: int, pose_cells: PoseCells) -> None:
        """Hebbian learning between the active view cell and the active pose cells, then
        fatigue/recovery bookkeeping for every view cell. Call once per tick after the pose
        cells have been updated."""
        cfg = self.config.local_view
        v = self.current
        if v >= 0 and self.activity > 0.0:
            lin, p = pose_cells.cells_at_least(cfg.learn_threshold)
            if self.theta_shift:  # learnt in the frame of the view's template
                lin = self._turned(lin, -self.theta_shift)
                order = np.argsort(lin, kind="stable")
                lin, p = lin[order], p[order]
            w = (cfg.learn_rate * self.activity) * p
            self._assoc_lin[v], self._assoc_w[v], self._assoc_tick[v] = merge_associations(
                self._assoc_lin[v], self._assoc_w[v], self._assoc_tick[v], lin, w, tick
            )
        if self.fatigue.size:
            active_fatigue = float(self.fatigue[v]) if v >= 0 else 0.0
            self.fatigue -= cfg.fatigue_recovery
            np.maximum(self.fatigue, 0.0, out=self.fatigue)
            if v >= 0:
                self.fatigue[v] = min(active_fatigue + cfg.fatigue_rate, FATIGUE_CAP)

    def associations(self, view_cell: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Associations of one view cell: cells (k, 3) as (x', y', θ'), weights (k,), learnt ticks (k,)."""
        lin = self._assoc_lin[view_cell]
        cells = np.stack(
            (
                lin // self._strides[0],
                (lin // self._strides[1]) % self.config.pose_cells.ny,
                lin % self.config.pose_cells.n_theta,
            ),
            axis=1,
        )
        return cells, self._assoc_w[view_cell].copy(), self._assoc_tick[view_cell].copy()

    # ------------------------------------------------------------------ state i/o
    def get_state(self) -> dict:
        """Arrays that fully describe the view cells (for save/load)."""
        counts = np.array([a.size for a in self._assoc_lin], dtype=np.int64)

        def cat(parts, dt):
            return np.concatenate(parts) if parts else np.zeros(0, dtype=dt)

        return {
            "lv_scenes": self.scenes.copy(),
            "lv_fatigue": self.fatigue.copy(),
            "lv_counts": counts,
            "lv_lin": cat(self._assoc_lin, np.int64),
            "lv_w": cat(self._assoc_w, float),
            "lv_tick": cat(self._assoc_tick, np.int64),
            "lv_current": np.array([self.current], dtype=np.int64),
            "lv_activity": np.array([self.activity, self.injected]),
        }

    def set_state(self, s: dict) -> None:
        """Restore a state produced by :meth:`get_state`."""
        self.scenes = np.asarray(s["lv_scenes"], dtype=np.int64).copy()
        self.fatigue = np.asarray(s["lv_fatigue"], dtype=float).copy()
        self._scene_to_cell = {int(sc): i for i, sc in enumerate(self.scenes)}
        bounds = np.concatenate(([0], np.cumsum(s["lv_counts"])))
        self._assoc_lin = [np.asarray(s["lv_lin"][a:b], dtype=np.int64).copy() for a, b in zip(bounds[:-1], bounds[1:])]
        self._assoc_w = [np.asarray(s["lv_w"][a:b], dtype=float).copy() for a, b in zip(bounds[:-1], bounds[1:])]
        self._assoc_tick = [
            np.asarray(s["lv_tick"][a:b], dtype=np.int64).copy() for a, b in zip(bounds[:-1], bounds[1:])
        ]
        self.current = int(s["lv_current"][0])
        self.activity, self.injected = (float(x) for x in s["lv_activity"])
