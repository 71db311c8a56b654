"""Pose cells: the 3D competitive attractor network over (x', y', θ').

The network wraps on every axis. One iteration (``step``) is, in order:

1. local excitation: activity is blurred by a normalised Gaussian (conserves total activity);
2. local inhibition: ``inhibit_weight`` times a wider Gaussian blur of the result is subtracted;
3. global inhibition: a constant is subtracted from every cell, then negative cells are set to 0;
4. normalisation: total activity is scaled back to 1;
5. path integration: each heading layer θ' is translated by the odometry (v·dt along its own
   heading, bilinear sub-cell shift), then all layers are rotated along θ' by ω·dt (linear
   sub-cell shift). Both shifts conserve activity and wrap.

After global inhibition nearly every cell is exactly zero, so the network stores only
wrap-aware bounding boxes around the non-zero cells (one per packet; boxes close enough to
interact are merged before each iteration) and applies each linear operator as a small matrix
per axis (all kernels are separable Gaussians). The full grid is materialised only when asked
for (:attr:`PoseCells.activity`). The result equals the same update run over the whole grid
(:mod:`ratslam.pose_cells_reference`) to rounding (tested).

Internally the local array is laid out (θ', x', y'); public coordinates are (x', y', θ').
"""

from __future__ import annotations

import math

import numpy as np

from .config import RatSLAMConfig

_TWO_PI = 2.0 * math.pi


def gaussian_kernel(sigma: float, radius: int) -> np.ndarray:
    """1D Gaussian weights over offsets -radius..radius, normalised to sum 1."""
    d = np.arange(-radius, radius + 1, dtype=float)
    k = np.exp(-0.5 * (d / sigma) ** 2)
    return k / k.sum()


def _cover_arc(occupied: np.ndarray) -> tuple[int, int]:
    """Smallest circular arc (start, length) covering every True entry of a ring."""
    n = occupied.size
    idx = np.flatnonzero(occupied)
    if idx.size == 0:
        raise ValueError("occupied ring is empty")
    if idx.size == n:
        return 0, n
    gaps = np.diff(np.concatenate((idx, idx[:1] + n)))  # gap after each occupied index
    k = int(np.argmax(gaps))
    start = int(idx[(k + 1) % idx.size])
    return start, n - int(gaps[k]) + 1


def _ring_gap(s1: int, l1: int, s2: int, l2: int, n: int) -> int:
    """Number of empty cells between two arcs of a ring (0 if they touch or overlap)."""
    if (s2 - s1) % n < l1 or (s1 - s2) % n < l2:
        return 0
    return int(min((s2 - (s1 + l1)) % n, (s1 - (s2 + l2)) % n))


def _rebox(start: np.ndarray, act: np.ndarray, new_start: np.ndarray, new_len, n: np.ndarray) -> np.ndarray:
    """Copy a box's activity into a new box (which must cover every non-zero cell)."""
    new = np.zeros(tuple(int(v) for v in new_len))
    src, dst = [], []
    for a in range(3):
        rel = (start[a] + np.arange(act.shape[a]) - new_start[a]) % n[a]
        keep = rel < new_len[a]
        src.append(np.flatnonzero(keep))
        dst.append(rel[keep])
    new[np.ix_(*dst)] = act[np.ix_(*src)]
    return new


class PoseCells:
    """Competitive attractor network of pose cells (see the module docstring).

    Activity is stored as a list of boxes ``[start, act]``: ``start`` is the global (θ', x', y')
    index of the box's first cell, ``act`` its local activity. Every non-zero cell lies in exactly
    one box; boxes close enough to interact through excitation or inhibition are merged before
    each iteration, so each box can be updated on its own. Public coordinates are (x', y', θ').
    """

    def __init__(self, config: RatSLAMConfig, start_cell: tuple[int, int, int] | None = None):
        self.config = config
        self._n = np.array([config.n_theta, config.nx, config.ny], dtype=np.int64)  # (θ, x, y)
        k_exc = gaussian_kernel(config.excite_sigma, config.excite_radius)
        k_inh = gaussian_kernel(config.inhibit_sigma, config.inhibit_radius)
        # per axis (θ, x, y): heading may use its own widths
        self._k_exc = (gaussian_kernel(config.excite_sigma_theta, config.excite_radius), k_exc, k_exc)
        self._k_inh = (gaussian_kernel(config.inhibit_sigma_theta, config.inhibit_radius), k_inh, k_inh)
        # boxes closer than this (empty cells, on every axis) interact within one iteration
        self._reach = 2 * config.excite_radius + config.inhibit_radius
        self._cache: dict = {}
        if start_cell is None:
            start_cell = (config.nx // 2, config.ny // 2, 0)
        x, y, t = start_cell
        start = np.array([t % config.n_theta, x % config.nx, y % config.ny], dtype=np.int64)
        self._boxes: list[list] = [[start, np.ones((1, 1, 1))]]
        self._peak = np.array([float(start[1]), float(start[2]), float(start[0])])
        rad = config.peak_radius
        self._offsets = np.arange(2 * rad + 1)
        ang = np.arange(-rad, rad + 1)[None, :] * (_TWO_PI / self._n[:, None])   # per axis (θ, x, y)
        self._peak_sin, self._peak_cos = np.sin(ang), np.cos(ang)
        angles = np.arange(config.n_theta) * config.theta_cell_rad
        self._cos = np.cos(angles)
        self._sin = np.sin(angles)

    # ------------------------------------------------------------------ read access
    @property
    def activity(self) -> np.ndarray:
        """Full activity grid, shape (nx, ny, n_theta), as a new read-only array."""
        full = np.zeros(tuple(self._n))
        for start, act in self._boxes:
            idx = [(start[a] + np.arange(act.shape[a])) % self._n[a] for a in range(3)]
            full[np.ix_(*idx)] += act
        out = full.transpose(1, 2, 0)
        out.flags.writeable = False
        return out

    @property
    def peak(self) -> np.ndarray:
        """Peak (x', y', θ') in cell units, wrapped into [0, n)."""
        return self._peak.copy()

    @property
    def total(self) -> float:
        """Total activity (1 after every step)."""
        return float(sum(act.sum() for _, act in self._boxes))

    def boxes(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Bounding boxes of the stored activity: (start, size) as (x', y', θ'), cell units."""
        order = [1, 2, 0]
        return [(start[order].copy(), np.array(act.shape)[order]) for start, act in self._boxes]

    def active_cells(self) -> tuple[np.ndarray, np.ndarray]:
        """Non-zero cells: (k, 3) int array of (x', y', θ') and their (k,) activities."""
        cells, vals = [], []
        for start, act in self._boxes:
            t, x, y = np.nonzero(act)
            vals.append(act[t, x, y])
            cells.append(np.stack(((x + start[1]) % self._n[1], (y + start[2]) % self._n[2],
                                   (t + start[0]) % self._n[0]), axis=1))
        return np.concatenate(cells), np.concatenate(vals)

    # ------------------------------------------------------------------ state i/o
    def get_state(self) -> dict:
        """Arrays that fully describe the network state (for save/load)."""
        return {
            "pc_starts": np.array([b[0] for b in self._boxes], dtype=np.int64).reshape(-1, 3),
            "pc_shapes": np.array([b[1].shape for b in self._boxes], dtype=np.int64).reshape(-1, 3),
            "pc_values": np.concatenate([b[1].ravel() for b in self._boxes]),
            "pc_peak": self._peak.copy(),
        }

    def set_state(self, state: dict) -> None:
        """Restore a state produced by :meth:`get_state`."""
        boxes, pos = [], 0
        values = np.asarray(state["pc_values"], dtype=float)
        for start, shape in zip(state["pc_starts"], state["pc_shapes"]):
            size = int(np.prod(shape))
            boxes.append([np.asarray(start, dtype=np.int64).copy(),
                          values[pos:pos + size].reshape(tuple(int(v) for v in shape)).copy()])
            pos += size
        self._boxes = boxes
        self._peak = np.asarray(state["pc_peak"], dtype=float).copy()

    # ------------------------------------------------------------------ input
    def inject(self, cells: np.ndarray, energy: np.ndarray | float) -> None:
        """Add activity ``energy`` at integer cells ``(k, 3)`` given as (x', y', θ') (wrapped)."""
        cells = np.atleast_2d(np.asarray(cells, dtype=np.int64))
        if cells.size == 0:
            return
        energy = np.broadcast_to(np.asarray(energy, dtype=float), (cells.shape[0],))
        g = np.stack((cells[:, 2] % self._n[0], cells[:, 0] % self._n[1], cells[:, 1] % self._n[2]))
        todo = np.ones(g.shape[1], dtype=bool)
        for start, act in self._boxes:
            local = (g - start[:, None]) % self._n[:, None]
            inside = todo & np.all(local < np.array(act.shape)[:, None], axis=0)
            if inside.any():
                np.add.at(act, (local[0, inside], local[1, inside], local[2, inside]), energy[inside])
                todo &= ~inside
        if todo.any():
            g, energy = g[:, todo], energy[todo]
            # one new box per cluster of cells (boxes that turn out close are merged later)
            remaining = np.arange(g.shape[1])
            while remaining.size:
                d = np.abs(g[:, remaining] - g[:, remaining[:1]])
                d = np.minimum(d, self._n[:, None] - d)
                near = np.all(d <= 2 * self._reach, axis=0)
                members, remaining = remaining[near], remaining[~near]
                gc = g[:, members]
                start = np.empty(3, dtype=np.int64)
                shape = []
                for a in range(3):
                    occ = np.zeros(int(self._n[a]), dtype=bool)
                    occ[gc[a]] = True
                    start[a], length = _cover_arc(occ)
                    shape.append(length)
                act = np.zeros(shape)
                local = (gc - start[:, None]) % self._n[:, None]
                np.add.at(act, (local[0], local[1], local[2]), energy[members])
                self._boxes.append([start, act])

    def _merge_interacting(self) -> None:
        """Merge boxes that are close enough to interact during one iteration."""
        boxes = self._boxes
        n = self._n
        i = 0
        while i < len(boxes):
            j = i + 1
            merged = False
            while j < len(boxes):
                (s1, a1), (s2, a2) = boxes[i], boxes[j]
                if all(_ring_gap(int(s1[a]), a1.shape[a], int(s2[a]), a2.shape[a], int(n[a])) <= self._reach
                       for a in range(3)):
                    start = np.empty(3, dtype=np.int64)
                    shape = []
                    for a in range(3):
                        occ = np.zeros(int(n[a]), dtype=bool)
                        occ[(s1[a] + np.arange(a1.shape[a])) % n[a]] = True
                        occ[(s2[a] + np.arange(a2.shape[a])) % n[a]] = True
                        start[a], length = _cover_arc(occ)
                        shape.append(length)
                    act = _rebox(s1, a1, start, shape, n) + _rebox(s2, a2, start, shape, n)
                    boxes[i] = [start, act]
                    del boxes[j]
                    merged = True
                else:
                    j += 1
            if not merged:
                i += 1

    # ------------------------------------------------------------------ operators
    def _spread(self, axis: int, length: int, kernel: np.ndarray) -> np.ndarray:
        """Matrix (out, in) applying a wrap-aware kernel; out box = in box grown by the radius.

        Output local index o is global ``start - r + o``; if the grown box would reach round the
        ring it is the whole axis (length n) and contributions are folded modulo n.
        """
        n = int(self._n[axis])
        key = ("spread", n, length, id(kernel))
        m = self._cache.get(key)
        if m is None:
            r = (kernel.size - 1) // 2
            out_len = min(length + 2 * r, n)
            rows = (np.arange(length)[None, :] + np.arange(2 * r + 1)[:, None]) % n
            cols = np.broadcast_to(np.arange(length)[None, :], rows.shape)
            vals = np.broadcast_to(kernel[:, None], rows.shape)
            m = np.zeros((out_len, length))
            np.add.at(m, (rows, cols), vals)
            self._cache[key] = m
        return m

    def _within(self, axis: int, length: int, kernel: np.ndarray) -> np.ndarray:
        """Matrix (L, L) applying a wrap-aware kernel from a box onto the same box."""
        n = int(self._n[axis])
        key = ("within", n, length, id(kernel))
        m = self._cache.get(key)
        if m is None:
            r = (kernel.size - 1) // 2
            rows = (np.arange(length)[None, :] + np.arange(-r, r + 1)[:, None]) % n
            cols = np.broadcast_to(np.arange(length)[None, :], rows.shape)
            vals = np.broadcast_to(kernel[:, None], rows.shape)
            keep = rows < length
            m = np.zeros((length, length))
            np.add.at(m, (rows[keep], cols[keep]), vals[keep])
            self._cache[key] = m
        return m

    @staticmethod
    def _apply3(act: np.ndarray, mt: np.ndarray, mx: np.ndarray, my: np.ndarray) -> np.ndarray:
        """Apply one matrix per axis to a (θ, x, y) array."""
        lt, lx, ly = act.shape
        out = (mt @ act.reshape(lt, lx * ly)).reshape(mt.shape[0], lx, ly)
        out = np.matmul(mx, out)
        return out @ my.T

    def _shift_matrices(self, axis: int, length: int, shift: np.ndarray) -> tuple[np.ndarray, int]:
        """Stack of (out, in) matrices translating by real ``shift[l]`` cells (linear interp).

        Returns the matrices (len(shift), out, in) and the change of box start. Each column has
        weight (1 - f) at floor(shift) and f one cell further, so activity is conserved.
        """
        n = int(self._n[axis])
        ishift = np.floor(shift)
        frac = shift - ishift
        ishift = ishift.astype(np.int64)
        lo = int(ishift.min())
        out_len = length + int(ishift.max()) - lo + 1
        b = shift.size
        rows = np.arange(length) + (ishift - lo)[:, None]  # (b, length)
        layer = np.arange(b)[:, None]
        cols = np.arange(length)[None, :]
        if out_len >= n:
            shape = rows.shape
            m = np.zeros((b, n, length))
            np.add.at(m, (np.broadcast_to(layer, shape), rows % n, np.broadcast_to(cols, shape)),
                      np.broadcast_to((1.0 - frac)[:, None], shape))
            np.add.at(m, (np.broadcast_to(layer, shape), (rows + 1) % n, np.broadcast_to(cols, shape)),
                      np.broadcast_to(frac[:, None], shape))
        else:
            m = np.zeros((b, out_len, length))
            m[layer, rows, cols] = (1.0 - frac)[:, None]
            m[layer, rows + 1, cols] = frac[:, None]
        return m, lo

    def _crop(self, start: np.ndarray, act: np.ndarray):
        """Shrink a box to its non-zero cells (wrap-aware); None if it is empty."""
        pos = act > 0.0
        pt = pos.any(axis=(1, 2))
        if not pt.any():
            return None
        projections = (pt, pos.any(axis=(0, 2)), pos.any(axis=(0, 1)))
        slices = []
        need_rebox = False
        new_start = start.copy()
        new_len = list(act.shape)
        for a in range(3):
            p = projections[a]
            length = act.shape[a]
            n = int(self._n[a])
            if length < n:
                nz = np.flatnonzero(p)
                lo, hi = int(nz[0]), int(nz[-1]) + 1
                slices.append(slice(lo, hi))
                new_start[a] = (start[a] + lo) % n
                new_len[a] = hi - lo
            else:
                ring = np.zeros(n, dtype=bool)
                ring[(start[a] + np.arange(n)) % n] = p
                s, ln = _cover_arc(ring)
                if ln < n:
                    need_rebox = True
                    new_start[a], new_len[a] = s, ln
                slices.append(slice(None))
        if need_rebox:
            return [new_start, _rebox(start, act, new_start, new_len, self._n)]
        return [new_start, act[tuple(slices)]]

    # ------------------------------------------------------------------ dynamics
    def step(self, v_trans_dt: float, v_rot_dt: float) -> None:
        """One network iteration followed by path integration.

        ``v_trans_dt`` is the distance travelled this tick (m), ``v_rot_dt`` the heading change
        (rad), both already including any path-integration bias. The translation is scaled by
        ``config.pc_trans_gain`` (lattice-lag compensation, see the config).
        """
        cfg = self.config
        if len(self._boxes) > 1:
            self._merge_interacting()
        r = cfg.excite_radius
        new_boxes = []
        total = 0.0
        for start, act in self._boxes:
            # 1. local excitation (the box grows by the excitation radius)
            lt, lx, ly = act.shape
            ke = self._k_exc
            exc = self._apply3(act, self._spread(0, lt, ke[0]), self._spread(1, lx, ke[1]),
                               self._spread(2, ly, ke[2]))
            start = (start - r) % self._n
            # 2. local inhibition (only inside the box: outside it activity is 0 and clipped)
            if cfg.inhibit_weight > 0.0:
                lt, lx, ly = exc.shape
                ki = self._k_inh
                inh = self._apply3(exc, self._within(0, lt, ki[0]), self._within(1, lx, ki[1]),
                                   self._within(2, ly, ki[2]))
                exc -= cfg.inhibit_weight * inh
            # 3. global inhibition and non-negativity
            exc -= cfg.global_inhibition
            np.maximum(exc, 0.0, out=exc)
            box = self._crop(start, exc)
            if box is not None:
                total += box[1].sum()
                new_boxes.append(box)
        # 4. normalisation
        if not total > 0.0:
            raise RuntimeError("pose-cell activity vanished: global_inhibition too strong for the packet")
        scale = 1.0 / total
        for box in new_boxes:
            box[1] *= scale
            # 5. path integration
            self._path_integrate_box(box, v_trans_dt * cfg.pc_trans_gain, v_rot_dt)
        self._boxes = new_boxes
        self._update_peak()

    def path_integrate(self, v_trans_dt: float, v_rot_dt: float) -> None:
        """Translate each heading layer by ``v_trans_dt`` metres along its heading, then rotate
        all layers by ``v_rot_dt`` radians (sub-cell shifts by linear interpolation, wrap)."""
        for box in self._boxes:
            self._path_integrate_box(box, v_trans_dt, v_rot_dt)

    def _path_integrate_box(self, box: list, v_trans_dt: float, v_rot_dt: float) -> None:
        start, act = box
        lt = act.shape[0]
        if v_trans_dt != 0.0:
            layers = (start[0] + np.arange(lt)) % self._n[0]
            dist = v_trans_dt / self.config.cell_size_m
            tx, lox = self._shift_matrices(1, act.shape[1], dist * self._cos[layers])
            ty, loy = self._shift_matrices(2, act.shape[2], dist * self._sin[layers])
            act = np.matmul(np.matmul(tx, act), ty.transpose(0, 2, 1))
            start[1] = (start[1] + lox) % self._n[1]
            start[2] = (start[2] + loy) % self._n[2]
        if v_rot_dt != 0.0:
            m, lo = self._shift_matrices(0, lt, np.array([v_rot_dt / self.config.theta_cell_rad]))
            _, lx, ly = act.shape
            act = (m[0] @ act.reshape(lt, lx * ly)).reshape(m.shape[1], lx, ly)
            start[0] = (start[0] + lo) % self._n[0]
        box[0], box[1] = start, act

    def _update_peak(self) -> None:
        """Strongest cell refined by the circular weighted mean of its neighbourhood."""
        boxes = self._boxes
        if len(boxes) == 1:
            bi = 0
        else:
            bi = int(np.argmax([b[1].max() for b in boxes]))
        start, act = boxes[bi]
        c = np.unravel_index(int(np.argmax(act)), act.shape)
        cg = (start + c) % self._n                      # global strongest cell
        rad = self.config.peak_radius
        sums = np.zeros((3, 2 * rad + 1))
        for start, act in boxes:
            rel = (cg - rad - start) % self._n          # neighbourhood start, box-relative
            shape = act.shape
            if all(rel[a] + 2 * rad < shape[a] for a in range(3)):   # inside, no wrap
                sub = act[rel[0]:rel[0] + 2 * rad + 1, rel[1]:rel[1] + 2 * rad + 1,
                          rel[2]:rel[2] + 2 * rad + 1]
                offs = (slice(None),) * 3
            else:
                idx, offs = [], []
                for a in range(3):
                    r = (rel[a] + self._offsets) % self._n[a]
                    keep = r < shape[a]
                    idx.append(r[keep])
                    offs.append(np.flatnonzero(keep))
                if any(i.size == 0 for i in idx):
                    continue
                sub = act[np.ix_(*idx)]
            sums[0, offs[0]] += sub.sum(axis=(1, 2))
            sums[1, offs[1]] += sub.sum(axis=(0, 2))
            sums[2, offs[2]] += sub.sum(axis=(0, 1))
        mean = np.arctan2((sums * self._peak_sin).sum(axis=1), (sums * self._peak_cos).sum(axis=1))
        peak = (cg + mean * self._n / _TWO_PI) % self._n
        peak[peak >= self._n] = 0.0                      # (-tiny) % n rounds to n
        self._peak = peak[[1, 2, 0]]
