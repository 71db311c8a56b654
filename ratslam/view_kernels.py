"""Compiled inner loops of the local view cells (numba, cached to disk)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def merge_associations(old_lin, old_w, old_t, new_lin, new_w, tick):
    """Hebbian max-rule merge of one view cell's associations.

    ``old_lin`` and ``new_lin`` are sorted, duplicate-free linear pose-cell indices. A cell in
    both keeps the stronger weight with the tick it was learnt at (the old entry wins ties);
    a new cell is added with ``tick``. Returns the merged (lin, w, tick) arrays, sorted.
    """
    m, k = old_lin.shape[0], new_lin.shape[0]
    lin = np.empty(m + k, dtype=np.int64)
    w = np.empty(m + k)
    t = np.empty(m + k, dtype=np.int64)
    i = j = o = 0
    while i < m or j < k:
        if j == k or (i < m and old_lin[i] < new_lin[j]):
            lin[o], w[o], t[o] = old_lin[i], old_w[i], old_t[i]
            i += 1
        elif i == m or new_lin[j] < old_lin[i]:
            lin[o], w[o], t[o] = new_lin[j], new_w[j], tick
            j += 1
        else:  # same cell: max rule, old wins ties
            if new_w[j] > old_w[i]:
                lin[o], w[o], t[o] = new_lin[j], new_w[j], tick
            else:
                lin[o], w[o], t[o] = old_lin[i], old_w[i], old_t[i]
            i += 1
            j += 1
        o += 1
    return lin[:o].copy(), w[:o].copy(), t[:o].copy()
