"""Compiled inner loop of the view-template matcher (numba, cached to disk): the best stored
template and shift for one view.

Templates are stored column-major, ``(n, width, height)``, so a column is contiguous. For each
stored template and each shift ``s`` the view's column ``j`` is compared with the template's
column ``j - s`` (wrapping when ``circular``, else over the columns both cover). The mean absolute
difference of the column means is a lower bound of the mean absolute difference of the pixels
(the triangle inequality, column by column), so a (template, shift) whose bound is not below the
best difference so far is skipped exactly; a pixel sum is abandoned as soon as it exceeds the best.
No ``fastmath``: sums are IEEE-exact and repeatable, and the first (template, shift) in search order
wins ties.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def best_template(view, view_cols, view_mean, templates, cols, means, n, shifts, circular, threshold, prefilter):
    """The stored template (of the first ``n``) and shift whose mean absolute difference to
    ``view`` (width, height) is least and below ``threshold``: returns (index, shift, difference),
    index -1 when none is below. ``prefilter``: skip templates whose mean differs from the view's
    by at least the threshold."""
    width, height = view.shape
    best, best_i, best_s = threshold, -1, 0
    for i in range(n):
        if prefilter and abs(means[i] - view_mean) >= threshold:
            continue
        for s in shifts:
            if circular:
                j0, j1 = 0, width
            else:
                j0, j1 = max(0, s), min(width, width + s)
            count = j1 - j0
            if count <= 0:
                continue
            # lower bound from the column means
            bound = 0.0
            for j in range(j0, j1):
                k = (j - s) % width
                bound += abs(view_cols[j] - cols[i, k])
            if bound >= best * count:
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
