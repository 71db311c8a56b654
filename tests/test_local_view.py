"""Local view cells: one per scene, Hebbian associations, injection, and the pinning trap."""

import numpy as np
import pytest

from ratslam import RatSLAM
from ratslam.local_view import FATIGUE_CAP, LocalView
from tests.helpers import CFG, DT, GRID, settled, wrapped_diff


def test_scene_minus_one_is_not_a_view():
    """ARCHITECTURE.md trap: -1 (nothing recognisable) creates no view cell and injects nothing."""
    lv, pc = LocalView(CFG), settled()
    for k in range(50):
        assert lv.inject(-1, k, pc) == -1
        lv.learn(k, pc)
    assert len(lv) == 0 and lv.injected == 0.0


def test_one_view_cell_per_scene_number():
    lv, pc = LocalView(CFG), settled()
    scenes = [4, 4, 9, -1, 4, 12, 9]
    cells = [lv.inject(s, k, pc) for k, s in enumerate(scenes)]
    assert len(lv) == 3
    assert cells == [0, 0, 1, -1, 0, 2, 1]
    assert lv.scenes.tolist() == [4, 9, 12]


def test_hebbian_association_follows_the_active_pose_cells():
    """β <- max(β, λ V P) over the active cells (above the learning threshold)."""
    lv, pc = LocalView(CFG), settled(cell=(12, 40, 7))
    lv.inject(5, 0, pc)
    lv.learn(0, pc)
    cells, w, ticks = lv.associations(0)
    act_cells, act = pc.active_cells()
    keep = act >= CFG.local_view.learn_threshold * act.max()
    assert len(cells) == keep.sum()
    order = np.lexsort(act_cells[keep].T[::-1])
    order_w = np.lexsort(cells.T[::-1])
    np.testing.assert_allclose(w[order_w], CFG.local_view.learn_rate * act[keep][order])
    assert np.all(ticks == 0)
    assert np.abs(wrapped_diff(cells.mean(axis=0), (12, 40, 7))).max() < 0.5


def test_familiar_view_injects_only_old_associations():
    """A view injects δ V β through associations at least min_age_ticks old; a recently
    learnt view does not inject (ARCHITECTURE.md trap: recently learnt views must not pin the packet)."""
    lv, pc = LocalView(CFG), settled()
    lv.inject(3, 0, pc)
    lv.learn(0, pc)
    _, w, _ = lv.associations(0)
    for k in range(1, CFG.local_view.min_age_ticks):  # fatigue recovers, association still young
        lv.inject(-1, k, pc)
        lv.learn(k, pc)
    lv.inject(3, CFG.local_view.min_age_ticks - 1, pc)
    assert lv.injected == 0.0
    lv.learn(CFG.local_view.min_age_ticks - 1, pc)
    lv2, pc2 = LocalView(CFG), settled()
    lv2.inject(3, 0, pc2)
    lv2.learn(0, pc2)
    for k in range(1, 200):
        lv2.inject(-1, k, pc2)
        lv2.learn(k, pc2)
    lv2.inject(3, 200, pc2)
    assert lv2.activity == 1.0
    assert lv2.injected == pytest.approx(CFG.local_view.inject * w.sum())


def test_fatigue_decays_a_persistent_view_and_recovers():
    lv, pc = LocalView(CFG), settled()
    acts = []
    for k in range(40):
        lv.inject(8, k, pc)
        acts.append(lv.activity)
        lv.learn(k, pc)
    assert acts[0] == 1.0 and acts[1] == pytest.approx(1 - CFG.local_view.fatigue_rate)
    assert acts[-1] == 0.0
    assert lv.fatigue[0] == FATIGUE_CAP
    for k in range(40, 40 + int(FATIGUE_CAP / CFG.local_view.fatigue_recovery) + 1):
        lv.inject(-1, k, pc)
        lv.learn(k, pc)
    assert lv.fatigue[0] == 0.0


def _straight_run(slam, scenes, v=0.3):
    peaks = []
    for s in scenes:
        slam.step(DT, v, 0.0, s)
        peaks.append(slam.peak)
    return np.array(peaks)


def test_a_scene_in_view_for_a_while_does_not_pin_the_packet():
    """ARCHITECTURE.md trap: a scene lasting ~1 m (23 ticks) must not drag the packet back to where the
    view began. First lap: scenes change every 23 ticks along a straight corridor; second pass
    (after the associations are old) sees the same sequence again from the same place. The
    packet keeps moving at v*t on both passes (within one cell)."""
    slam = RatSLAM(CFG)
    scenes = np.repeat(np.arange(8), 23)
    p1 = _straight_run(slam, scenes)
    travelled = 0.3 * DT * len(scenes) / CFG.pose_cells.cell_size_m
    assert (
        abs(wrapped_diff(p1[-1, 0], p1[0, 0] + travelled - 0.3 * DT / CFG.pose_cells.cell_size_m, CFG.pose_cells.nx))
        < 1.0
    )
    # wait (no view) until the associations are old, then drive the same corridor again,
    # starting from the same pose-cell place: put the packet back with a strong injection
    for _ in range(CFG.local_view.min_age_ticks):
        slam.step(DT, 0.0, 0.0, -1)
    start_cell = np.round(p1[0]).astype(int)
    for _ in range(20):
        slam.pose_cells.inject([start_cell], 1.0)
        slam.step(DT, 0.0, 0.0, -1)
    p0 = slam.peak
    p2 = _straight_run(slam, scenes)
    assert np.abs(wrapped_diff(p2[-1, :2], [p0[0] + travelled, p0[1]], GRID[:2])).max() < 1.0
    # and at every tick the packet is within one cell of v*t from the start
    expected_x = p0[0] + 0.3 * DT * np.arange(1, len(scenes) + 1) / CFG.pose_cells.cell_size_m
    assert np.abs(wrapped_diff(p2[:, 0], expected_x, CFG.pose_cells.nx)).max() < 1.0


def test_naive_injection_would_pin_the_packet():
    """The same run with the guards switched off (no fatigue, associations inject at once)
    stalls path integration: this is the trap the guards avoid."""
    cfg = CFG.replace(local_view={"fatigue_rate": 1e-9, "min_age_ticks": 1, "inject": 0.3})
    slam = RatSLAM(cfg)
    scenes = np.full(200, 4)
    p = _straight_run(slam, scenes)
    travelled = 0.3 * DT * len(scenes) / CFG.pose_cells.cell_size_m
    assert wrapped_diff(p[-1, 0], p[0, 0], CFG.pose_cells.nx) < travelled - 3.0


def test_state_round_trip():
    lv, pc = LocalView(CFG), settled()
    for k, s in enumerate([1, 1, 2, -1, 3, 1]):
        lv.inject(s, k, pc)
        pc.step(0.04, 0.01)
        lv.learn(k, pc)
    other = LocalView(CFG)
    other.set_state(lv.get_state())
    for v in range(len(lv)):
        for a, b in zip(lv.associations(v), other.associations(v)):
            np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(lv.fatigue, other.fatigue)
    assert other.cell_of(3) == lv.cell_of(3) == 2
