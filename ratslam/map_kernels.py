"""Compiled inner loop of the experience map's correction (eqs 12-14; numba, cached to disk)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_TWO_PI = 2.0 * math.pi


@njit(cache=True, inline="always")
def _wrap(a):
    return a - _TWO_PI * np.round(a * (1.0 / _TWO_PI))


@njit(cache=True)
def correct(x, y, th, n, frm, to, d, theta, phi, m, inv_degree, alpha_d, alpha_theta):
    """One simultaneous (Jacobi) pass of eqs 12-14 over links ``0..m-1`` of ``n`` experiences,
    in place on the pose columns ``x, y, th``.

    Link i -> j contributes its residual (where j is, less where i and the link put it) with
    a plus sign to i (the sums over j) and a minus sign to j (the sums over k). ``inv_degree``
    (n,) divides each sum by the experience's link count (the stable form); an empty array
    keeps the printed sums.
    """
    dx = np.zeros(n)
    dy = np.zeros(n)
    dt = np.zeros(n)
    rx = np.empty(m)
    ry = np.empty(m)
    rt = np.empty(m)
    for k in range(m):
        i, j = frm[k], to[k]
        ang = th[i] + theta[k]
        rx[k] = x[j] - x[i] - d[k] * np.cos(ang)
        ry[k] = y[j] - y[i] - d[k] * np.sin(ang)
        rt[k] = _wrap(th[j] - th[i] - phi[k])
    for k in range(m):  # + at the link's start (eqs 12-14, sums over j) ...
        i = frm[k]
        dx[i] += rx[k]
        dy[i] += ry[k]
        dt[i] += rt[k]
    for k in range(m):  # ... - at its end (the sums over k)
        j = to[k]
        dx[j] -= rx[k]
        dy[j] -= ry[k]
        dt[j] -= rt[k]
    stable = inv_degree.shape[0] > 0
    for i in range(n):
        if stable:
            dx[i] *= inv_degree[i]
            dy[i] *= inv_degree[i]
            dt[i] *= inv_degree[i]
        x[i] += alpha_d * dx[i]
        y[i] += alpha_d * dy[i]
        th[i] = _wrap(th[i] + alpha_theta * dt[i])


@njit(cache=True)
def energy(cells, views, ids, peak, grid, view, r_inf, theta_inf, product):
    """Energy E_i (eqs 2-9) of experiences ``ids`` for a pose-cell peak (3,) and a view:
    ``cells`` (N, 3) and ``views`` (N,) are the map's columns, ``grid`` the pose-cell grid's
    size per axis (cells, distances taken the short way round). ``product``: the stricter
    product form instead of eq 9's sum."""
    out = np.empty(ids.shape[0])
    for k in range(ids.shape[0]):
        i = ids[k]
        d0 = abs(cells[i, 0] - peak[0])
        d0 = min(d0, grid[0] - d0)
        d1 = abs(cells[i, 1] - peak[1])
        d1 = min(d1, grid[1] - d1)
        d2 = abs(cells[i, 2] - peak[2])
        d2 = min(d2, grid[2] - d2)
        r = np.sqrt(d0 * d0 + d1 * d1)  # eq 3
        e_xy = max(1.0 - r / r_inf, 0.0)  # eq 2
        e_th = max(1.0 - d2 / theta_inf, 0.0)  # eqs 4-5
        e_v = 1.0 if views[i] == view else 0.0  # eqs 6-8
        out[k] = e_v * e_xy * e_th if product else e_v * (e_xy + e_th)  # eq 9 (or the product)
    return out
