"""One attractor iteration of a box that holds several packets, packet group by packet group
(numba, cached to disk).

Boxes that came close are merged, and the packets of a merged box drift apart again (each heading
layer moves along its own heading), so a box often holds a few packets and mostly zeros. Groups
of cells further apart than ``reach`` empty cells on some axis (``reach = 2 · excite radius +
inhibit radius``, the distance over which cells interact in one iteration, as in
:meth:`ratslam.pose_cells.PoseCells._merge_interacting`) do not interact: every cell's
excitation and inhibition sums hold terms of one group only, the others' terms being products of
exact zeros. :func:`network_box` therefore splits the box into such groups (cutting along empty
slabs of the axes' projections, recursively), runs the dense iteration of
:mod:`ratslam.pose_cell_kernels` on each group's own smaller box, and writes the results into
the frame the whole box would have used, before the same crop. Each cell receives the same
non-zero terms in the same order and adding a zero leaves a sum unchanged, so the result,
its crop and its sum (added in the whole box's order) are bit-for-bit those of
:func:`ratslam.pose_cell_kernels.network_box` (tested).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.typed import List

from . import pose_cell_kernels as K


@njit(cache=True)
def _pieces(p, n, reach):
    """Runs of True in projection ``p`` (local to a range of a ring of ``n``) separated by more
    than ``reach`` False entries, as (k, 2) local [start, end); one run if the first and last
    would come within ``reach`` round the ring (then the range is not cut on this axis)."""
    length = p.shape[0]
    out = np.empty((length, 2), dtype=np.int64)
    k = 0
    first = -1
    last = -1
    for i in range(length):
        if p[i]:
            if first < 0:
                first = i
                out[0, 0] = i
                k = 1
            elif i - last - 1 > reach:
                out[k - 1, 1] = last + 1
                out[k, 0] = i
                k += 1
            last = i
    if k == 0:
        return out[:0]
    out[k - 1, 1] = last + 1
    if k > 1 and n - (last + 1 - first) <= reach:  # the outer runs meet round the ring
        out[0, 0], out[0, 1] = first, last + 1
        k = 1
    return out[:k]


@njit(cache=True)
def _one_group(act, n, reach):
    """Whether :func:`groups` would find at most one group in ``act``: no axis of the whole box's
    projections cut (the usual case, decided without building the groups)."""
    pt, px, py = K.above(act, 0.0)  # the activity is never negative: non-zero cells
    return (
        _pieces(pt, n[0], reach).shape[0] <= 1
        and _pieces(px, n[1], reach).shape[0] <= 1
        and _pieces(py, n[2], reach).shape[0] <= 1
    )


@njit(cache=True)
def groups(act, n, reach):
    """Local ranges (k, 6) as (t0, t1, x0, x1, y0, y1) of the groups of non-zero cells of box
    ``act`` that lie more than ``reach`` empty cells apart on some axis (tight around their cells;
    none if the box is all zero)."""
    out = List()
    stack = List()
    lo0 = np.zeros(3, dtype=np.int64)
    hi0 = np.array(act.shape, dtype=np.int64)
    stack.append((lo0, hi0))
    while len(stack):
        lo, hi = stack.pop()
        pt, px, py = K.above(act[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]], 0.0)
        for a in range(3):
            pieces = _pieces(pt if a == 0 else (px if a == 1 else py), n[a], reach)
            if pieces.shape[0] != 1:  # all zero, or cut along this axis
                for j in range(pieces.shape[0] - 1, -1, -1):
                    nlo = lo.copy()
                    nhi = hi.copy()
                    nlo[a] = lo[a] + pieces[j, 0]
                    nhi[a] = lo[a] + pieces[j, 1]
                    stack.append((nlo, nhi))
                break
            # tight on this axis (dropping empty slabs leaves the other projections as they are)
            lo = lo.copy()
            hi = hi.copy()
            lo[a], hi[a] = lo[a] + pieces[0, 0], lo[a] + pieces[0, 1]
        else:
            out.append(np.array([lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]], dtype=np.int64))
    res = np.empty((len(out), 6), dtype=np.int64)
    for i in range(len(out)):
        res[i] = out[i]
    return res


@njit(cache=True)
def network_box(
    act, start, n, exc0, exc1, exc2, inh0, inh1, inh2, off_spread, off_within, r_exc, inhibit_weight, global_inhibition
):
    """:func:`ratslam.pose_cell_kernels.network_box` (one attractor iteration of one box before
    normalisation), group by group (see the module docstring); bit-for-bit the same result.
    Returns (new start, activity, mass)."""
    reach = 2 * r_exc - off_within[0]  # 2 · excite radius + inhibit radius (off_within = -radius)
    if _one_group(act, n, reach):  # the usual case: the whole box at once
        return K.network_box(
            act,
            start,
            n,
            exc0,
            exc1,
            exc2,
            inh0,
            inh1,
            inh2,
            off_spread,
            off_within,
            r_exc,
            inhibit_weight,
            global_inhibition,
        )
    parts = groups(act, n, reach)  # two or more
    # the frame of the whole box: grown by the excitation radius (at most the ring)
    lg = np.empty(3, dtype=np.int64)
    grown = np.empty(3, dtype=np.int64)
    for a in range(3):
        lg[a] = min(act.shape[a] + 2 * r_exc, n[a])
        grown[a] = (start[a] - r_exc) % n[a]
    pt = np.zeros(lg[0], dtype=np.bool_)
    px = np.zeros(lg[1], dtype=np.bool_)
    py = np.zeros(lg[2], dtype=np.bool_)
    # each group's iteration on its own box; its cells above the global inhibition projected
    # into the whole box's frame
    wins = List()
    outs = List()
    for g in range(parts.shape[0]):
        t0, t1, x0, x1, y0, y1 = parts[g]
        sub = np.ascontiguousarray(act[t0:t1, x0:x1, y0:y1])
        exc = K.excite(sub, exc0, exc1, exc2, off_spread, n)
        gp = np.empty(3, dtype=np.int64)  # the group's grown box, global
        gp[0] = (start[0] + t0 - r_exc) % n[0]
        gp[1] = (start[1] + x0 - r_exc) % n[1]
        gp[2] = (start[2] + y0 - r_exc) % n[2]
        qt, qx, qy, wt, wx, wy, a_win, _, _, _ = K.inhibit_clip(
            exc, inh0, inh1, inh2, off_within, inhibit_weight, global_inhibition, n
        )
        for i in range(qt.shape[0]):
            if qt[i]:
                pt[(gp[0] + i - grown[0]) % n[0]] = True
        for i in range(qx.shape[0]):
            if qx[i]:
                px[(gp[1] + i - grown[1]) % n[1]] = True
        for i in range(qy.shape[0]):
            if qy[i]:
                py[(gp[2] + i - grown[2]) % n[2]] = True
        if a_win.shape[0]:
            w = np.empty(3, dtype=np.int64)
            w[0] = (gp[0] + wt) % n[0]
            w[1] = (gp[1] + wx) % n[1]
            w[2] = (gp[2] + wy) % n[2]
            wins.append(w)
            outs.append(a_win)
    if not pt.any():
        return grown, np.zeros((0, 0, 0)), 0.0
    # the whole box's window and activity over it, then the same crop
    t0, nt = K._window(pt, n[0])
    x0, nx = K._window(px, n[1])
    y0, ny = K._window(py, n[2])
    win = np.empty(3, dtype=np.int64)
    win[0] = (grown[0] + t0) % n[0]
    win[1] = (grown[1] + x0) % n[1]
    win[2] = (grown[2] + y0) % n[2]
    out = np.zeros((nt, nx, ny))
    qt = np.zeros(nt, dtype=np.bool_)
    qx = np.zeros(nx, dtype=np.bool_)
    qy = np.zeros(ny, dtype=np.bool_)
    for g in range(len(outs)):
        a_win = outs[g]
        w = wins[g]
        for t in range(a_win.shape[0]):
            ot = (w[0] + t - win[0]) % n[0]
            for x in range(a_win.shape[1]):
                ox = (w[1] + x - win[1]) % n[1]
                row = a_win[t, x]
                for y in range(a_win.shape[2]):
                    if row[y] > 0.0:
                        oy = (w[2] + y - win[2]) % n[2]
                        out[ot, ox, oy] = row[y]
                        qt[ot] = True
                        qx[ox] = True
                        qy[oy] = True
    return K.crop(out, qt, qx, qy, win, n)


@njit(cache=True)
def step_one_box(
    act,
    start,
    n,
    exc0,
    exc1,
    exc2,
    inh0,
    inh1,
    inh2,
    off_spread,
    off_within,
    r_exc,
    inhibit_weight,
    global_inhibition,
    cos_t,
    sin_t,
    dist,
    rot,
    peak_radius,
):
    """``PoseCells.step`` for a network held in one box, in one call: :func:`network_box`, the
    normalisation, :func:`~ratslam.pose_cell_kernels.path_integrate_box` (``dist``, ``rot`` in
    cells) and the peak (:func:`~ratslam.pose_cell_kernels.peak_of_box`), the same operations in
    the same order. Returns (activity survived, new start, activity, peak (x', y', θ'))."""
    start, act, mass = network_box(
        act,
        start,
        n,
        exc0,
        exc1,
        exc2,
        inh0,
        inh1,
        inh2,
        off_spread,
        off_within,
        r_exc,
        inhibit_weight,
        global_inhibition,
    )
    total = 0.0
    if act.size:
        total += mass
    if not total > 0.0:
        return False, start, act, np.zeros(3)
    act *= 1.0 / total
    start, act = K.path_integrate_box(act, start, n, cos_t, sin_t, dist, rot)
    return True, start, act, K.peak_of_box(act, start, n, peak_radius)
