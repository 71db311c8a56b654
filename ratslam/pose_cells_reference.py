"""Straightforward full-grid pose-cell update: the correctness oracle and benchmark baseline.

Runs exactly the update of :class:`ratslam.pose_cells.PoseCells` over the whole grid every tick
(scipy.ndimage wrap-around correlations, per-layer rolls for path integration). It touches every
cell every tick, which is what the windowed network avoids.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from .config import RatSLAMConfig
from .pose_cells import axis_kernels

_TWO_PI = 2.0 * math.pi


class FullGridPoseCells:
    """The pose-cell update of :class:`~ratslam.pose_cells.PoseCells` on the dense grid."""

    def __init__(self, config: RatSLAMConfig, start_cell: tuple[int, int, int] | None = None):
        self.config = config
        self._k_exc, self._k_inh = axis_kernels(config)
        pc = config.pose_cells
        if start_cell is None:
            start_cell = (pc.nx // 2, pc.ny // 2, 0)
        self._act = np.zeros((pc.n_theta, pc.nx, pc.ny))  # (θ, x, y)
        x, y, t = start_cell
        self._act[t % pc.n_theta, x % pc.nx, y % pc.ny] = 1.0
        self._angles = np.arange(pc.n_theta) * pc.theta_cell_rad

    @property
    def activity(self) -> np.ndarray:
        """Full activity grid, shape (nx, ny, n_theta)."""
        return self._act.transpose(1, 2, 0)

    @property
    def peak(self) -> np.ndarray:
        """Peak (x', y', θ'): strongest cell refined by the circular weighted mean of its
        neighbourhood (same rule as the windowed network)."""
        c = self.config.pose_cells
        n = np.array([c.n_theta, c.nx, c.ny])
        cg = np.array(np.unravel_index(int(np.argmax(self._act)), self._act.shape))
        d = np.arange(-c.peak_radius_cells, c.peak_radius_cells + 1)
        sub = self._act[np.ix_(*[(cg[a] + d) % n[a] for a in range(3)])]
        sums = (sub.sum(axis=(1, 2)), sub.sum(axis=(0, 2)), sub.sum(axis=(0, 1)))
        peak = np.empty(3)
        for a in range(3):
            ang = d * (_TWO_PI / n[a])
            mean = math.atan2(float(sums[a] @ np.sin(ang)), float(sums[a] @ np.cos(ang))) * n[a] / _TWO_PI
            p = (cg[a] + mean) % n[a]
            peak[a] = p if p < n[a] else 0.0
        return np.array([peak[1], peak[2], peak[0]])

    def active_cells(self) -> tuple[np.ndarray, np.ndarray]:
        """Non-zero cells (k, 3) as (x', y', θ') and their activities."""
        t, x, y = np.nonzero(self._act)
        return np.stack((x, y, t), axis=1), self._act[t, x, y]

    def cells_at_least(self, fraction: float) -> tuple[np.ndarray, np.ndarray]:
        """Active cells at or above ``fraction`` of the strongest: sorted linear indices over
        (x', y', θ') and their activities."""
        a = self.activity  # (x, y, θ): C order is the linear index
        flat = a.reshape(-1)
        lin = np.flatnonzero((flat > 0.0) & (flat >= fraction * flat.max()))
        return lin, flat[lin]

    def inject(self, cells: np.ndarray, energy) -> None:
        """Add ``energy`` at integer cells (k, 3) of (x', y', θ')."""
        cells = np.atleast_2d(np.asarray(cells, dtype=np.int64))
        energy = np.broadcast_to(np.asarray(energy, dtype=float), (cells.shape[0],))
        c = self.config.pose_cells
        np.add.at(self._act, (cells[:, 2] % c.n_theta, cells[:, 0] % c.nx, cells[:, 1] % c.ny), energy)

    def inject_linear(self, lin: np.ndarray, energy) -> None:
        """Add ``energy`` at linear indices ``(x' * ny + y') * n_theta + θ'``."""
        c = self.config.pose_cells
        lin = np.asarray(lin, dtype=np.int64)
        self.inject(np.stack((lin // (c.ny * c.n_theta), (lin // c.n_theta) % c.ny, lin % c.n_theta), axis=1), energy)

    def _blur(self, a: np.ndarray, k: tuple) -> np.ndarray:
        for axis in range(3):
            a = ndimage.correlate1d(a, k[axis], axis=axis, mode="wrap")
        return a

    def step(self, v_trans_dt: float, v_rot_dt: float) -> None:
        """Excite, inhibit, global inhibition, normalise, path integrate (whole grid)."""
        c = self.config.pose_cells
        a = self._blur(self._act, self._k_exc)
        if c.inhibit_weight > 0.0:
            a = a - c.inhibit_weight * self._blur(a, self._k_inh)
        a = np.maximum(a - c.global_inhibition, 0.0)
        a /= a.sum()
        if v_trans_dt != 0.0:
            dist = v_trans_dt * c.trans_gain / c.cell_size_m
            out = np.empty_like(a)
            for t in range(c.n_theta):
                layer = a[t]
                sx, sy = dist * math.cos(self._angles[t]), dist * math.sin(self._angles[t])
                ix, iy = math.floor(sx), math.floor(sy)
                fx, fy = sx - ix, sy - iy
                shifted = np.roll(layer, (ix, iy), axis=(0, 1))
                bx = (1 - fx) * shifted + fx * np.roll(shifted, 1, axis=0)
                out[t] = (1 - fy) * bx + fy * np.roll(bx, 1, axis=1)
            a = out
        if v_rot_dt != 0.0:
            s = v_rot_dt / c.theta_cell_rad
            i = math.floor(s)
            f = s - i
            shifted = np.roll(a, i, axis=0)
            a = (1 - f) * shifted + f * np.roll(shifted, 1, axis=0)
        self._act = a
