"""Every metric of the project, defined once (pure numpy; scipy for neighbour search and graphs).

Conventions: a pose is ``(x m, y m, θ rad)``; trajectories are arrays ``(N, 3)``; an estimate
and its ground truth are compared row by row (same timestamps; the caller associates them).
Pose-cell quantities are in cell units and wrap around the grid (``grid_shape``).

* :func:`align_se2`, :func:`ate`, :func:`ate_rmse` -- absolute trajectory error after the
  least-squares rigid (SE(2), no scale) alignment of the estimate onto ground truth (Umeyama
  1991 without scale). The alignment's yaw is the map's global orientation: across the odometric
  biases of Figs 8-10 only that should differ.
* :func:`rpe` -- relative pose error over a fixed travelled distance.
* :func:`snap_mask` -- pose-cell peak jumps of more than ``k`` cells in one tick (wrap-aware),
  the paper's "snaps", by the pipeline's own definition (:mod:`ratslam.snaps`).
* :func:`multiple_representations` -- one place represented more than once in the experience map.
* :func:`hash_collisions` -- one pose-cell region serving places far apart (Fig 4 F).
* :func:`loop_closure_pr`, :func:`realtime_factor`.

TUM trajectory files are read and written by :mod:`worlds.files`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from ratslam.snaps import is_snap

__all__ = [
    "Alignment",
    "HashCollisions",
    "MultipleRepresentations",
    "align_se2",
    "apply_se2",
    "ate",
    "ate_rmse",
    "hash_collisions",
    "loop_closure_pr",
    "multiple_representations",
    "realtime_factor",
    "rpe",
    "snap_mask",
    "wrap_angle",
    "wrap_cells",
]


def wrap_angle(a):
    """Angle(s) wrapped into [-π, π)."""
    return (np.asarray(a, dtype=float) + np.pi) % (2 * np.pi) - np.pi


def wrap_cells(d, grid_shape):
    """Cell differences ``d (..., D)`` wrapped into [-n/2, n/2) per axis (``grid_shape`` (D,))."""
    n = np.asarray(grid_shape, dtype=float)
    return (np.asarray(d, dtype=float) + n / 2) % n - n / 2


def _xy(a, name: str) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[1] < 2:
        raise ValueError(f"{name}: expected an (N, 2) or (N, 3) array, got shape {a.shape}")
    return a[:, :2]


def _pair(est, gt, cols: int = 2) -> tuple[np.ndarray, np.ndarray]:
    est, gt = np.asarray(est, dtype=float), np.asarray(gt, dtype=float)
    for name, a in (("est", est), ("gt", gt)):
        if a.ndim != 2 or a.shape[1] < cols:
            raise ValueError(f"{name}: expected an (N, {cols}) array, got shape {a.shape}")
    if len(est) != len(gt):
        raise ValueError(f"est and gt: different lengths ({len(est)} vs {len(gt)}); associate them first")
    if len(est) == 0:
        raise ValueError("est and gt: empty trajectories")
    return est, gt


# --------------------------------------------------------------------------------- alignment, ATE
@dataclass(frozen=True)
class Alignment:
    """Result of :func:`ate`: the SE(2) alignment estimate -> ground truth and the errors."""

    rmse: float  # m, position RMSE after alignment
    yaw: float  # rad, rotation of the alignment (the estimate's global orientation offset)
    R: np.ndarray  # (2, 2)
    t: np.ndarray  # (2,)
    errors: np.ndarray  # (N,) m, per-pose position error after alignment

    def apply(self, xy_or_xyt: np.ndarray) -> np.ndarray:
        """Move poses ``(N, 2)`` or ``(N, 3)`` of the estimate's frame into the ground-truth frame."""
        return apply_se2(xy_or_xyt, self.R, self.t)


def apply_se2(poses, R, t) -> np.ndarray:
    """``R @ p + t`` for points ``(N, 2)``; poses ``(N, 3)`` also get their heading rotated."""
    p = np.asarray(poses, dtype=float)
    out = p.copy()
    out[..., :2] = p[..., :2] @ np.asarray(R).T + np.asarray(t)
    if p.shape[-1] >= 3:
        out[..., 2] = wrap_angle(p[..., 2] + math.atan2(R[1][0], R[0][0]))
    return out


def align_se2(est_xy, gt_xy) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares rigid alignment of ``est_xy`` onto ``gt_xy`` (Umeyama without scale).

    Finds R ∈ SO(2), t minimising Σ ||gt_i − (R est_i + t)||². Only the first two columns are
    used, so poses ``(N, 3)`` may be passed. Returns ``(R (2, 2), t (2,), yaw rad)``; with a
    single point (or all points coincident) the rotation is the identity.
    """
    e, g = _pair(est_xy, gt_xy)
    e, g = e[:, :2], g[:, :2]
    mu_e, mu_g = e.mean(axis=0), g.mean(axis=0)
    cov = (g - mu_g).T @ (e - mu_e) / len(e)  # Σ_ge
    U, _, Vt = np.linalg.svd(cov)
    S = np.diag([1.0, np.sign(np.linalg.det(U @ Vt)) or 1.0])  # exclude reflections
    R = U @ S @ Vt
    if not np.any(np.abs(cov) > 1e-300):  # degenerate: nothing constrains the rotation
        R = np.eye(2)
    t = mu_g - R @ mu_e
    return R, t, math.atan2(R[1, 0], R[0, 0])


def ate(est_xyt, gt_xyt) -> Alignment:
    """Absolute trajectory error: position RMSE after :func:`align_se2`, with the alignment."""
    e, g = _pair(est_xyt, gt_xyt)
    R, t, yaw = align_se2(e, g)
    err = np.hypot(*(g[:, :2] - (e[:, :2] @ R.T + t)).T)
    return Alignment(rmse=float(np.sqrt(np.mean(err**2))), yaw=yaw, R=R, t=t, errors=err)


def ate_rmse(est_xyt, gt_xyt) -> float:
    """ATE RMSE in metres (positions, after SE(2) alignment); see :func:`ate` for the yaw."""
    return ate(est_xyt, gt_xyt).rmse


# --------------------------------------------------------------------------------------- RPE
def _relative(p_i: np.ndarray, p_j: np.ndarray) -> np.ndarray:
    """Poses of j in i's frame (⊖p_i ⊕ p_j), rows (dx, dy, dθ)."""
    c, s = np.cos(p_i[:, 2]), np.sin(p_i[:, 2])
    dx, dy = p_j[:, 0] - p_i[:, 0], p_j[:, 1] - p_i[:, 1]
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy, wrap_angle(p_j[:, 2] - p_i[:, 2])])


def rpe(est_xyt, gt_xyt, delta_m: float) -> tuple[float, float]:
    """Relative pose error over ``delta_m`` metres travelled (in ground truth).

    For every pose i, j is the first later pose with travelled ground-truth distance
    s_j − s_i ≥ ``delta_m``; the error is E = (⊖gt_i ⊕ gt_j)⁻¹ (⊖est_i ⊕ est_j). Returns
    ``(translation RMSE m, rotation RMSE rad)`` over all such pairs (evo's ``--delta_unit m
    --all_pairs`` convention), NaN if the trajectory is shorter than ``delta_m``.
    """
    if not (isinstance(delta_m, (int, float)) and math.isfinite(delta_m) and delta_m > 0):
        raise ValueError(f"delta_m must be a positive finite distance, got {delta_m!r}")
    e, g = _pair(est_xyt, gt_xyt, cols=3)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(g[:, :2], axis=0).T))])
    j = np.searchsorted(s, s + delta_m - 1e-12, side="left")
    i = np.flatnonzero(j < len(s))
    if len(i) == 0:
        return float("nan"), float("nan")
    j = j[i]
    rel_g, rel_e = _relative(g[i], g[j]), _relative(e[i], e[j])
    err = _relative(rel_g, rel_e)  # error pose: rel_g⁻¹ ⊕ rel_e
    t_err = np.hypot(err[:, 0], err[:, 1])
    return float(np.sqrt(np.mean(t_err**2))), float(np.sqrt(np.mean(err[:, 2] ** 2)))


# ------------------------------------------------------------------------------------- snaps
def snap_mask(peaks_cells, grid_shape, k: float) -> np.ndarray:
    """Per tick (N,) bool: the pose-cell peak moved more than ``k`` cells since the previous tick.

    The definition ``RatSLAM.snapped`` reports (:func:`ratslam.snaps.is_snap`): Euclidean
    distance in cell units over all given axes, each difference taken the short way round the
    grid. The first tick is never a snap. ``peaks_cells`` is ``(N, D)`` and ``grid_shape`` has
    at least D entries.
    """
    p = np.asarray(peaks_cells, dtype=float)
    if p.ndim != 2:
        raise ValueError(f"peaks_cells: expected an (N, D) array, got shape {p.shape}")
    shape = tuple(grid_shape)[: p.shape[1]]
    if len(shape) != p.shape[1]:
        raise ValueError(f"grid_shape: {len(grid_shape)} axes for peaks with {p.shape[1]} columns")
    out = np.zeros(len(p), dtype=bool)
    if len(p) > 1:
        out[1:] = is_snap(p[:-1], p[1:], shape, k)
    return out


# ----------------------------------------------------------------- multiple representations
def _clusters(pairs: np.ndarray, n: int) -> list[np.ndarray]:
    """Connected components (size >= 2) of the graph on n nodes with edges ``pairs``."""
    if len(pairs) == 0:
        return []
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(g, directed=False)
    members = np.unique(pairs)
    out = [members[labels[members] == lab] for lab in np.unique(labels[members])]
    return sorted(out, key=lambda c: int(c[0]))


@dataclass(frozen=True)
class MultipleRepresentations:
    """Places represented more than once. ``int(result)`` is the number of clusters."""

    pairs: np.ndarray  # (P, 2) int, i < j: experiences close in ground truth, far apart in the map
    clusters: list = field(default_factory=list)  # arrays of experience indices, one per place
    n_pairs: int = 0
    n_clusters: int = 0

    def __int__(self) -> int:
        return self.n_clusters

    def as_dict(self) -> dict:
        return {
            "pairs": self.n_pairs,
            "clusters": self.n_clusters,
            "cluster_sizes": [int(len(c)) for c in self.clusters],
        }


def multiple_representations(exp_gt_xy, links, radius: float = 0.5, min_path_m: float = 5.0) -> MultipleRepresentations:
    """Experiences of one place that the experience map does not join.

    A pair (i, j) counts when the two experiences were within ``radius`` metres of each other
    in ground truth (``exp_gt_xy``: the true position when each was created / last active) and
    no link path joins them whose length (sum of the ground-truth distances between linked
    experiences) is at most ``min_path_m``. ``min_path_m=math.inf`` is the strict reading
    "sharing no link path at all" (different connected components over ``links``) -- but an
    experience map whose every new experience is linked from the previous one is always one
    component, so by default a path must be short: a revisit joined to the first visit only
    around the whole loop (no re-used experience, no closing transition) is a second
    representation of the place. The default 5 m is below every loop of the worlds here
    (≥ 18 m) and above the length of in-pass paths between experiences 0.5 m apart.

    ``links`` is ``(M, 2)`` int (from, to), undirected here. ``clusters`` groups the pairs into
    places (connected components of the pair graph); ``int(result)`` is their number.
    """
    p = _xy(exp_gt_xy, "exp_gt_xy")
    n = len(p)
    lk = np.asarray(links, dtype=np.int64).reshape(-1, 2)
    if len(lk) and (lk.min() < 0 or lk.max() >= n):
        raise ValueError(f"links: indices must be in [0, {n}), got [{lk.min()}, {lk.max()}]")
    if not radius > 0:
        raise ValueError(f"radius must be positive, got {radius!r}")
    close = (
        np.array(sorted(cKDTree(p).query_pairs(radius)), dtype=np.int64).reshape(-1, 2)
        if n
        else np.zeros((0, 2), np.int64)
    )
    if len(close):
        lk = lk[lk[:, 0] != lk[:, 1]]
        if math.isinf(min_path_m):
            g = coo_matrix((np.ones(len(lk)), (lk[:, 0], lk[:, 1])), shape=(n, n))
            _, lab = connected_components(g, directed=False)
            far = lab[close[:, 0]] != lab[close[:, 1]]
        else:
            w = np.hypot(*(p[lk[:, 0]] - p[lk[:, 1]]).T) + 1e-9  # zero weights would mean "no edge"
            g = coo_matrix((w, (lk[:, 0], lk[:, 1])), shape=(n, n)).tocsr()
            src = np.unique(close[:, 0])
            dist = dijkstra(g, directed=False, indices=src, limit=min_path_m)
            row = np.searchsorted(src, close[:, 0])
            far = ~np.isfinite(dist[row, close[:, 1]])
        close = close[far]
    clusters = _clusters(close, n)
    return MultipleRepresentations(pairs=close, clusters=clusters, n_pairs=len(close), n_clusters=len(clusters))


# ---------------------------------------------------------------------------- hash collisions
@dataclass(frozen=True)
class HashCollisions:
    """Pose-cell regions serving distant places. ``int(result)`` is the number of regions."""

    regions: np.ndarray  # (R, 2) int: (x', y') index of each colliding tile of 2·cell_radius cells
    spread_m: np.ndarray  # (R,) m: largest ground-truth distance between experiences of the tile
    pairs: np.ndarray  # (P, 2) int: experience pairs within cell_radius cells, > place_dist m apart
    n_regions: int = 0

    def __int__(self) -> int:
        return self.n_regions

    def as_dict(self) -> dict:
        return {
            "regions": self.n_regions,
            "pairs": int(len(self.pairs)),
            "max_spread_m": float(self.spread_m.max()) if len(self.spread_m) else 0.0,
        }


def hash_collisions(
    exp_cells_xy, exp_gt_xy, grid_shape, cell_radius: float = 2.0, place_dist: float = 2.0
) -> HashCollisions:
    """One pose-cell region serving places more than ``place_dist`` m apart (Fig 4 F).

    ``exp_cells_xy``: the experiences' (x', y') pose-cell coordinates; ``exp_gt_xy``: their
    ground-truth positions; ``grid_shape``: (nx, ny) (more entries are ignored).

    Distinct collisions are counted over a fixed tiling of the (x', y') plane into square
    regions of side 2·``cell_radius`` cells (2 → 4 × 4-cell tiles, 1 m × 1 m at 0.25 m cells,
    the grid the paper's pose-cell plots are drawn on): a region collides when two of its
    experiences were more than ``place_dist`` m apart in ground truth. ``pairs`` lists every
    experience pair within ``cell_radius`` cells (wrap-aware, regardless of tiles) whose places
    are more than ``place_dist`` apart.
    """
    c, p = _xy(exp_cells_xy, "exp_cells_xy"), _xy(exp_gt_xy, "exp_gt_xy")
    if len(c) != len(p):
        raise ValueError(f"exp_cells_xy and exp_gt_xy: different lengths ({len(c)} vs {len(p)})")
    n = np.asarray(tuple(grid_shape)[:2], dtype=float)
    if not cell_radius > 0:
        raise ValueError(f"cell_radius must be positive, got {cell_radius!r}")
    empty = HashCollisions(np.zeros((0, 2), np.int64), np.zeros(0), np.zeros((0, 2), np.int64), 0)
    if len(c) < 2:
        return empty
    cw = np.mod(c, n)
    pairs = np.array(sorted(cKDTree(cw, boxsize=n).query_pairs(cell_radius)), dtype=np.int64).reshape(-1, 2)
    if len(pairs):
        pairs = pairs[np.hypot(*(p[pairs[:, 0]] - p[pairs[:, 1]]).T) > place_dist]
    side = 2.0 * cell_radius
    tiles = np.floor(cw / side).astype(np.int64)
    key = tiles[:, 0] * (int(n[1] // side) + 2) + tiles[:, 1]
    order = np.argsort(key, kind="stable")
    starts = np.flatnonzero(np.r_[True, np.diff(key[order]) != 0])
    regions, spread = [], []
    for a, b in zip(starts, np.r_[starts[1:], len(order)]):
        idx = order[a:b]
        if len(idx) < 2:
            continue
        q = p[idx]
        if np.ptp(q[:, 0]) <= place_dist / 2 and np.ptp(q[:, 1]) <= place_dist / 2:
            continue  # bounding box diagonal small enough: cannot exceed place_dist
        d = np.sqrt(((q[:, None, :] - q[None, :, :]) ** 2).sum(-1)).max()
        if d > place_dist:
            regions.append(tiles[idx[0]])
            spread.append(d)
    if not regions:
        return HashCollisions(np.zeros((0, 2), np.int64), np.zeros(0), pairs, 0)
    return HashCollisions(np.array(regions, dtype=np.int64), np.array(spread), pairs, len(regions))


# --------------------------------------------------------------------- closures, timing
def loop_closure_pr(accepted, is_true) -> tuple[float | None, float | None]:
    """Precision and recall of accepted loop closures among the proposed ones.

    ``accepted`` and ``is_true`` are (L,) bool over proposed closures. Precision = accepted and
    true / accepted; recall = accepted and true / true. ``None`` where the denominator is 0.
    """
    a, t = np.asarray(accepted, dtype=bool).ravel(), np.asarray(is_true, dtype=bool).ravel()
    if a.shape != t.shape:
        raise ValueError(f"accepted and is_true: different lengths ({a.size} vs {t.size})")
    tp = int((a & t).sum())
    precision = tp / int(a.sum()) if a.any() else None
    recall = tp / int(t.sum()) if t.any() else None
    return precision, recall


def realtime_factor(sim_seconds: float, wall_seconds: float) -> float | None:
    """Simulated seconds per wall-clock second (> 1: faster than real time); ``None`` if no
    wall time was measured."""
    for name, v in (("sim_seconds", sim_seconds), ("wall_seconds", wall_seconds)):
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be a finite non-negative number of seconds, got {v!r}")
    return sim_seconds / wall_seconds if wall_seconds > 0 else None
