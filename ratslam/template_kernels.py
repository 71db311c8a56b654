"""Compiled inner loop of the view-template matcher (numba, cached to disk): the best stored
template and shift for one view.

Templates are stored column-major, ``(n, width, height)``, so a column is contiguous. For each
stored template and each shift ``s`` the view's column ``j`` is compared with the template's
column ``j - s`` (wrapping when ``circular``, else over the columns both cover). The mean absolute
difference of the column means is a lower bound of the mean absolute difference of the pixels
(the triangle inequality, column by column), that of the half-column means a tighter one, and the
difference of the overlap's upper- and lower-half means a looser one that costs one subtraction
(from running sums over the columns), so
a (template, shift) whose bound is not below the best difference so far is skipped exactly; a
pixel sum is abandoned as soon as it exceeds the best. No ``fastmath``: sums are IEEE-exact and
repeatable, and the first (template, shift) in search order wins ties.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def best_template(
    view,
    view_cols,
    view_halves,
    view_cum,
    templates,
    cols,
    halves,
    cums,
    n,
    shifts,
    circular,
    threshold,
    prefilter,
):
    """The stored template (of the first ``n``) and shift whose mean absolute difference to
    ``view`` (width, height) is least and below ``threshold``: returns (index, shift, difference),
    index -1 when none is below. Templates are searched newest first (a view most often looks like
    the latest ones, and an early good match tightens the bounds). ``prefilter``: the cheap first
    bound, from the overlap's upper- and lower-half means (exact; once per template when
    ``circular``, the overlap being the whole image; off only to measure it). ``cols`` (n, width) are the
    column means, ``halves`` (n, width, 2) the means of each column's upper and lower half and
    ``cums`` (n, width + 1, 2) their running sums over the columns (the view's likewise)."""
    width, height = view.shape
    split = height // 2
    wu, wl = split / height, (height - split) / height
    best, best_i, best_s = threshold, -1, 0
    for i in range(n - 1, -1, -1):
        if prefilter and circular:  # the half means of the whole image, whatever the shift
            bound = wu * abs(view_cum[width, 0] - cums[i, width, 0])
            bound += wl * abs(view_cum[width, 1] - cums[i, width, 1])
            if bound >= best * width:  # the running sums add ``width`` column means
                continue
        for s in shifts:
            if circular:
                j0, j1 = 0, width
            else:
                j0, j1 = max(0, s), min(width, width + s)
            count = j1 - j0
            if count <= 0:
                continue
            # lower bounds: the overlap's upper- and lower-half means (O(1) from the running sums),
            # the column means, then the half-column means (each weighted by its rows)
            cap = best * count
            if prefilter and not circular:
                k0, k1 = j0 - s, j1 - s
                bound = wu * abs(view_cum[j1, 0] - view_cum[j0, 0] - cums[i, k1, 0] + cums[i, k0, 0])
                bound += wl * abs(view_cum[j1, 1] - view_cum[j0, 1] - cums[i, k1, 1] + cums[i, k0, 1])
                if bound >= cap:
                    continue
            bound = 0.0
            for j in range(j0, j1):
                bound += abs(view_cols[j] - cols[i, (j - s) % width])
                if bound >= cap:
                    break
            if bound >= cap:
                continue
            if split > 0:
                cap = best * count * height
                bound = 0.0
                for j in range(j0, j1):
                    k = (j - s) % width
                    bound += split * abs(view_halves[j, 0] - halves[i, k, 0])
                    bound += (height - split) * abs(view_halves[j, 1] - halves[i, k, 1])
                    if bound >= cap:
                        break
                if bound >= cap:
                    continue
            limit = best * count * height
            acc = 0.0
            for j in range(j0, j1):
                k = (j - s) % width
                for r in range(height):
                    acc += abs(view[j, r] - templates[i, k, r])
                if acc >= limit:
                    break
            if acc < limit:
                d = acc / (count * height)
                if d < best:
                    best, best_i, best_s = d, i, s
    return best_i, best_s, best


@njit(cache=True)
def all_differences(view, templates, n, shifts, circular):
    """Every stored template's least mean absolute difference over the shifts and its shift
    (the exhaustive reference of :func:`best_template`, for tests and diagnostics)."""
    width, height = view.shape
    out = np.full(n, np.inf)
    at = np.zeros(n, dtype=np.int64)
    for i in range(n):
        for s in shifts:
            if circular:
                j0, j1 = 0, width
            else:
                j0, j1 = max(0, s), min(width, width + s)
            count = j1 - j0
            if count <= 0:
                continue
            acc = 0.0
            for j in range(j0, j1):
                k = (j - s) % width
                for r in range(height):
                    acc += abs(view[j, r] - templates[i, k, r])
            d = acc / (count * height)
            if d < out[i]:
                out[i], at[i] = d, s
    return out, at
