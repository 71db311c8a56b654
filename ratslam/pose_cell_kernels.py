"""Compiled inner loops of the pose-cell network (numba, cached to disk).

Every linear step of the network (excitation, inhibition, the sub-cell shifts of path
integration) is a 1D operator along one axis of a box of activity laid out (θ', x', y'). Each is
applied in *scatter* form: input cell ``i`` adds ``kw[d] * in[i]`` to output cell
``(i + off + d) mod n`` for taps ``d = 0 .. W-1``, contributions landing at or beyond the output
length ``lout`` being dropped. The modulo is resolved by splitting each tap's input range into
runs that wrap the same number of times, so the innermost loops are plain contiguous
multiply-adds (vectorised by LLVM; no ``fastmath``, so results are IEEE-exact and repeatable).

The three uses, for an input box of length ``L`` on a ring of ``n`` cells:

* spread (excitation, the box grows by ``r`` each side): ``off = 0``, ``lout = min(L + 2r, n)``;
* within (inhibition, onto the same box): ``off = -r``, ``lout = L``;
* shift (path integration by ``s`` cells, linear interpolation): taps ``(1 - f, f)`` with
  ``off = floor(s) - min floor(s)`` per heading layer, ``lout = min(L + spread + 1, n)``.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.typed import List


@njit(cache=True)
def _runs(kw, off, p, length, lout, n):
    """The contiguous runs of operator row ``p``: rows (tap weight index d, delta, i0, i1) meaning
    input cells ``i0 <= i < i1`` add ``kw[p, d] * in[i]`` to output cell ``i + delta``.

    Input ``i`` lands at ``(i + off + d) mod n``; splitting each tap's inputs by how many times
    they wrap (``w``: ``i + off + d + w·n`` in [0, lout)) leaves plain index offsets.
    """
    n_taps = kw.shape[1]
    runs = np.empty((n_taps * (3 + (length + lout) // n), 4), dtype=np.int64)
    r = 0
    for d in range(n_taps):
        if kw[p, d] == 0.0:
            continue
        c = off[p] + d
        for w in range(-((length - 1 + c) // n), (lout - 1 - c) // n + 1):
            delta = c + w * n
            i0 = max(0, -delta)
            i1 = min(length, lout - delta)
            if i0 < i1:
                runs[r, 0], runs[r, 1], runs[r, 2], runs[r, 3] = d, delta, i0, i1
                r += 1
    return runs[:r]


@njit(cache=True)
def op_mid(inp, off, kw, lout, n):
    """Apply a 1D operator along axis 1 of ``inp`` (A, L, C).

    ``off`` (P,) and ``kw`` (P, W) hold one offset and one set of taps per index of axis 0
    (P = A), or one for all (P = 1). Returns a new (A, lout, C) array. Rows along axis 2 are
    contiguous in both arrays, so each run is one multiply-add over a contiguous block.
    """
    a_len, length, c_len = inp.shape
    per_layer = kw.shape[0] > 1
    out = np.zeros((a_len, lout, c_len))
    flat_in = inp.reshape(a_len, length * c_len)
    flat_out = out.reshape(a_len, lout * c_len)
    runs = _runs(kw, off, 0, length, lout, n)
    for a in range(a_len):
        p = a if per_layer else 0
        if per_layer and a > 0:
            runs = _runs(kw, off, p, length, lout, n)
        for r in range(runs.shape[0]):
            k = kw[p, runs[r, 0]]
            delta, i0, i1 = runs[r, 1], runs[r, 2], runs[r, 3]
            cnt = (i1 - i0) * c_len
            dst = flat_out[a, (i0 + delta) * c_len : (i0 + delta) * c_len + cnt]
            src = flat_in[a, i0 * c_len : i0 * c_len + cnt]
            for q in range(cnt):  # row views + range index: vectorised
                dst[q] += k * src[q]
    return out


@njit(cache=True)
def op_last(inp, off, kw, lout, n):
    """Apply a 1D operator along the last axis of ``inp`` (A, B, L) (taps per index of axis 0,
    or one set for all, as in :func:`op_mid`). Returns a new (A, B, lout) array."""
    a_len, b_len, length = inp.shape
    per_layer = kw.shape[0] > 1
    out = np.zeros((a_len, b_len, lout))
    runs = _runs(kw, off, 0, length, lout, n)
    for a in range(a_len):
        p = a if per_layer else 0
        if per_layer and a > 0:
            runs = _runs(kw, off, p, length, lout, n)
        for r in range(runs.shape[0]):
            k = kw[p, runs[r, 0]]
            delta, i0, i1 = runs[r, 1], runs[r, 2], runs[r, 3]
            for b in range(b_len):
                dst = out[a, b, i0 + delta : i1 + delta]
                src = inp[a, b, i0:i1]
                for q in range(i1 - i0):
                    dst[q] += k * src[q]
    return out


@njit(cache=True)
def _window(p, n):
    """Local range (lo, length) of a box axis holding every True entry of projection ``p``.
    A box that spans the whole ring may hold them across its local end: then the whole axis."""
    s, ln = cover_arc(p, 0, n)
    if s + ln <= p.shape[0]:
        return s, ln
    return 0, p.shape[0]


@njit(cache=True)
def above(box, level):
    """Per-axis projections (θ', x', y') of the cells of ``box`` above ``level``, or-ed as bytes
    without branches (the row loop vectorises)."""
    lt, lx, ly = box.shape
    pt = np.zeros(lt, dtype=np.uint8)
    px = np.zeros(lx, dtype=np.uint8)
    py = np.zeros(ly, dtype=np.uint8)
    for t in range(lt):
        for x in range(lx):
            row = box[t, x]
            row_any = np.uint8(0)
            for y in range(ly):
                b = np.uint8(row[y] > level)
                py[y] |= b
                row_any |= b
            pt[t] |= row_any
            px[x] |= row_any
    return pt.astype(np.bool_), px.astype(np.bool_), py.astype(np.bool_)


@njit(cache=True)
def inhibit_clip(exc, taps0, taps1, taps2, off_within, weight, global_inh, n):
    """Steps 2-3 for one excited box ``exc``: ``max(exc - weight · inh - global_inh, 0)``, ``inh``
    being the inhibition kernel applied within the box.

    Inhibition is non-negative, so a cell with ``exc <= global_inh`` ends at zero whatever it
    is: ``inh`` is evaluated only over the window of cells above the global inhibition (the
    same sums, in the same order, as over the whole box). Returns the projections of the cells
    above the global inhibition (``pt, px, py``, over the box), the window's local start
    (``t0, x0, y0``), the activity over the window and the projections of its non-zero cells
    (``qt, qx, qy``); the window is empty if no cell is above the global inhibition.
    """
    lt, lx, ly = exc.shape
    pt, px, py = above(exc, global_inh)
    if not pt.any():
        none = np.zeros(0, dtype=np.bool_)
        return pt, px, py, 0, 0, 0, np.zeros((0, 0, 0)), none, none, none
    t0, nt = _window(pt, n[0])
    x0, nx = _window(px, n[1])
    y0, ny = _window(py, n[2])
    if weight > 0.0:
        r = off_within[0]
        off = np.empty(1, dtype=np.int64)
        off[0] = r - t0
        inh = op_mid(exc.reshape(1, lt, lx * ly), off, taps0, nt, n[0]).reshape(nt, lx, ly)
        off[0] = r - x0
        inh = op_mid(inh, off, taps1, nx, n[1])
        off[0] = r - y0
        inh = op_last(inh, off, taps2, ny, n[2])
    else:
        inh = np.zeros((nt, nx, ny))
    act = np.empty((nt, nx, ny))
    qt = np.zeros(nt, dtype=np.uint8)  # projections of the non-zero cells, or-ed as bytes
    qx = np.zeros(nx, dtype=np.uint8)  # without branches (the row loop vectorises)
    qy = np.zeros(ny, dtype=np.uint8)
    for t in range(nt):
        for x in range(nx):
            e_row = exc[t0 + t, x0 + x, y0 : y0 + ny]
            i_row = inh[t, x]
            a_row = act[t, x]
            row_any = np.uint8(0)
            for y in range(ny):
                v = e_row[y] - weight * i_row[y] - global_inh
                alive = v > 0.0
                a_row[y] = v if alive else 0.0
                b = np.uint8(alive)
                qy[y] |= b
                row_any |= b
            qt[t] |= row_any
            qx[x] |= row_any
    return pt, px, py, t0, x0, y0, act, qt.astype(np.bool_), qx.astype(np.bool_), qy.astype(np.bool_)


@njit(cache=True)
def inhibit_clip_crop(exc, taps0, taps1, taps2, off_within, weight, global_inh, start, n):
    """Steps 2-3 and the crop for one excited box ``exc`` starting at global ``start``
    (:func:`inhibit_clip`), then the smallest wrap-aware box holding every non-zero cell.
    Returns (new start (3,), activity, its sum); the activity is (0, 0, 0) if every cell is zero.
    """
    _, _, _, t0, x0, y0, act, qt, qx, qy = inhibit_clip(exc, taps0, taps1, taps2, off_within, weight, global_inh, n)
    if act.shape[0] == 0:
        return start.copy(), np.zeros((0, 0, 0)), 0.0
    win_start = np.empty(3, dtype=np.int64)
    win_start[0] = (start[0] + t0) % n[0]
    win_start[1] = (start[1] + x0) % n[1]
    win_start[2] = (start[2] + y0) % n[2]
    return crop(act, qt, qx, qy, win_start, n)


@njit(cache=True)
def cover_arc(p, start, n):
    """Smallest arc (global start, length) covering the True entries of projection ``p`` of a
    box starting at global index ``start`` on a ring of ``n``; (0, 0) if none."""
    length = p.shape[0]
    if length < n:
        lo = -1
        hi = -1
        for i in range(length):
            if p[i]:
                if lo < 0:
                    lo = i
                hi = i
        if lo < 0:
            return 0, 0
        return (start + lo) % n, hi - lo + 1
    # the box covers the whole ring: the arc starts after the widest gap between occupied cells
    # (gap = index difference to the next occupied cell, circularly; the first widest wins)
    ring = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        if p[i]:
            ring[(start + i) % n] = True
    first = -1
    for i in range(n):
        if ring[i]:
            first = i
            break
    if first < 0:
        return 0, 0
    best_gap, best_next = 0, first
    prev = first
    for i in range(first + 1, first + n + 1):
        j = i % n
        if ring[j]:
            gap = i - prev
            if gap > best_gap:
                best_gap, best_next = gap, j
            prev = i
    if best_gap == 1:  # every cell occupied
        return 0, n
    return best_next, n - best_gap + 1


@njit(cache=True)
def crop(act, pt, px, py, start, n):
    """Copy the non-zero part of ``act`` (projections ``pt, px, py``) into its smallest
    wrap-aware box. Returns (new_start, new activity, sum)."""
    s0, l0 = cover_arc(pt, start[0], n[0])
    s1, l1 = cover_arc(px, start[1], n[1])
    s2, l2 = cover_arc(py, start[2], n[2])
    new_start = np.empty(3, dtype=np.int64)
    if l0 == 0:
        new_start[:] = start
        return new_start, np.zeros((0, 0, 0)), 0.0
    new_start[0], new_start[1], new_start[2] = s0, s1, s2
    # offsets of the new box inside the old one (the new box lies within the old)
    o0 = (s0 - start[0]) % n[0]
    o1 = (s1 - start[1]) % n[1]
    o2 = (s2 - start[2]) % n[2]
    ly = act.shape[2]
    out = np.empty((l0, l1, l2))
    total = 0.0
    contiguous = o2 + l2 <= ly  # the y range does not wrap round the old box
    for t in range(l0):
        st = (o0 + t) % n[0]
        for x in range(l1):
            sx = (o1 + x) % n[1]
            dst = out[t, x]
            if contiguous:
                src = act[st, sx, o2 : o2 + l2]
                for y in range(l2):
                    dst[y] = src[y]
                    total += src[y]
            else:
                for y in range(l2):
                    sy = (o2 + y) % n[2]
                    v = act[st, sx, sy] if sy < ly else 0.0
                    dst[y] = v
                    total += v
    return new_start, out, total


@njit(cache=True)
def shift_taps(shift):
    """Linear-interpolation taps for real shifts (cells) per layer: offsets from the smallest
    integer shift, taps (1 - f, f), the smallest integer shift and the output growth."""
    b = shift.shape[0]
    off = np.empty(b, dtype=np.int64)
    kw = np.empty((b, 2))
    lo = np.int64(1 << 62)
    hi = -lo
    for i in range(b):
        s = np.floor(shift[i])
        f = shift[i] - s
        si = np.int64(s)
        off[i] = si
        kw[i, 0] = 1.0 - f
        kw[i, 1] = f
        lo = min(lo, si)
        hi = max(hi, si)
    for i in range(b):
        off[i] -= lo
    return off, kw, lo, hi - lo + 1


@njit(cache=True)
def neighbourhood_sums(act, rel, rad, n):
    """Per-axis sums of the activity of a box over the (2·rad + 1)³ neighbourhood that starts at
    box-relative index ``rel`` (wrap-aware; cells outside the box count as zero). Returns (3, 2rad+1)."""
    w = 2 * rad + 1
    sums = np.zeros((3, w))
    lt, lx, ly = act.shape
    for a in range(w):
        t = (rel[0] + a) % n[0]
        if t >= lt:
            continue
        for b in range(w):
            x = (rel[1] + b) % n[1]
            if x >= lx:
                continue
            for c in range(w):
                y = (rel[2] + c) % n[2]
                if y >= ly:
                    continue
                v = act[t, x, y]
                sums[0, a] += v
                sums[1, b] += v
                sums[2, c] += v
    return sums


# --------------------------------------------------------------------- fused per-box steps
@njit(cache=True)
def excite(act, taps0, taps1, taps2, off, n):
    """Separable local excitation along θ', x', y' (taps (1, W) per axis, ``off`` = [0]): the
    output box is the input box grown by the kernel radius on each side (at most the ring)."""
    lt, lx, ly = act.shape
    lout = min(lt + taps0.shape[1] - 1, n[0])
    out = op_mid(act.reshape(1, lt, lx * ly), off, taps0, lout, n[0]).reshape(lout, lx, ly)
    out = op_mid(out, off, taps1, min(lx + taps1.shape[1] - 1, n[1]), n[1])
    return op_last(out, off, taps2, min(ly + taps2.shape[1] - 1, n[2]), n[2])


@njit(cache=True)
def network_box(
    act, start, n, exc0, exc1, exc2, inh0, inh1, inh2, off_spread, off_within, r_exc, inhibit_weight, global_inhibition
):
    """One attractor iteration of one box, before normalisation: local excitation (the box grows
    by ``r_exc``), local inhibition within that box, global inhibition, clip at zero, crop.
    Returns (new start, activity, mass); the activity is (0, 0, 0) if nothing survived."""
    exc = excite(act, exc0, exc1, exc2, off_spread, n)
    grown = np.empty(3, dtype=np.int64)
    for a in range(3):
        grown[a] = (start[a] - r_exc) % n[a]
    return inhibit_clip_crop(exc, inh0, inh1, inh2, off_within, inhibit_weight, global_inhibition, grown, n)


@njit(cache=True)
def heading_shifts(t_start, lt, n_theta, cos_t, sin_t, dist):
    """Shifts (x', y' cells) of ``lt`` heading layers from global layer ``t_start``, each moved
    ``dist`` cells along its own heading."""
    sx = np.empty(lt)
    sy = np.empty(lt)
    for t in range(lt):
        g = (t_start + t) % n_theta
        sx[t] = dist * cos_t[g]
        sy[t] = dist * sin_t[g]
    return sx, sy


@njit(cache=True)
def path_integrate_box(act, start, n, cos_t, sin_t, dist, rot):
    """Path integration of one box: each heading layer θ' translated by ``dist`` cells along its
    heading (``cos_t``/``sin_t`` per global heading cell), then all layers rotated by ``rot``
    heading cells; linear sub-cell interpolation, wrap-aware. Returns (new start, activity)."""
    new_start = start.copy()
    lt = act.shape[0]
    if dist != 0.0:
        sx, sy = heading_shifts(start[0], lt, n[0], cos_t, sin_t, dist)
        off, kw, lo, growth = shift_taps(sx)
        act = op_mid(act, off, kw, min(act.shape[1] + growth, n[1]), n[1])
        new_start[1] = (start[1] + lo) % n[1]
        off, kw, lo, growth = shift_taps(sy)
        act = op_last(act, off, kw, min(act.shape[2] + growth, n[2]), n[2])
        new_start[2] = (start[2] + lo) % n[2]
    if rot != 0.0:
        s = np.empty(1)
        s[0] = rot
        off, kw, lo, growth = shift_taps(s)
        lx, ly = act.shape[1], act.shape[2]
        lout = min(lt + growth, n[0])
        act = op_mid(act.reshape(1, lt, lx * ly), off, kw, lout, n[0]).reshape(lout, lx, ly)
        new_start[0] = (start[0] + lo) % n[0]
    return new_start, act


@njit(cache=True)
def strongest_cell(act):
    """(value, box-relative (θ, x, y) index) of the first strongest cell of a box."""
    lt, lx, ly = act.shape
    best = -1.0
    bt = bx = by = 0
    for t in range(lt):
        for x in range(lx):
            for y in range(ly):
                if act[t, x, y] > best:
                    best = act[t, x, y]
                    bt, bx, by = t, x, y
    idx = np.empty(3, dtype=np.int64)
    idx[0], idx[1], idx[2] = bt, bx, by
    return best, idx


@njit(cache=True)
def refine_peak(cg, sums, rad, n):
    """Peak (θ, x, y) from the global strongest cell ``cg`` and the per-axis neighbourhood sums:
    the cell plus the circular weighted mean offset of its neighbourhood, wrapped into [0, n)."""
    peak = np.empty(3)
    for a in range(3):
        s = 0.0
        c = 0.0
        for k in range(2 * rad + 1):
            ang = (k - rad) * (2.0 * np.pi / n[a])
            s += sums[a, k] * np.sin(ang)
            c += sums[a, k] * np.cos(ang)
        p = (cg[a] + np.arctan2(s, c) * n[a] / (2.0 * np.pi)) % n[a]
        peak[a] = 0.0 if p >= n[a] else p  # (-tiny) % n rounds to n
    return peak


@njit(cache=True)
def peak_of_box(act, start, n, rad):
    """The peak (x', y', θ') of a network held in one box: its strongest cell refined by
    :func:`refine_peak` over the neighbourhood sums (the steps of ``PoseCells._update_peak``)."""
    _, idx = strongest_cell(act)
    return peak_at(act, start, idx, n, rad)


@njit(cache=True)
def peak_at(act, start, idx, n, rad):
    """The peak (x', y', θ') of a box whose strongest cell is at box-relative ``idx``: the cell
    refined by :func:`refine_peak` over the neighbourhood sums."""
    cg = np.empty(3, dtype=np.int64)
    rel = np.empty(3, dtype=np.int64)
    for a in range(3):
        cg[a] = (start[a] + idx[a]) % n[a]
        rel[a] = (cg[a] - rad - start[a]) % n[a]
    p = refine_peak(cg, neighbourhood_sums(act, rel, rad, n), rad, n)
    out = np.empty(3)
    out[0], out[1], out[2] = p[1], p[2], p[0]
    return out


@njit(cache=True)
def cells_at_least(act, start, n, threshold):
    """Cells of a box with activity > 0 and >= ``threshold``: linear indices over (x', y', θ')
    (``(x·ny + y)·nθ + θ``, sorted) and their activities."""
    lt, lx, ly = act.shape
    count = 0
    for t in range(lt):
        for x in range(lx):
            for y in range(ly):
                v = act[t, x, y]
                if v > 0.0 and v >= threshold:
                    count += 1
    lin = np.empty(count, dtype=np.int64)
    val = np.empty(count)
    # visit the cells in ascending linear index (x' major, then y', then θ'): no sort needed
    ot, ox, oy = _ascending(start[0], lt, n[0]), _ascending(start[1], lx, n[1]), _ascending(start[2], ly, n[2])
    k = 0
    for i in range(lx):
        x = ox[i]
        gx = (start[1] + x) % n[1]
        for j in range(ly):
            y = oy[j]
            base = (gx * n[2] + (start[2] + y) % n[2]) * n[0]
            for m in range(lt):
                t = ot[m]
                v = act[t, x, y]
                if v > 0.0 and v >= threshold:
                    lin[k] = base + (start[0] + t) % n[0]
                    val[k] = v
                    k += 1
    return lin, val


@njit(cache=True)
def _ascending(start, length, n):
    """Local indices ``0..length-1`` of a box axis starting at global ``start`` on a ring of ``n``
    (``length <= n``), ordered by ascending global index ``(start + i) mod n``."""
    order = np.empty(length, dtype=np.int64)
    wrap = min(max(n - start, 0), length)  # local indices below this do not wrap
    k = 0
    for i in range(wrap, length):
        order[k] = i
        k += 1
    for i in range(wrap):
        order[k] = i
        k += 1
    return order


# --------------------------------------------------------------------- injection and merging
@njit(cache=True)
def add_inside(act, start, n, g, energy, todo):
    """Add ``energy[c]`` at global cell ``g[:, c]`` (θ, x, y) for every pending cell (``todo``)
    that lies inside the box; those cells are marked done."""
    lt, lx, ly = act.shape
    for c in range(g.shape[1]):
        if todo[c]:
            t = (g[0, c] - start[0]) % n[0]
            x = (g[1, c] - start[1]) % n[1]
            y = (g[2, c] - start[2]) % n[2]
            if t < lt and x < lx and y < ly:
                act[t, x, y] += energy[c]
                todo[c] = False


@njit(cache=True)
def box_of_cells(g, energy, n):
    """The smallest wrap-aware box holding global cells ``g`` (3, k), with their energies added.
    Returns (start, activity)."""
    start = np.empty(3, dtype=np.int64)
    shape = np.empty(3, dtype=np.int64)
    for a in range(3):
        p = np.zeros(n[a], dtype=np.bool_)
        for c in range(g.shape[1]):
            p[g[a, c]] = True
        start[a], shape[a] = cover_arc(p, 0, n[a])
    act = np.zeros((shape[0], shape[1], shape[2]))
    for c in range(g.shape[1]):
        act[(g[0, c] - start[0]) % n[0], (g[1, c] - start[1]) % n[1], (g[2, c] - start[2]) % n[2]] += energy[c]
    return start, act


@njit(cache=True)
def rebox_add(out, out_start, act, start, n):
    """Add a box's activity into a larger box ``out`` that covers all of it."""
    lt, lx, ly = act.shape
    for t in range(lt):
        ot = (start[0] + t - out_start[0]) % n[0]
        for x in range(lx):
            ox = (start[1] + x - out_start[1]) % n[1]
            for y in range(ly):
                out[ot, ox, (start[2] + y - out_start[2]) % n[2]] += act[t, x, y]


@njit(cache=True)
def decode_linear(lin, n):
    """Global cells (3, k) as (θ, x, y) of linear indices ``(x·ny + y)·nθ + θ``."""
    g = np.empty((3, lin.shape[0]), dtype=np.int64)
    for c in range(lin.shape[0]):
        v = lin[c]
        g[0, c] = v % n[0]
        v //= n[0]
        g[2, c] = v % n[2]
        g[1, c] = v // n[2]
    return g


@njit(cache=True)
def boxes_of_clusters(g, energy, todo, n, radius):
    """New boxes for the pending cells (``todo``) of global cells ``g`` (3, k), one per cluster:
    the first pending cell seeds a cluster of every pending cell within ``radius`` cells of it on
    every axis (wrap-aware), the next cell left seeds the next. Returns the boxes' starts (m, 3),
    shapes (m, 3) and activities (:func:`box_of_cells`, cells added in their order) one after the
    other, flattened."""
    k = g.shape[1]
    label = np.full(k, -1, dtype=np.int64)
    count = 0
    for s in range(k):
        if not todo[s] or label[s] >= 0:
            continue
        for c in range(s, k):
            if not todo[c] or label[c] >= 0:
                continue
            near = True
            for a in range(3):
                d = abs(g[a, c] - g[a, s])
                if min(d, n[a] - d) > radius:
                    near = False
                    break
            if near:
                label[c] = count
        count += 1
    starts = np.empty((count, 3), dtype=np.int64)
    shapes = np.empty((count, 3), dtype=np.int64)
    parts = List()
    size = 0
    for j in range(count):
        m = 0
        for c in range(k):
            if label[c] == j:
                m += 1
        gj = np.empty((3, m), dtype=np.int64)
        ej = np.empty(m)
        i = 0
        for c in range(k):
            if label[c] == j:
                gj[:, i] = g[:, c]
                ej[i] = energy[c]
                i += 1
        start, act = box_of_cells(gj, ej, n)
        starts[j] = start
        for a in range(3):
            shapes[j, a] = act.shape[a]
        parts.append(act.ravel())
        size += act.size
    values = np.empty(size)
    pos = 0
    for j in range(count):
        values[pos : pos + parts[j].shape[0]] = parts[j]
        pos += parts[j].shape[0]
    return starts, shapes, values


@njit(cache=True)
def ring_gap(s1, l1, s2, l2, n):
    """Number of empty cells between two arcs (start, length) of a ring of ``n`` (0 if they touch
    or overlap)."""
    if (s2 - s1) % n < l1 or (s1 - s2) % n < l2:
        return 0
    return min((s2 - (s1 + l1)) % n, (s1 - (s2 + l2)) % n)


@njit(cache=True)
def arc_union(s1, l1, s2, l2, n):
    """Smallest arc (start, length) of a ring of ``n`` covering two arcs."""
    if l1 >= n:
        return s1, n
    if l2 >= n:
        return s2, n
    a = max(l1, (s2 - s1) % n + l2)  # starting at s1
    b = max(l2, (s1 - s2) % n + l1)  # starting at s2
    if min(a, b) >= n:
        return 0, n
    if a <= b:
        return s1, a
    return s2, b


@njit(cache=True)
def interacting_groups(starts, shapes, n, reach):
    """Groups of boxes (``starts``, ``shapes`` (k, 3)) that interact within one iteration: boxes
    no more than ``reach`` empty cells apart on every axis are grouped, and a group's covering
    box may reach further boxes, so grouping repeats until no two groups interact (each group
    takes in the later ones it reaches, in order). Returns the groups in order (their slots), each
    slot's covering box (start, length per axis) and its member boxes in the order they joined
    (``members[g, :count[g]]``)."""
    k = starts.shape[0]
    arc_s = starts.copy()
    arc_l = shapes.copy()
    members = np.empty((k, k), dtype=np.int64)
    count = np.ones(k, dtype=np.int64)
    order = np.arange(k)
    for g in range(k):
        members[g, 0] = g
    m = k
    changed = True
    while changed and m > 1:
        changed = False
        i = 0
        while i < m:
            gi = order[i]
            j = i + 1
            while j < m:
                gj = order[j]
                near = True
                for a in range(3):
                    if ring_gap(arc_s[gi, a], arc_l[gi, a], arc_s[gj, a], arc_l[gj, a], n[a]) > reach:
                        near = False
                        break
                if near:
                    for a in range(3):
                        arc_s[gi, a], arc_l[gi, a] = arc_union(
                            arc_s[gi, a], arc_l[gi, a], arc_s[gj, a], arc_l[gj, a], n[a]
                        )
                    for c in range(count[gj]):
                        members[gi, count[gi]] = members[gj, c]
                        count[gi] += 1
                    for q in range(j, m - 1):
                        order[q] = order[q + 1]
                    m -= 1
                    changed = True
                else:
                    j += 1
            i += 1
    return order[:m].copy(), arc_s, arc_l, members, count
