"""Pose cells: attractor dynamics, path integration, wrap-around, peak, equivalence to full grid."""

import math

import numpy as np
import pytest

from ratslam import PoseCellConfig, RatSLAMConfig
from ratslam.pose_cell_kernels import arc_union, cover_arc
from ratslam.pose_cells import PoseCells, gaussian_kernel
from ratslam.pose_cells_reference import FullGridPoseCells
from tests.helpers import CFG, DT, GRID, settled, wrapped_diff


def test_gaussian_kernel_is_normalised_and_symmetric():
    k = gaussian_kernel(1.5, 4)
    assert k.sum() == pytest.approx(1.0)
    assert np.allclose(k, k[::-1])
    assert np.argmax(k) == 4


def test_cover_arc_finds_smallest_wrapping_arc():
    occ = np.zeros(10, dtype=bool)
    occ[[0, 1, 9]] = True
    assert cover_arc(occ, 0, 10) == (9, 3)
    assert cover_arc(occ, 4, 10) == (3, 3)  # the same ring read from global index 4
    occ[:] = False
    occ[[3, 5]] = True
    assert cover_arc(occ, 0, 10) == (3, 3)
    occ[:] = True
    assert cover_arc(occ, 0, 10) == (0, 10)
    assert cover_arc(occ[:4], 7, 10) == (7, 4)  # a box shorter than the ring: plain extent


def test_arc_union_is_the_smallest_covering_arc():
    """Merged boxes cover both boxes with the smallest wrap-aware arc (brute force check)."""
    n = 9
    for s1 in range(n):
        for l1 in range(1, n + 1):
            for s2 in range(n):
                for l2 in range(1, n + 1):
                    start, length = arc_union(s1, l1, s2, l2, n)
                    cover = {(start + i) % n for i in range(length)}
                    want = {(s1 + i) % n for i in range(l1)} | {(s2 + i) % n for i in range(l2)}
                    assert want <= cover
                    occ = np.zeros(n, dtype=bool)
                    occ[list(want)] = True
                    assert length == cover_arc(occ, 0, n)[1]


def test_packet_stays_put_and_keeps_mass_without_input():
    """Paper: the attractor holds a stable packet (the pose estimate) without input."""
    pc = PoseCells(CFG, start_cell=(20, 30, 5))
    peaks = []
    for _ in range(300):
        pc.step(0.0, 0.0)
        assert pc.total == pytest.approx(1.0, abs=1e-12)
        peaks.append(pc.peak)
    peaks = np.array(peaks)
    assert np.abs(wrapped_diff(peaks, [20, 30, 5], GRID)).max() < 1e-9
    # the packet converged to a fixed, compact shape
    a1 = pc.activity.copy()
    pc.step(0.0, 0.0)
    assert np.abs(pc.activity - a1).max() < 1e-9
    assert (pc.activity > 0).sum() < 400


def test_activity_is_non_negative_and_mostly_zero():
    pc = settled()
    a = pc.activity
    assert a.min() >= 0.0
    assert (a > 0).mean() < 0.01


def _drive(pc, v, w, steps):
    for _ in range(steps):
        pc.step(v * DT, w * DT)


def test_straight_line_10m_peak_within_one_cell_of_vt():
    """Path integration along a straight 10 m line: peak within one cell of v*t / cell size."""
    for heading_cell in (0, 4, 9, 13, 31):  # 0, 40, 90, 130, 310 degrees
        pc = settled(cell=(30, 30, heading_cell))
        v = 0.3
        steps = int(round(10.0 / (v * DT)))
        start = pc.peak
        _drive(pc, v, 0.0, steps)
        th = heading_cell * CFG.pose_cells.theta_cell_rad
        dist = v * DT * steps / CFG.pose_cells.cell_size_m
        expected = start + np.array([dist * math.cos(th), dist * math.sin(th), 0.0])
        err = wrapped_diff(pc.peak, expected, GRID)
        assert np.hypot(err[0], err[1]) < 1.0, (heading_cell, err)  # measured <= 0.55 cells
        assert abs(err[2]) < 1.0


def test_ninety_degree_turn_peak_within_one_cell():
    """Path integration around a 90 degree turn: peak within one cell of the integrated path."""
    pc = settled(cell=(20, 20, 0))
    x, y, _ = pc.peak
    th_rad = 0.0
    legs = [(0.3, 0.0, 50), (0.1, math.pi / 2 / 3.0, 21), (0.3, 0.0, 50)]
    for v, w, steps in legs:
        for _ in range(steps):
            pc.step(v * DT, w * DT)
            x += v * DT * math.cos(th_rad) / CFG.pose_cells.cell_size_m
            y += v * DT * math.sin(th_rad) / CFG.pose_cells.cell_size_m
            th_rad += w * DT
    expected = np.array([x, y, th_rad / CFG.pose_cells.theta_cell_rad])
    err = wrapped_diff(pc.peak, expected, GRID)
    assert np.hypot(err[0], err[1]) < 1.0, err
    assert abs(err[2]) < 1.0, err
    assert th_rad == pytest.approx(math.pi / 2, abs=0.01)


def test_sub_cell_shift_is_exact_for_a_single_cell():
    """One path-integration step splits a single cell bilinearly (sub-cell shift, mass kept)."""
    pc = PoseCells(CFG, start_cell=(10, 10, 0))
    pc.path_integrate(0.1 * CFG.pose_cells.cell_size_m, 0.0)  # 0.1 cell east at heading 0
    a = pc.activity
    assert a[10, 10, 0] == pytest.approx(0.9)
    assert a[11, 10, 0] == pytest.approx(0.1)
    assert a.sum() == pytest.approx(1.0)
    pc = PoseCells(CFG, start_cell=(10, 10, 0))
    pc.path_integrate(0.0, 0.25 * CFG.pose_cells.theta_cell_rad)
    a = pc.activity
    assert a[10, 10, 0] == pytest.approx(0.75) and a[10, 10, 1] == pytest.approx(0.25)


def test_fast_motion_moves_several_cells_per_tick():
    pc = settled(cell=(30, 30, 9))  # heading 90 degrees
    y0 = pc.peak[1]
    pc.step(3.3 * CFG.pose_cells.cell_size_m, 0.0)  # 3.3 cells in one tick
    assert wrapped_diff(pc.peak[1], y0 + 3.3, CFG.pose_cells.ny) == pytest.approx(0.0, abs=0.05)


@pytest.mark.parametrize("axis,sign", [(0, 1), (0, -1), (1, 1), (1, -1), (2, 1), (2, -1)])
def test_wrap_around_at_every_face(axis, sign):
    """The network wraps on every axis: a packet crossing a face re-enters at the opposite one."""
    n = [CFG.pose_cells.nx, CFG.pose_cells.ny, CFG.pose_cells.n_theta]
    cell = [30, 30, 0]
    if axis < 2:
        cell[axis] = n[axis] - 2 if sign > 0 else 1
        cell[2] = {(0, 1): 0, (0, -1): 18, (1, 1): 9, (1, -1): 27}[(axis, sign)]
    else:
        cell[2] = n[2] - 2 if sign > 0 else 1
    pc = settled(cell=tuple(cell))
    ref = FullGridPoseCells(CFG, start_cell=tuple(cell))
    for _ in range(30):
        ref.step(0.0, 0.0)
    start = pc.peak
    steps = 40
    v, w = (0.3, 0.0) if axis < 2 else (0.0, sign * math.radians(20))
    for _ in range(steps):
        pc.step(v * DT, w * DT)
        ref.step(v * DT, w * DT)
    moved = np.zeros(3)
    if axis < 2:
        moved[axis] = sign * v * DT * steps / CFG.pose_cells.cell_size_m
    else:
        moved[2] = w * DT * steps / CFG.pose_cells.theta_cell_rad
    expected = (start + moved) % GRID
    err = wrapped_diff(pc.peak, expected, GRID)
    assert np.abs(err).max() < 1.0, err
    assert np.all(pc.peak >= 0) and np.all(pc.peak < GRID)
    # crossed the face: the raw coordinate did wrap
    assert abs(pc.peak[axis] - (start[axis] + moved[axis])) > GRID[axis] / 2
    assert np.abs(pc.activity - ref.activity).max() < 1e-12
    assert pc.total == pytest.approx(1.0)


def test_windowed_network_equals_full_grid_reference():
    """The boxed update is the same update as the straightforward full-grid one (to rounding),
    including injections far from the packet and the competition that follows."""
    rng = np.random.default_rng(3)
    pc, ref = PoseCells(CFG), FullGridPoseCells(CFG)
    for k in range(400):
        if k % 37 == 5:
            cells = rng.integers(
                0, [CFG.pose_cells.nx, CFG.pose_cells.ny, CFG.pose_cells.n_theta], size=(rng.integers(1, 6), 3)
            )
            e = rng.uniform(0.01, 0.3, len(cells))
            pc.inject(cells, e)
            ref.inject(cells, e)
        v, w = rng.uniform(0, 0.6), rng.normal(0, 0.5)
        pc.step(v * DT, w * DT)
        ref.step(v * DT, w * DT)
        assert np.abs(pc.activity - ref.activity).max() < 1e-12, k


def test_small_grid_wraps_whole_axes_and_matches_reference():
    cfg = RatSLAMConfig(
        pose_cells=PoseCellConfig(
            nx=8, ny=9, n_theta=8, excite_radius_cells=2, inhibit_radius_cells=3, peak_radius_cells=3
        )
    )
    pc, ref = PoseCells(cfg), FullGridPoseCells(cfg)
    rng = np.random.default_rng(0)
    for k in range(100):
        if k % 10 == 0:
            pc.inject([[k % 8, 3, 5]], 0.4)
            ref.inject([[k % 8, 3, 5]], 0.4)
        v, w = rng.uniform(0, 1.0), rng.normal(0, 1.0)
        pc.step(v * DT, w * DT)
        ref.step(v * DT, w * DT)
        assert np.abs(pc.activity - ref.activity).max() < 1e-12


def test_peak_is_circular_weighted_mean_across_the_wrap():
    """The peak refines the strongest cell by a wrap-aware weighted mean of its neighbourhood."""
    pc = PoseCells(CFG, start_cell=(0, 10, 0))
    pc.inject([[CFG.pose_cells.nx - 1, 10, 0]], 1.0)  # equal mass at x'=59 and x'=0
    pc._update_peak()
    x = pc.peak[0]
    assert min(abs(x - (CFG.pose_cells.nx - 0.5)), abs(x + 0.5)) < 1e-9  # half-way, across the face


def test_single_weak_injection_does_not_move_the_peak():
    """One tick of view-sized injection far from the packet must not move the peak (ARCHITECTURE.md:
    a packet sharp enough that one tick of an aliased or false view cannot move it)."""
    pc = settled(cell=(30, 30, 9))
    before = pc.peak
    cells, vals = pc.active_cells()
    shifted = cells + np.array([20, -15, 12])
    pc.inject(shifted, CFG.local_view.inject * vals)  # a whole familiar-view association, one tick
    for _ in range(60):
        pc.step(0.0, 0.0)
        assert np.abs(wrapped_diff(pc.peak, before, GRID)).max() < 0.5
    assert len(pc.boxes()) == 1  # the injected activity died out


def test_state_round_trip():
    pc = settled()
    pc.inject([[5, 5, 5]], 0.2)
    pc.step(0.05, 0.1)
    other = PoseCells(CFG)
    other.set_state(pc.get_state())
    np.testing.assert_array_equal(other.activity, pc.activity)
    pc.step(0.05, 0.1)
    other.step(0.05, 0.1)
    np.testing.assert_array_equal(other.activity, pc.activity)
    np.testing.assert_array_equal(other.peak, pc.peak)


def test_boxes_join_through_a_box_between_them():
    """Two boxes too far apart to interact are merged when a third between them reaches both: the
    first takes in the third (the first pass), then the second (the next pass), in that order."""
    from ratslam.pose_cell_kernels import interacting_groups

    n = np.array([36, 60, 60], dtype=np.int64)
    starts = np.array([[0, 0, 0], [0, 24, 0], [0, 12, 0]], dtype=np.int64)
    shapes = np.array([[5, 4, 4], [5, 4, 4], [5, 4, 4]], dtype=np.int64)
    order, arc_s, arc_l, members, count = interacting_groups(starts, shapes, n, 8)
    assert order.tolist() == [0]
    assert members[0, : count[0]].tolist() == [0, 2, 1]
    assert arc_s[0].tolist() == [0, 0, 0] and arc_l[0].tolist() == [5, 28, 4]
    # one cell further apart, the third no longer reaches the second: two groups
    starts[1, 1] = 25
    order, _, arc_l, members, count = interacting_groups(starts, shapes, n, 8)
    assert order.tolist() == [0, 1] and members[0, : count[0]].tolist() == [0, 2] and arc_l[0, 1] == 16
