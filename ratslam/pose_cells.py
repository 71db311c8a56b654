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
interact are merged before each iteration) and applies each linear operator along one axis at a
time (all kernels are separable Gaussians), compiled in :mod:`ratslam.pose_cell_kernels`; a box
holding packets far apart is stepped packet group by packet group (:mod:`ratslam.pose_cell_split`)
and a large box whose heading layers are mostly empty layer by layer
(:mod:`ratslam.pose_cell_layers`), both bit for bit the whole box's step. The full grid is
materialised only when asked for (:attr:`PoseCells.activity`). The result equals the same update
run over the whole grid (:mod:`ratslam.pose_cells_reference`) to rounding (tested).

Internally the local array is laid out (θ', x', y'); public coordinates are (x', y', θ').
"""

from __future__ import annotations

import numpy as np

from . import pose_cell_kernels as K
from . import pose_cell_layers, pose_cell_split
from .config import RatSLAMConfig
from .heap import retain_freed_memory


def gaussian_kernel(sigma: float, radius: int) -> np.ndarray:
    """1D Gaussian weights over offsets -radius..radius, normalised to sum 1."""
    d = np.arange(-radius, radius + 1, dtype=float)
    k = np.exp(-0.5 * (d / sigma) ** 2)
    return k / k.sum()


def axis_kernels(config: RatSLAMConfig) -> tuple[tuple, tuple]:
    """Excitation and inhibition kernels per axis (θ', x', y'): heading has its own widths."""
    pc = config.pose_cells
    k_exc = gaussian_kernel(pc.excite_sigma_cells, pc.excite_radius_cells)
    k_inh = gaussian_kernel(pc.inhibit_sigma_cells, pc.inhibit_radius_cells)
    return (
        (gaussian_kernel(pc.excite_sigma_theta_cells, pc.excite_radius_cells), k_exc, k_exc),
        (gaussian_kernel(pc.inhibit_sigma_theta_cells, pc.inhibit_radius_cells), k_inh, k_inh),
    )


# a box of this many cells or more whose layers' rectangles cover at most this fraction of it is
# stepped layer by layer (:mod:`ratslam.pose_cell_layers`)
LAYERED_MIN_CELLS = 20_000
LAYERED_MAX_COVER = 0.3


class PoseCells:
    """Competitive attractor network of pose cells (see the module docstring).

    Activity is stored as a list of boxes ``[start, act]``: ``start`` is the global (θ', x', y')
    index of the box's first cell, ``act`` its local activity. Every non-zero cell lies in exactly
    one box; boxes close enough to interact through excitation or inhibition are merged before
    each iteration, so each box can be updated on its own. Public coordinates are (x', y', θ').
    """

    def __init__(self, config: RatSLAMConfig, start_cell: tuple[int, int, int] | None = None):
        retain_freed_memory()  # every step makes and drops arrays of up to hundreds of kB
        self.config = config
        pc = config.pose_cells
        self._n = np.array([pc.n_theta, pc.nx, pc.ny], dtype=np.int64)  # (θ, x, y)
        # per-axis kernels as one-row tap tables for the compiled operators
        k_exc, k_inh = axis_kernels(config)
        self._taps_exc = tuple(np.ascontiguousarray(k[None, :]) for k in k_exc)
        self._taps_inh = tuple(np.ascontiguousarray(k[None, :]) for k in k_inh)
        self._off_spread = np.zeros(1, dtype=np.int64)
        self._off_within = np.array([-pc.inhibit_radius_cells], dtype=np.int64)
        # boxes closer than this (empty cells, on every axis) interact within one iteration
        self._reach = 2 * pc.excite_radius_cells + pc.inhibit_radius_cells
        te, ti = self._taps_exc, self._taps_inh
        # the attractor's operands after (activity, start), as the kernels take them
        self._network = (
            self._n,
            te[0],
            te[1],
            te[2],
            ti[0],
            ti[1],
            ti[2],
            self._off_spread,
            self._off_within,
            pc.excite_radius_cells,
            pc.inhibit_weight,
            pc.global_inhibition,
        )
        if start_cell is None:
            start_cell = (pc.nx // 2, pc.ny // 2, 0)
        x, y, t = start_cell
        start = np.array([t % pc.n_theta, x % pc.nx, y % pc.ny], dtype=np.int64)
        self._boxes: list[list] = [[start, np.ones((1, 1, 1))]]
        self._peak = np.array([float(start[1]), float(start[2]), float(start[0])])
        angles = np.arange(pc.n_theta) * pc.theta_cell_rad
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
            cells.append(
                np.stack(
                    ((x + start[1]) % self._n[1], (y + start[2]) % self._n[2], (t + start[0]) % self._n[0]), axis=1
                )
            )
        return np.concatenate(cells), np.concatenate(vals)

    def cells_at_least(self, fraction: float) -> tuple[np.ndarray, np.ndarray]:
        """Active cells at or above ``fraction`` of the strongest one: sorted linear indices over
        (x', y', θ') (``(x' * ny + y') * n_theta + θ'``) and their activities."""
        top = max(K.strongest_cell(act)[0] for _, act in self._boxes)
        parts = [K.cells_at_least(act, start, self._n, fraction * top) for start, act in self._boxes]
        if len(parts) == 1:
            return parts[0]
        lin = np.concatenate([p[0] for p in parts])
        order = np.argsort(lin)
        return lin[order], np.concatenate([p[1] for p in parts])[order]

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
            boxes.append(
                [
                    np.asarray(start, dtype=np.int64).copy(),
                    values[pos : pos + size].reshape(tuple(int(v) for v in shape)).copy(),
                ]
            )
            pos += size
        self._boxes = boxes
        self._peak = np.asarray(state["pc_peak"], dtype=float).copy()

    # ------------------------------------------------------------------ input
    def inject(self, cells: np.ndarray, energy: np.ndarray | float) -> None:
        """Add activity ``energy`` at integer cells ``(k, 3)`` given as (x', y', θ') (wrapped)."""
        cells = np.atleast_2d(np.asarray(cells, dtype=np.int64))
        if cells.size == 0:
            return
        n = self._n
        self._inject_global(np.stack((cells[:, 2] % n[0], cells[:, 0] % n[1], cells[:, 1] % n[2])), energy)

    def inject_linear(self, lin: np.ndarray, energy: np.ndarray | float) -> None:
        """:meth:`inject` at cells given by linear index ``(x' * ny + y') * n_theta + θ'``."""
        lin = np.asarray(lin, dtype=np.int64)
        if lin.size:
            self._inject_global(K.decode_linear(lin, self._n), energy)

    def _inject_global(self, g: np.ndarray, energy) -> None:
        """Inject at global cells ``g`` (3, k) as (θ', x', y')."""
        n = self._n
        energy = np.ascontiguousarray(energy, dtype=float)
        if energy.shape != (g.shape[1],):
            energy = np.full(g.shape[1], energy)
        todo = np.ones(g.shape[1], dtype=bool)
        for start, act in self._boxes:
            K.add_inside(act, start, n, g, energy, todo)
        if todo.any():
            # one new box per cluster of cells (boxes that turn out close are merged later)
            starts, shapes, values = K.boxes_of_clusters(g, energy, todo, n, 2 * self._reach)
            pos = 0
            for start, shape in zip(starts, shapes):
                size = int(shape[0] * shape[1] * shape[2])
                self._boxes.append([start.copy(), values[pos : pos + size].reshape(tuple(shape))])
                pos += size

    def _merge_interacting(self) -> None:
        """Merge boxes that are close enough to interact during one iteration.

        Boxes are grouped first (a group's covering box may reach further boxes, so grouping
        repeats until no two groups interact: :func:`ratslam.pose_cell_kernels.interacting_groups`),
        then each group is copied into one new box.
        """
        old = self._boxes
        order, arc_s, arc_l, members, count = K.interacting_groups(
            np.array([b[0] for b in old], dtype=np.int64),
            np.array([b[1].shape for b in old], dtype=np.int64),
            self._n,
            self._reach,
        )
        if len(order) == len(old):
            return
        boxes = []
        for g in order:
            if count[g] == 1:
                boxes.append(old[members[g, 0]])
                continue
            start = arc_s[g].copy()
            act = np.zeros(tuple(int(v) for v in arc_l[g]))
            for m in members[g, : count[g]]:
                K.rebox_add(act, start, old[m][1], old[m][0], self._n)
            boxes.append([start, act])
        self._boxes = boxes

    # ------------------------------------------------------------------ dynamics
    def step(self, v_trans_dt: float, v_rot_dt: float) -> None:
        """One network iteration followed by path integration.

        ``v_trans_dt`` is the distance travelled this tick (m), ``v_rot_dt`` the heading change
        (rad), both already including any path-integration bias. The translation is scaled by
        ``config.pose_cells.trans_gain`` (lattice-lag compensation, see the config).
        """
        cfg = self.config.pose_cells
        if len(self._boxes) > 1:
            self._merge_interacting()
        network = self._network
        if len(self._boxes) == 1:  # the usual case: the steps below in one compiled call
            start, act = self._boxes[0]
            odometry = (v_trans_dt * cfg.trans_gain / cfg.cell_size_m, v_rot_dt / cfg.theta_cell_rad)
            pi_and_peak = (self._cos, self._sin, *odometry, cfg.peak_radius_cells)
            large = act.size >= LAYERED_MIN_CELLS
            rect = pose_cell_layers.sparse_windows(act, LAYERED_MAX_COVER) if large else None
            if rect is not None and len(rect):  # a large box whose layers are mostly empty
                alive, start, act, peak = pose_cell_layers.step_one_box(act, rect, start, *network, *pi_and_peak)
            else:
                alive, start, act, peak = pose_cell_split.step_one_box(act, start, *network, *pi_and_peak)
            if not alive:
                raise RuntimeError("pose-cell activity vanished: global_inhibition too strong for the packet")
            self._boxes = [[start, act]]
            self._peak = peak
            return
        new_boxes = []
        total = 0.0
        for start, act in self._boxes:
            # 1. local excitation (the box grows by the excitation radius), 2. local inhibition
            # within that box, 3. global inhibition and non-negativity, then crop
            start, act, mass = pose_cell_split.network_box(act, start, *network)
            if act.size:
                total += mass
                new_boxes.append([start, act])
        # 4. normalisation
        if not total > 0.0:
            raise RuntimeError("pose-cell activity vanished: global_inhibition too strong for the packet")
        scale = 1.0 / total
        for box in new_boxes:
            box[1] *= scale
            # 5. path integration
            self._path_integrate_box(box, v_trans_dt * cfg.trans_gain, v_rot_dt)
        self._boxes = new_boxes
        self._update_peak()

    def path_integrate(self, v_trans_dt: float, v_rot_dt: float) -> None:
        """Translate each heading layer by ``v_trans_dt`` metres along its heading, then rotate
        all layers by ``v_rot_dt`` radians (sub-cell shifts by linear interpolation, wrap)."""
        for box in self._boxes:
            self._path_integrate_box(box, v_trans_dt, v_rot_dt)

    def _path_integrate_box(self, box: list, v_trans_dt: float, v_rot_dt: float) -> None:
        box[0], box[1] = K.path_integrate_box(
            box[1],
            box[0],
            self._n,
            self._cos,
            self._sin,
            v_trans_dt / self.config.pose_cells.cell_size_m,
            v_rot_dt / self.config.pose_cells.theta_cell_rad,
        )

    def _update_peak(self) -> None:
        """Strongest cell refined by the circular weighted mean of its neighbourhood."""
        boxes, n, rad = self._boxes, self._n, self.config.pose_cells.peak_radius_cells
        if len(boxes) == 1:
            self._peak = K.peak_of_box(boxes[0][1], boxes[0][0], n, rad)
            return
        best = [K.strongest_cell(act) for _, act in boxes]
        bi = max(range(len(boxes)), key=lambda i: best[i][0]) if len(boxes) > 1 else 0
        cg = (boxes[bi][0] + best[bi][1]) % n  # global strongest cell (θ, x, y)
        sums = K.neighbourhood_sums(boxes[bi][1], (cg - rad - boxes[bi][0]) % n, rad, n)
        for i, (start, act) in enumerate(boxes):
            if i != bi:
                sums += K.neighbourhood_sums(act, (cg - rad - start) % n, rad, n)
        self._peak = K.refine_peak(cg, sums, rad, n)[[1, 2, 0]]


# ---------------------------------------------------------------------- compiling the kernels
KERNEL_PARTS = ("iteration", "boxes", "layers")


def compile_kernels(config: RatSLAMConfig, part: str) -> None:
    """Compile one part of the kernels a :class:`PoseCells` step uses (or load it from numba's disk
    cache), so that two processes can compile the two parts side by side. ``"iteration"``: the
    inhibition of one box, then one step of a network held in one box (the attractor iteration,
    group by group, with path integration and the peak). ``"boxes"``: first the kernels that step
    calls besides the inhibition (the excitation, the groups of a box, path integration, the
    peak), which the other part then loads from the cache while it is still compiling the
    inhibition, then the rest (boxes from injected cells, merging, several boxes' peak, the
    active cells). ``"layers"``: a large box's step, layer by layer
    (:mod:`ratslam.pose_cell_layers`)."""
    cells = PoseCells(config)
    start, act = cells._boxes[0]
    n, te0, te1, te2, ti0, ti1, ti2, off_spread, off_within, _, weight, global_inh = cells._network
    if part == "iteration":
        K.inhibit_clip_crop(act, ti0, ti1, ti2, off_within, weight, global_inh, start, n)
        cells.step(0.0, 0.0)
    elif part == "boxes":
        K.excite(act, te0, te1, te2, off_spread, n)
        pose_cell_split.groups(act, n, cells._reach)
        cells.path_integrate(0.1, 0.05)
        cells._update_peak()
        for x in (10, 4):  # a new box, then cells near it (added inside, merged)
            cells.inject(np.array([[x, 0, 0]]), 0.5)
        cells._merge_interacting()
        cells.path_integrate(0.1, 0.05)
        cells._update_peak()
        cells.cells_at_least(0.5)
    elif part == "layers":  # a large box's step, layer by layer (this one-cell box is not sparse)
        pose_cell_layers.sparse_windows(act, LAYERED_MAX_COVER)
        rect = pose_cell_layers.layer_windows(act)
        pose_cell_layers.step_one_box(act, rect, start, *cells._network, cells._cos, cells._sin, 0.1, 0.05, 1)
    else:
        raise ValueError(f"unknown kernel part {part!r} (known: {', '.join(KERNEL_PARTS)})")
