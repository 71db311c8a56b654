"""Metrics: hand-computed cases, edge cases, and ATE from TUM files read back against the arrays."""

import math

import numpy as np
import pytest

from harness.report import metrics as M
from worlds.files import read_tum, write_tum


def rot(a):
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def loop(n=200, seed=0):
    """A noisy square-ish loop (x, y, θ) to stand in for a ground-truth path."""
    s = np.linspace(0, 2 * np.pi, n, endpoint=False)
    xy = np.column_stack([3 * np.cos(s) + 0.5 * np.cos(3 * s), 2 * np.sin(s)])
    th = np.arctan2(np.gradient(xy[:, 1]), np.gradient(xy[:, 0]))
    return np.column_stack([xy, th]) + np.random.default_rng(seed).normal(0, 0.01, (n, 3))


# ------------------------------------------------------------------------------ alignment
def test_align_two_points_by_hand():
    """est (0,0),(1,0) onto gt (1,1),(1,2): a quarter turn and t = (1, 1)."""
    R, t, yaw = M.align_se2([[0, 0], [1, 0]], [[1, 1], [1, 2]])
    assert yaw == pytest.approx(math.pi / 2)
    np.testing.assert_allclose(R, [[0, -1], [1, 0]], atol=1e-12)
    np.testing.assert_allclose(t, [1, 1], atol=1e-12)


def test_align_recovers_rigid_motion_and_ate_is_zero():
    gt = loop()
    est = gt.copy()
    est[:, :2] = (gt[:, :2] - [2.0, -1.0]) @ rot(-0.7).T  # est = R(-0.7)(gt - c)
    est[:, 2] -= 0.7
    res = M.ate(est, gt)
    assert res.yaw == pytest.approx(0.7, abs=1e-12)
    assert res.rmse == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(res.apply(est), np.column_stack([gt[:, :2], M.wrap_angle(gt[:, 2])]), atol=1e-9)


def test_ate_has_no_scale_by_hand():
    """gt (0,0),(4,0) vs est (0,0),(2,0): centroids align, residuals ±1 m -> RMSE exactly 1
    (a similarity alignment would give 0)."""
    assert M.ate_rmse([[0, 0, 0], [2, 0, 0]], [[0, 0, 0], [4, 0, 0]]) == pytest.approx(1.0)


def test_align_never_reflects():
    """A mirrored path is not matched by a reflection: R stays a rotation, the error stays large."""
    gt = loop()
    mirrored = gt * [-1, 1, 1]
    R, _, _ = M.align_se2(mirrored, gt)
    assert np.linalg.det(R) == pytest.approx(1.0)
    assert M.ate_rmse(mirrored, gt) > 0.5


def test_align_single_point_is_translation():
    R, t, yaw = M.align_se2([[1.0, 2.0]], [[4.0, 6.0]])
    np.testing.assert_array_equal(R, np.eye(2))
    np.testing.assert_allclose(t, [3, 4])
    assert yaw == 0.0


def test_ate_rejects_mismatched_lengths():
    with pytest.raises(ValueError, match="different lengths"):
        M.ate_rmse(np.zeros((3, 3)), np.zeros((4, 3)))


# ------------------------------------------------------------------------------------ RPE
def test_rpe_scale_error_by_hand():
    """gt at 1 m steps along x, est at 1.1 m steps: over 2 m every relative translation is
    2.2 m instead of 2 m -> translation RMSE 0.2 m, rotation 0."""
    i = np.arange(11.0)
    gt = np.column_stack([i, 0 * i, 0 * i])
    est = np.column_stack([1.1 * i, 0 * i, 0 * i])
    t_err, r_err = M.rpe(est, gt, 2.0)
    assert t_err == pytest.approx(0.2)
    assert r_err == pytest.approx(0.0)


def test_rpe_heading_drift_by_hand():
    """Same positions, est heading drifting 0.05 rad per metre: over 2 m the relative heading is
    off by 0.1 rad for every pair; the translation error is |2(cos a, -sin a) - (2, 0)|."""
    i = np.arange(11.0)
    gt = np.column_stack([i, 0 * i, 0 * i])
    est = np.column_stack([i, 0 * i, 0.05 * i])
    t_err, r_err = M.rpe(est, gt, 2.0)
    assert r_err == pytest.approx(0.1)
    a = 0.05 * i[:9]
    expect = np.sqrt(np.mean((2 * np.cos(a) - 2) ** 2 + (2 * np.sin(a)) ** 2))
    assert t_err == pytest.approx(expect)


def test_rpe_invariant_to_rigid_motion_and_nan_when_too_short():
    gt = loop()
    est = gt.copy()
    est[:, :2] = gt[:, :2] @ rot(1.0).T + [5, 5]
    est[:, 2] += 1.0
    t_err, r_err = M.rpe(est, gt, 3.0)
    assert t_err == pytest.approx(0.0, abs=1e-9) and r_err == pytest.approx(0.0, abs=1e-9)
    assert all(math.isnan(v) for v in M.rpe(est, gt, 1e6))
    with pytest.raises(ValueError, match="delta_m"):
        M.rpe(est, gt, 0.0)


# ---------------------------------------------------------------------------------- snaps
def test_snaps_wrap_aware_by_hand():
    """Grid of 10 cells: 0 -> 1 (1 cell), 1 -> 9 (2 cells across the wrap), 9 -> 5 (4 cells):
    only the last exceeds k = 3."""
    peaks = np.array([[0.0], [1.0], [9.0], [5.0]])
    np.testing.assert_array_equal(M.snap_mask(peaks, (10,), 3), [False, False, False, True])


def test_snaps_euclidean_over_three_axes():
    """(x', y', θ') jump (2, 2, 1) in a 10x10x36 grid is 3 cells exactly: not > 3; a θ' wrap
    35 -> 0 is 1 cell."""
    peaks = np.array([[0, 0, 35], [0, 0, 0], [2, 2, 1], [2, 2, 5]], dtype=float)
    np.testing.assert_array_equal(M.snap_mask(peaks, (10, 10, 36), 3.0), [False, False, False, True])


# ------------------------------------------------------------------- multiple representations
def corridor_map():
    """Chain 0-1-2-3 along y = 0; a second visit 4-5 near 0 and 1, linked only to each other."""
    gt = np.array([[0, 0], [1, 0], [2, 0], [3, 0], [0.2, 0.1], [1.1, 0.1]], dtype=float)
    links = [[0, 1], [1, 2], [2, 3], [4, 5]]
    return gt, links


def test_multiple_representations_strict_components_by_hand():
    """Pairs within 0.5 m in different components: (0,4) at 0.224 m and (1,5) at 0.141 m."""
    gt, links = corridor_map()
    res = M.multiple_representations(gt, links, radius=0.5, min_path_m=math.inf)
    np.testing.assert_array_equal(res.pairs, [[0, 4], [1, 5]])
    assert int(res) == 2 and res.n_pairs == 2
    assert [c.tolist() for c in res.clusters] == [[0, 4], [1, 5]]


def test_multiple_representations_long_detour_still_counts():
    """A link 3 -> 4 joins the second visit only around a 3 + 2.80 = 5.80 m path (> 5 m): still two
    representations; the strict component reading no longer sees them."""
    gt, links = corridor_map()
    links = links + [[3, 4]]
    assert int(M.multiple_representations(gt, links)) == 2
    assert int(M.multiple_representations(gt, links, min_path_m=math.inf)) == 0
    assert int(M.multiple_representations(gt, links, min_path_m=6.0)) == 0


def test_multiple_representations_closure_link_removes_them():
    """A transition 0 -> 4 (the map re-used the place): 0-4 is 0.22 m, 1-5 via 1-0-4-5 is 2.1 m."""
    gt, links = corridor_map()
    res = M.multiple_representations(gt, links + [[0, 4]])
    assert int(res) == 0 and res.pairs.shape == (0, 2)


def test_multiple_representations_empty_and_bad_links():
    assert int(M.multiple_representations(np.zeros((0, 2)), np.zeros((0, 2)))) == 0
    with pytest.raises(ValueError, match="links"):
        M.multiple_representations(np.zeros((2, 2)), [[0, 2]])


# ---------------------------------------------------------------------------- hash collisions
def test_hash_collisions_by_hand():
    """Grid 20 x 20, 4 x 4-cell tiles. Experiences 0, 1 share tile (0, 0) and are 10 m apart: a
    collision. 2, 3 share tile (2, 2) 0.5 m apart: none. 4, 5 are 1 cell apart across the wrap
    (x' 19.5 and 0.5), 5 m apart in truth: a colliding pair, but in different tiles."""
    cells = np.array([[1, 1], [2, 2], [9, 9], [10, 10], [19.5, 5], [0.5, 5]], dtype=float)
    gt = np.array([[0, 0], [10, 0], [3, 3], [3.5, 3], [0, 20], [0, 25]], dtype=float)
    res = M.hash_collisions(cells, gt, (20, 20), cell_radius=2.0, place_dist=2.0)
    assert int(res) == 1
    np.testing.assert_array_equal(res.regions, [[0, 0]])
    assert res.spread_m[0] == pytest.approx(10.0)
    np.testing.assert_array_equal(res.pairs, [[0, 1], [4, 5]])


def test_hash_collisions_counts_regions_not_pairs():
    """Two places with two experiences each in one tile: 4 colliding pairs, one region; a
    consistent map (cells = position / 0.25 m, no wrap) has none."""
    cells = np.array([[1, 1], [1.5, 1], [2, 2], [2.5, 2]], dtype=float)
    gt = np.array([[0, 0], [0.1, 0], [10, 0], [10.1, 0]], dtype=float)
    res = M.hash_collisions(cells, gt, (20, 20))
    assert int(res) == 1 and len(res.pairs) == 4
    path = loop()[:, :2] + 5
    assert int(M.hash_collisions(path / 0.25, path, (100, 100))) == 0


# ------------------------------------------------------------------------- closures, timing
def test_loop_closure_pr_by_hand():
    """accepted T T F T, true T F T T: 2 true accepted of 3 accepted and of 3 true."""
    p, r = M.loop_closure_pr([1, 1, 0, 1], [1, 0, 1, 1])
    assert p == pytest.approx(2 / 3) and r == pytest.approx(2 / 3)
    assert M.loop_closure_pr([0, 0], [1, 0]) == (None, 0.0)
    assert M.loop_closure_pr([1, 0], [0, 0]) == (0.0, None)


def test_realtime_factor():
    assert M.realtime_factor(900.0, 90.0) == pytest.approx(10.0)
    assert M.realtime_factor(900.0, 0.0) is None
    with pytest.raises(ValueError, match="wall_seconds"):
        M.realtime_factor(900.0, -1.0)


# ------------------------------------------------------------------------------ TUM files
def independent_ate(t_est, p_est, t_gt, p_gt):
    """ATE as evo computes it, written independently: associate by timestamp, closed-form 2-D
    rotation from centred cross/dot sums, then position RMSE."""
    idx = {round(float(v), 6): i for i, v in enumerate(t_gt)}
    j = np.array([idx[round(float(v), 6)] for v in t_est])
    a, b = p_est[:, :2], p_gt[j, :2]
    a0, b0 = a - a.mean(0), b - b.mean(0)
    ang = math.atan2(np.sum(a0[:, 0] * b0[:, 1] - a0[:, 1] * b0[:, 0]), np.sum(a0 * b0))
    resid = b0 - a0 @ rot(ang).T
    return math.sqrt(np.mean(np.sum(resid**2, axis=1))), ang


def test_ate_from_tum_files_matches_arrays(tmp_path):
    """The run-directory contract: ATE computed evo-style from the TUM files equals the ATE the
    metrics report from the arrays (to the files' 1 µm precision)."""
    gt = loop(300)
    rng = np.random.default_rng(3)
    est = gt.copy()
    est[:, :2] = gt[:, :2] @ rot(0.4).T + [1, -2] + rng.normal(0, 0.05, (len(gt), 2))
    est[:, 2] = gt[:, 2] + 0.4
    t = np.arange(len(gt)) / 7.0
    write_tum(tmp_path / "ground_truth.tum", t, *gt.T)
    write_tum(tmp_path / "ratslam.tum", t[::3], *est[::3].T)  # subset: association matters
    from_arrays = M.ate(est[::3], gt[::3])
    rmse, ang = independent_ate(*read_tum(tmp_path / "ratslam.tum"), *read_tum(tmp_path / "ground_truth.tum"))
    assert rmse == pytest.approx(from_arrays.rmse, abs=1e-5)
    assert ang == pytest.approx(from_arrays.yaw, abs=1e-5)
    assert from_arrays.yaw == pytest.approx(-0.4, abs=0.02)
