"""A large box's step layer by layer (ratslam.pose_cell_layers) equals the step of the whole box
(ratslam.pose_cell_split.step_one_box) bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import ratslam.pose_cells as pose_cells
from ratslam import RatSLAMConfig
from ratslam import pose_cell_layers as L
from ratslam import pose_cell_split as S
from ratslam.config import PoseCellConfig
from ratslam.pose_cells import PoseCells

from .test_pose_cell_split import _random_box


def _same(want, got) -> bool:
    return (
        want[0] == got[0]
        and np.array_equal(want[1], got[1])
        and want[2].shape == got[2].shape
        and want[2].tobytes() == got[2].tobytes()
        and want[3].tobytes() == got[3].tobytes()
    )


def _both(cells: PoseCells, act, start, dist, rot):
    args = (start, *cells._network, cells._cos, cells._sin, dist, rot, cells.config.pose_cells.peak_radius_cells)
    return S.step_one_box(act, *args), L.step_one_box(act, L.layer_windows(act), *args)


@pytest.mark.parametrize("grid", [(60, 60, 36), (16, 14, 12), (40, 40, 36)])
@pytest.mark.parametrize("weight", [0.5, 0.0])
def test_layered_step_equals_whole_box_step(grid, weight):
    """Random boxes of packets, translations and rotations of either sign (on the small grid the
    boxes span the rings, so crops that wrap round x' or y' are among them)."""
    nx, ny, nth = grid
    cells = PoseCells(RatSLAMConfig(pose_cells=PoseCellConfig(nx=nx, ny=ny, n_theta=nth, inhibit_weight=weight)))
    n = (nth, nx, ny)
    rng = np.random.default_rng(sum(grid))
    survived = 0
    for trial in range(250):
        start, act = _random_box(rng, n, 5)
        if not act.any():
            continue
        act /= act.sum()
        dist = rng.uniform(-2.0, 2.0) * (rng.uniform() < 0.8)
        rot = rng.uniform(-1.5, 1.5) * (rng.uniform() < 0.7)
        want, got = _both(cells, act, start, dist, rot)
        assert _same(want, got), trial
        survived += bool(want[0])
    assert survived > 150  # most trials step a live network, not only the empty case


def test_a_crop_round_the_ring_equals_the_whole_box():
    """Packets at both ends of a box that spans x' and y' whole: the crop wraps round the rings."""
    cells = PoseCells(RatSLAMConfig(pose_cells=PoseCellConfig(nx=30, ny=30, n_theta=36)))
    act = np.zeros((5, 30, 30))
    act[2, 1, 1] = act[2, 28, 28] = 0.4
    act[1:4, 0:3, 27:30] = 0.02
    act /= act.sum()
    for dist, rot in ((0.0, 0.0), (0.7, -0.3), (-1.2, 0.6)):
        want, got = _both(cells, act, np.array([3, 0, 0], dtype=np.int64), dist, rot)
        start, shape = want[1], want[2].shape
        assert start[1] + shape[1] > 30 and start[2] + shape[2] > 30  # the new box wraps round both
        assert _same(want, got)


def test_sparse_windows_leave_dense_boxes_whole():
    act = np.zeros((4, 20, 20))
    act[1, 2:4, 2:4] = 1.0
    assert len(L.sparse_windows(act, 0.3)) == 4  # 4 of 1,600 cells
    act[:, 1:19, 1:19] = 1.0
    assert len(L.sparse_windows(act, 0.3)) == 0


def test_a_run_is_the_same_with_every_box_stepped_layer_by_layer(monkeypatch):
    """Pose cells stepped with energy injected at random cells (new packets, boxes merged), once
    with every one-box step layer by layer and once never: the same boxes and peaks every step."""
    config = RatSLAMConfig(pose_cells=PoseCellConfig(nx=40, ny=40, n_theta=36))

    def run(layered: bool) -> list:
        monkeypatch.setattr(pose_cells, "LAYERED_MIN_CELLS", 0 if layered else 10**12)
        monkeypatch.setattr(pose_cells, "LAYERED_MAX_COVER", 1.0)
        rng = np.random.default_rng(7)
        cells = PoseCells(config)
        out = []
        for tick in range(400):
            if tick % 9 == 0:
                cell = [int(rng.integers(0, m)) for m in (40, 40, 36)]
                cells.inject(np.array([cell]), float(rng.uniform(0.05, 0.3)))
            cells.step(float(rng.uniform(0.0, 0.4)), float(rng.uniform(-0.1, 0.1)))
            out.append((cells.peak.tobytes(), [(s.tobytes(), a.shape, a.tobytes()) for s, a in cells._boxes]))
        return out

    assert run(True) == run(False)
