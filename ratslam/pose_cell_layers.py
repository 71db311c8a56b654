"""One pose-cell step of a large, mostly empty box, heading layer by heading layer (numba, cached
to disk).

Packets of different headings drift apart in a merged box, each θ' layer along its own heading,
so in a large box each layer's non-zero cells fill a small part of the layer. Here the box is
taken apart into its θ' layers, each stored as the rectangle (x' and y' ranges, box-local) that
holds its non-zero cells, and the step's one-axis operators (:mod:`ratslam.pose_cell_kernels`)
run rectangle by rectangle: a layer's rectangle grows by the taps along x' and y', a θ' operator
writes the union of the rectangles it reads. The local inhibition is evaluated only where it can
matter, on the bands of rows of each layer that hold cells above the global inhibition (a cell at
or below it ends at zero whatever its inhibition; a layer holding several packets has a band per
packet, as a rule), and the operators before it only over what each band reads. The
layers go back into one box after path integration.

Every cell evaluated receives the same non-zero terms in the same order as in the whole-box
operators (the taps in ascending order; a term left out is a product of an exact zero), and the
inhibition's window, the crop, the normalising total (summed in the box's cell order) and the
strongest cell are the whole box's: :func:`step_one_box` returns bit for bit what
:func:`ratslam.pose_cell_split.step_one_box` returns (tested).

Layers are one flat array of values with, per layer, its rectangle (a row ``(x0, x1, y0, y1)``,
half-open, of a (layers, 4) array; empty if ``x0 >= x1``) and the offset of its values (row by
row) in the flat array.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from . import pose_cell_kernels as K


# --------------------------------------------------------------------- layers of a box
@njit(cache=True)
def layer_windows(act):
    """The rectangle of each θ' layer of ``act`` (θ', x', y') holding its non-zero cells."""
    lt, lx, ly = act.shape
    win = np.zeros((lt, 4), dtype=np.int64)
    for t in range(lt):
        x0, x1, y0, y1 = lx, 0, ly, 0
        for x in range(lx):
            row = act[t, x]
            row_any = np.uint8(0)
            for y in range(ly):  # branch-free: vectorises
                row_any |= np.uint8(row[y] != 0.0)
            if not row_any:
                continue
            lo = 0
            while row[lo] == 0.0:
                lo += 1
            hi = ly - 1
            while row[hi] == 0.0:
                hi -= 1
            x0 = min(x0, x)
            x1 = x + 1
            y0 = min(y0, lo)
            y1 = max(y1, hi + 1)
        if x0 < x1:
            win[t, 0], win[t, 1], win[t, 2], win[t, 3] = x0, x1, y0, y1
    return win


@njit(cache=True)
def sparse_windows(act, max_cover):
    """The rectangles of the layers of ``act`` (:func:`layer_windows`) if together they cover at
    most ``max_cover`` of the box, else none (a (0, 4) array): the box is stepped whole."""
    rect = layer_windows(act)
    cells = 0
    for t in range(rect.shape[0]):
        cells += max(rect[t, 1] - rect[t, 0], 0) * max(rect[t, 3] - rect[t, 2], 0)
    if cells > max_cover * act.size:
        return rect[:0]
    return rect


@njit(cache=True)
def _size(rect, t):
    """Rows and columns of layer ``t``'s rectangle."""
    return max(rect[t, 1] - rect[t, 0], 0), max(rect[t, 3] - rect[t, 2], 0)


@njit(cache=True)
def _zeros_over(rect):
    """Zero layers over the rectangles: (values, offsets)."""
    pos = np.zeros(rect.shape[0], dtype=np.int64)
    size = 0
    for t in range(rect.shape[0]):
        pos[t] = size
        h, w = _size(rect, t)
        size += h * w
    return np.zeros(size), pos


@njit(cache=True)
def _row(vals, pos, rect, t, x):
    """Row ``x`` (counted from the rectangle's first) of layer ``t``'s values (a view)."""
    w = max(rect[t, 3] - rect[t, 2], 0)
    return vals[pos[t] + x * w : pos[t] + (x + 1) * w]


@njit(cache=True)
def to_layers(act, rect):
    """The layers of a box over their rectangles (:func:`layer_windows`): (values, offsets,
    rectangles)."""
    vals, pos = _zeros_over(rect)
    for t in range(act.shape[0]):
        h, w = _size(rect, t)
        for x in range(h):
            src = act[t, rect[t, 0] + x, rect[t, 2] : rect[t, 3]]
            row = _row(vals, pos, rect, t, x)
            for y in range(w):
                row[y] = src[y]
    return vals, pos, rect


@njit(cache=True)
def to_box(vals, pos, rect, shape):
    """The box of ``shape`` (θ', x', y') holding the layers."""
    act = np.zeros((shape[0], shape[1], shape[2]))
    for t in range(shape[0]):
        h, w = _size(rect, t)
        x0, y0 = rect[t, 0], rect[t, 2]
        for x in range(h):
            dst = act[t, x0 + x, y0 : y0 + w]
            src = _row(vals, pos, rect, t, x)
            for y in range(w):
                dst[y] = src[y]
    return act


@njit(cache=True)
def _grow(rect, t, x0, x1, y0, y1):
    """Widen layer ``t``'s rectangle to hold ``[x0, x1) × [y0, y1)`` (nothing if that is empty)."""
    if x0 >= x1 or y0 >= y1:
        return
    if rect[t, 0] >= rect[t, 1]:
        rect[t, 0], rect[t, 1], rect[t, 2], rect[t, 3] = x0, x1, y0, y1
    else:
        rect[t, 0] = min(rect[t, 0], x0)
        rect[t, 1] = max(rect[t, 1], x1)
        rect[t, 2] = min(rect[t, 2], y0)
        rect[t, 3] = max(rect[t, 3], y1)


# --------------------------------------------------------------------- one-axis operators
# Each operator is split in two: which output rectangle each layer gets (the image of the input
# rectangles, or a rectangle asked for), then the sums over it. Runs are the operator's
# contiguous runs (:func:`ratslam.pose_cell_kernels._runs`), for all layers or per layer.
@njit(cache=True)
def _image(lo, hi, runs):
    """Bounding range of the outputs of inputs ``[lo, hi)`` (empty: lo >= hi)."""
    a, b = np.int64(1 << 62), -np.int64(1 << 62)
    for r in range(runs.shape[0]):
        i0, i1 = max(runs[r, 2], lo), min(runs[r, 3], hi)
        if i0 < i1:
            a = min(a, i0 + runs[r, 1])
            b = max(b, i1 + runs[r, 1])
    return a, b


@njit(cache=True)
def _preimage(lo, hi, runs):
    """Bounding range of the inputs whose outputs land in ``[lo, hi)``."""
    a, b = np.int64(1 << 62), -np.int64(1 << 62)
    for r in range(runs.shape[0]):
        i0, i1 = max(runs[r, 2], lo - runs[r, 1]), min(runs[r, 3], hi - runs[r, 1])
        if i0 < i1:
            a = min(a, i0)
            b = max(b, i1)
    return a, b


@njit(cache=True)
def _theta_image(rect, runs, lout):
    """Output rectangles of a θ' operator: each the union of the rectangles it reads."""
    want = np.zeros((lout, 4), dtype=np.int64)
    for r in range(runs.shape[0]):
        for i in range(runs[r, 2], runs[r, 3]):
            _grow(want, i + runs[r, 1], rect[i, 0], rect[i, 1], rect[i, 2], rect[i, 3])
    return want


@njit(cache=True)
def _theta(vals, pos, rect, kw, runs, layer, want):
    """A θ' operator (one set of taps) evaluated over rectangles ``want`` of output layers
    ``layer`` (several rectangles may share a layer)."""
    out, opos = _zeros_over(want)
    for p in range(want.shape[0]):
        if want[p, 0] >= want[p, 1]:
            continue
        o = layer[p]
        for r in range(runs.shape[0]):  # the taps in ascending order, as in the whole box
            i = o - runs[r, 1]
            if i < runs[r, 2] or i >= runs[r, 3]:
                continue
            k = kw[0, runs[r, 0]]
            xa, xb = max(rect[i, 0], want[p, 0]), min(rect[i, 1], want[p, 1])
            ya, yb = max(rect[i, 2], want[p, 2]), min(rect[i, 3], want[p, 3])
            for x in range(xa, xb):
                d = _row(out, opos, want, p, x - want[p, 0])[ya - want[p, 2] : yb - want[p, 2]]
                s = _row(vals, pos, rect, i, x - rect[i, 0])[ya - rect[i, 2] : yb - rect[i, 2]]
                for q in range(yb - ya):
                    d[q] += k * s[q]
    return out, opos


@njit(cache=True)
def _axis_image(rect, kw, off, length, lout, n, axis):
    """Output rectangles of an x' (``axis`` 1) or y' (2) operator, taps per layer or one set."""
    want = np.zeros_like(rect)
    runs = K._runs(kw, off, 0, length, lout, n)
    for t in range(rect.shape[0]):
        if rect[t, 0] >= rect[t, 1]:
            continue
        if kw.shape[0] > 1 and t > 0:
            runs = K._runs(kw, off, t, length, lout, n)
        if axis == 1:
            a, b = _image(rect[t, 0], rect[t, 1], runs)
            _grow(want, t, a, b, rect[t, 2], rect[t, 3])
        else:
            a, b = _image(rect[t, 2], rect[t, 3], runs)
            _grow(want, t, rect[t, 0], rect[t, 1], a, b)
    return want


@njit(cache=True)
def _x(vals, pos, rect, kw, off, length, lout, n, want):
    """An x' operator (taps per layer or one set) evaluated over the rectangles ``want``."""
    out, opos = _zeros_over(want)
    runs = K._runs(kw, off, 0, length, lout, n)
    for t in range(rect.shape[0]):
        ya, yb = max(rect[t, 2], want[t, 2]), min(rect[t, 3], want[t, 3])
        if want[t, 0] >= want[t, 1] or rect[t, 0] >= rect[t, 1] or ya >= yb:
            continue
        p = t if kw.shape[0] > 1 else 0
        if p > 0:
            runs = K._runs(kw, off, p, length, lout, n)
        for r in range(runs.shape[0]):
            k = kw[p, runs[r, 0]]
            delta = runs[r, 1]
            i0 = max(runs[r, 2], rect[t, 0], want[t, 0] - delta)
            i1 = min(runs[r, 3], rect[t, 1], want[t, 1] - delta)
            for i in range(i0, i1):
                d = _row(out, opos, want, t, i + delta - want[t, 0])[ya - want[t, 2] : yb - want[t, 2]]
                s = _row(vals, pos, rect, t, i - rect[t, 0])[ya - rect[t, 2] : yb - rect[t, 2]]
                for q in range(yb - ya):
                    d[q] += k * s[q]
    return out, opos


@njit(cache=True)
def _y(vals, pos, rect, kw, off, length, lout, n, want):
    """A y' operator (taps per layer or one set) evaluated over the rectangles ``want``."""
    out, opos = _zeros_over(want)
    runs = K._runs(kw, off, 0, length, lout, n)
    for t in range(rect.shape[0]):
        xa, xb = max(rect[t, 0], want[t, 0]), min(rect[t, 1], want[t, 1])
        if want[t, 0] >= want[t, 1] or rect[t, 0] >= rect[t, 1] or xa >= xb:
            continue
        p = t if kw.shape[0] > 1 else 0
        if p > 0:
            runs = K._runs(kw, off, p, length, lout, n)
        for r in range(runs.shape[0]):
            k = kw[p, runs[r, 0]]
            delta = runs[r, 1]
            j0 = max(runs[r, 2], rect[t, 2], want[t, 2] - delta)
            j1 = min(runs[r, 3], rect[t, 3], want[t, 3] - delta)
            if j0 >= j1:
                continue
            for x in range(xa, xb):
                d = _row(out, opos, want, t, x - want[t, 0])[j0 + delta - want[t, 2] : j1 + delta - want[t, 2]]
                s = _row(vals, pos, rect, t, x - rect[t, 0])[j0 - rect[t, 2] : j1 - rect[t, 2]]
                for q in range(j1 - j0):
                    d[q] += k * s[q]
    return out, opos


@njit(cache=True)
def _theta_op(vals, pos, rect, off, kw, length, lout, n):
    """A θ' operator over the layers' rectangles: (values, offsets, rectangles)."""
    runs = K._runs(kw, off, 0, length, lout, n)
    want = _theta_image(rect, runs, lout)
    out, opos = _theta(vals, pos, rect, kw, runs, np.arange(lout), want)
    return out, opos, want


@njit(cache=True)
def _axis_op(vals, pos, rect, off, kw, length, lout, n, axis):
    """An x' (``axis`` 1) or y' (2) operator over the layers' rectangles."""
    want = _axis_image(rect, kw, off, length, lout, n, axis)
    if axis == 1:
        out, opos = _x(vals, pos, rect, kw, off, length, lout, n, want)
    else:
        out, opos = _y(vals, pos, rect, kw, off, length, lout, n, want)
    return out, opos, want


# --------------------------------------------------------------------- the steps
@njit(cache=True)
def _above(vals, pos, rect, level, shape):
    """Per-axis projections of the cells above ``level`` (not negative), and the bands holding
    them: runs of consecutive rows of a layer with cells above, each with the y' range of those
    cells, as rows ``(layer, x0, x1, y0, y1)`` (bands of one layer never share a row)."""
    pt = np.zeros(shape[0], dtype=np.bool_)
    px = np.zeros(shape[1], dtype=np.bool_)
    py = np.zeros(shape[2], dtype=np.uint8)
    rows = 0
    for t in range(shape[0]):
        rows += _size(rect, t)[0]
    bands = np.zeros((rows, 5), dtype=np.int64)
    k = 0
    for t in range(shape[0]):
        h, w = _size(rect, t)
        x0, y0 = rect[t, 0], rect[t, 2]
        open_band = False
        for x in range(h):
            row = _row(vals, pos, rect, t, x)
            row_any = np.uint8(0)
            for y in range(w):
                b = np.uint8(row[y] > level)
                py[y0 + y] |= b
                row_any |= b
            if not row_any:
                open_band = False
                continue
            pt[t] = px[x0 + x] = True
            a = 0
            while not row[a] > level:
                a += 1
            c = w - 1
            while not row[c] > level:
                c -= 1
            if not open_band:
                bands[k, 0], bands[k, 1], bands[k, 3], bands[k, 4] = t, x0 + x, y0 + a, y0 + c + 1
                k += 1
                open_band = True
            bands[k - 1, 2] = x0 + x + 1
            bands[k - 1, 3] = min(bands[k - 1, 3], y0 + a)
            bands[k - 1, 4] = max(bands[k - 1, 4], y0 + c + 1)
    return pt, px, py.astype(np.bool_), bands[:k]


@njit(cache=True)
def _inhibit_clip(vals, pos, rect, shape, taps0, taps1, taps2, off_within, weight, global_inh, n):
    """:func:`ratslam.pose_cell_kernels.inhibit_clip` on an excited box held as layers: the
    window's local start (``t0, x0, y0``) and shape, the surviving activity over it as layers
    and the projections of its non-zero cells (``qt, qx, qy``). The inhibition is evaluated on
    the bands of cells above the global inhibition (:func:`_above`), and the θ' and x' passes
    over what each band reads."""
    pt, px, py, hot = _above(vals, pos, rect, global_inh, shape)
    wshape = np.zeros(3, dtype=np.int64)
    if not pt.any():
        no = np.zeros((0, 4), dtype=np.int64)
        return 0, 0, 0, wshape, np.zeros(0), np.zeros(0, dtype=np.int64), no, pt, px, py
    t0, nt = K._window(pt, n[0])
    x0, nx = K._window(px, n[1])
    y0, ny = K._window(py, n[2])
    wshape[0], wshape[1], wshape[2] = nt, nx, ny
    # the bands to evaluate, in the window's coordinates
    nb = hot.shape[0]
    layer = hot[:, 0] - t0
    target = np.empty((nb, 4), dtype=np.int64)
    for p in range(nb):
        target[p, 0], target[p, 1] = hot[p, 1] - x0, hot[p, 2] - x0
        target[p, 2], target[p, 3] = hot[p, 3] - y0, hot[p, 4] - y0
    if weight > 0.0:
        r = off_within[0]
        oy = np.full(1, r - y0, dtype=np.int64)
        ox = np.full(1, r - x0, dtype=np.int64)
        ot = np.full(1, r - t0, dtype=np.int64)
        runs_y = K._runs(taps2, oy, 0, shape[2], ny, n[2])
        runs_x = K._runs(taps1, ox, 0, shape[1], nx, n[1])
        want_x = np.zeros((nb, 4), dtype=np.int64)  # x' in the window, y' in the box
        want_t = np.zeros((nb, 4), dtype=np.int64)  # both in the box
        for p in range(nb):
            ja, jb = _preimage(target[p, 2], target[p, 3], runs_y)
            _grow(want_x, p, target[p, 0], target[p, 1], ja, jb)
            ia, ib = _preimage(target[p, 0], target[p, 1], runs_x)
            _grow(want_t, p, ia, ib, ja, jb)
        runs_t = K._runs(taps0, ot, 0, shape[0], nt, n[0])
        inh, ipos = _theta(vals, pos, rect, taps0, runs_t, layer, want_t)
        inh, ipos = _x(inh, ipos, want_t, taps1, ox, shape[1], nx, n[1], want_x)  # band by band
        inh, ipos = _y(inh, ipos, want_x, taps2, oy, shape[2], ny, n[2], target)
    else:
        inh, ipos = _zeros_over(target)
    # the surviving cells, first over the bands, then each layer's own rectangle
    act, apos = _zeros_over(target)
    qt = np.zeros(nt, dtype=np.bool_)
    qx = np.zeros(nx, dtype=np.bool_)
    qy = np.zeros(ny, dtype=np.uint8)
    alive = np.zeros((nt, 4), dtype=np.int64)
    for p in range(nb):
        t = layer[p]
        xa, ya = target[p, 0], target[p, 2]
        e = t0 + t
        h, w = _size(target, p)
        ex, ey = x0 - rect[e, 0], y0 - rect[e, 2]  # the cells above lie inside the layer's rectangle
        for x in range(h):
            e_row = _row(vals, pos, rect, e, xa + x + ex)
            i_row = _row(inh, ipos, target, p, x)
            a_row = _row(act, apos, target, p, x)
            row_any = np.uint8(0)
            for y in range(w):
                v = e_row[ya + y + ey] - weight * i_row[y] - global_inh
                live = v > 0.0
                a_row[y] = v if live else 0.0
                b = np.uint8(live)
                qy[ya + y] |= b
                row_any |= b
            if row_any:
                qt[t] = qx[xa + x] = True
                a = 0
                while a_row[a] == 0.0:
                    a += 1
                c = w - 1
                while a_row[c] == 0.0:
                    c -= 1
                _grow(alive, t, xa + x, xa + x + 1, ya + a, ya + c + 1)
    out, opos = _zeros_over(alive)
    for p in range(nb):  # the bands of a layer never share a row
        t = layer[p]
        if alive[t, 0] >= alive[t, 1]:
            continue
        for x in range(max(target[p, 0], alive[t, 0]), min(target[p, 1], alive[t, 1])):
            ya, yb = max(target[p, 2], alive[t, 2]), min(target[p, 3], alive[t, 3])
            d = _row(out, opos, alive, t, x - alive[t, 0])[ya - alive[t, 2] : yb - alive[t, 2]]
            s = _row(act, apos, target, p, x - target[p, 0])[ya - target[p, 2] : yb - target[p, 2]]
            for y in range(yb - ya):
                d[y] = s[y]
    return t0, x0, y0, wshape, out, opos, alive, qt, qx, qy.astype(np.bool_)


@njit(cache=True)
def _crop(vals, pos, rect, shape, pt, px, py, start, n):
    """:func:`ratslam.pose_cell_kernels.crop` of layers: (new start, new shape, values, offsets,
    rectangles, the sum in the box's cell order)."""
    s0, l0 = K.cover_arc(pt, start[0], n[0])
    s1, l1 = K.cover_arc(px, start[1], n[1])
    s2, l2 = K.cover_arc(py, start[2], n[2])
    new_shape = np.zeros(3, dtype=np.int64)
    if l0 == 0:
        return start.copy(), new_shape, vals, pos, rect, 0.0
    new_start = np.empty(3, dtype=np.int64)
    new_start[0], new_start[1], new_start[2] = s0, s1, s2
    new_shape[0], new_shape[1], new_shape[2] = l0, l1, l2
    o0 = (s0 - start[0]) % n[0]
    o1 = (s1 - start[1]) % n[1]
    o2 = (s2 - start[2]) % n[2]
    if o1 + l1 > shape[1] or o2 + l2 > shape[2]:  # the crop wraps round x' or y': cell by cell
        box = np.zeros((l0, l1, l2))
        total = 0.0
        for t in range(l0):
            st = (o0 + t) % n[0]
            for x in range(l1):
                sx = (o1 + x) % n[1] - rect[st, 0]
                if sx < 0 or sx >= rect[st, 1] - rect[st, 0]:
                    continue
                row = _row(vals, pos, rect, st, sx)
                for y in range(l2):
                    sy = (o2 + y) % n[2] - rect[st, 2]
                    v = row[sy] if 0 <= sy < row.shape[0] else 0.0
                    box[t, x, y] = v
                    total += v
        out, opos, orect = to_layers(box, layer_windows(box))
        return new_start, new_shape, out, opos, orect, total
    # the same values, the layers renumbered and their rectangles moved
    opos = np.zeros(l0, dtype=np.int64)
    orect = np.zeros((l0, 4), dtype=np.int64)
    total = 0.0
    for t in range(l0):
        st = (o0 + t) % n[0]
        opos[t] = pos[st]
        if rect[st, 0] < rect[st, 1]:
            orect[t, 0], orect[t, 1] = rect[st, 0] - o1, rect[st, 1] - o1
            orect[t, 2], orect[t, 3] = rect[st, 2] - o2, rect[st, 3] - o2
        h, w = _size(orect, t)
        for x in range(h):  # the box's cell order: x', then y'
            row = _row(vals, opos, orect, t, x)
            for y in range(w):
                total += row[y]
    return new_start, new_shape, vals, opos, orect, total


@njit(cache=True)
def step_one_box(
    act,
    rect,
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
    """:func:`ratslam.pose_cell_split.step_one_box` (the attractor iteration, the normalisation,
    path integration and the peak of a network held in one box), layer by layer (``rect`` its
    layers' rectangles, :func:`layer_windows`); bit for bit the same (activity survived, new start,
    activity, peak (x', y', θ'))."""
    vals, pos, rect = to_layers(act, rect)
    shape = np.empty(3, dtype=np.int64)
    for a in range(3):
        shape[a] = act.shape[a]
    # 1. local excitation: the box grows by the excitation radius on each side
    grown = np.empty(3, dtype=np.int64)
    for a in range(3):
        grown[a] = (start[a] - r_exc) % n[a]
    lout = min(shape[0] + exc0.shape[1] - 1, n[0])
    vals, pos, rect = _theta_op(vals, pos, rect, off_spread, exc0, shape[0], lout, n[0])
    shape[0] = lout
    lout = min(shape[1] + exc1.shape[1] - 1, n[1])
    vals, pos, rect = _axis_op(vals, pos, rect, off_spread, exc1, shape[1], lout, n[1], 1)
    shape[1] = lout
    lout = min(shape[2] + exc2.shape[1] - 1, n[2])
    vals, pos, rect = _axis_op(vals, pos, rect, off_spread, exc2, shape[2], lout, n[2], 2)
    shape[2] = lout
    # 2-3. local inhibition within the excited box, global inhibition, clip at zero; the crop
    t0, x0, y0, wshape, vals, pos, rect, qt, qx, qy = _inhibit_clip(
        vals, pos, rect, shape, inh0, inh1, inh2, off_within, inhibit_weight, global_inhibition, n
    )
    if wshape[0] == 0:
        return False, grown, np.zeros((0, 0, 0)), np.zeros(3)
    at = np.empty(3, dtype=np.int64)
    at[0] = (grown[0] + t0) % n[0]
    at[1] = (grown[1] + x0) % n[1]
    at[2] = (grown[2] + y0) % n[2]
    start, shape, vals, pos, rect, total = _crop(vals, pos, rect, wshape, qt, qx, qy, at, n)
    if not total > 0.0:
        return False, start, np.zeros((0, 0, 0)), np.zeros(3)
    # 4. normalisation (every value the layers hold is the box's)
    vals *= 1.0 / total
    # 5. path integration: each layer along its heading, then all layers rotated
    new_start = start.copy()
    if dist != 0.0:
        sx, sy = K.heading_shifts(start[0], shape[0], n[0], cos_t, sin_t, dist)
        off, kw, lo, growth = K.shift_taps(sx)
        lout = min(shape[1] + growth, n[1])
        vals, pos, rect = _axis_op(vals, pos, rect, off, kw, shape[1], lout, n[1], 1)
        shape[1] = lout
        new_start[1] = (start[1] + lo) % n[1]
        off, kw, lo, growth = K.shift_taps(sy)
        lout = min(shape[2] + growth, n[2])
        vals, pos, rect = _axis_op(vals, pos, rect, off, kw, shape[2], lout, n[2], 2)
        shape[2] = lout
        new_start[2] = (start[2] + lo) % n[2]
    if rot != 0.0:
        s = np.empty(1)
        s[0] = rot
        off, kw, lo, growth = K.shift_taps(s)
        lout = min(shape[0] + growth, n[0])
        vals, pos, rect = _theta_op(vals, pos, rect, off, kw, shape[0], lout, n[0])
        shape[0] = lout
        new_start[0] = (start[0] + lo) % n[0]
    act = to_box(vals, pos, rect, shape)
    # the peak: the first strongest cell in the box's order, refined over its neighbourhood
    best = -1.0
    idx = np.zeros(3, dtype=np.int64)
    for t in range(shape[0]):
        h, w = _size(rect, t)
        for x in range(h):
            row = _row(vals, pos, rect, t, x)
            for y in range(w):
                if row[y] > best:
                    best = row[y]
                    idx[0], idx[1], idx[2] = t, rect[t, 0] + x, rect[t, 2] + y
    return True, new_start, act, K.peak_at(act, new_start, idx, n, peak_radius)
