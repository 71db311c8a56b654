"""Fast paths of the pose-cell kernels equal their plain forms bit for bit: the group-by-group
attractor iteration, the clustering of new boxes, the cells above a threshold in index order."""

from __future__ import annotations

import numpy as np
import pytest

from ratslam import RatSLAMConfig
from ratslam import pose_cell_kernels as K
from ratslam import pose_cell_split as S
from ratslam.config import PoseCellConfig
from ratslam.pose_cells import PoseCells


def _args(config: RatSLAMConfig, act: np.ndarray, start: np.ndarray):
    return (act, start, *PoseCells(config)._network)


def _blobs(rng, shape, count):
    act = np.zeros(shape)
    for _ in range(count):
        size = [int(rng.integers(1, min(6, s) + 1)) for s in shape]
        at = [int(rng.integers(0, s - z + 1)) for s, z in zip(shape, size)]
        region = tuple(slice(a, a + z) for a, z in zip(at, size))
        act[region] += rng.uniform(0.0, 1e-2, size) * (rng.uniform(size=size) < 0.8)
    return act


def _random_box(rng, n, most_blobs):
    """A box of random shape and start on a ring of ``n`` (θ', x', y') holding 1 to
    ``most_blobs`` packets: (start, activity)."""
    shape = tuple(int(rng.integers(1, s + 1)) for s in n)
    start = np.array([int(rng.integers(0, s)) for s in n], dtype=np.int64)
    return start, _blobs(rng, shape, int(rng.integers(1, most_blobs + 1)))


@pytest.mark.parametrize("grid, min_split", [((60, 60, 36), 30), ((16, 14, 12), 0), ((40, 40, 36), 30)])
def test_group_iteration_equals_whole_box(grid, min_split):
    """Random boxes of packets (on a small grid every box is near the whole ring: no cuts)."""
    nx, ny, nth = grid
    config = RatSLAMConfig(pose_cells=PoseCellConfig(nx=nx, ny=ny, n_theta=nth))
    n = (nth, nx, ny)
    ring = np.array(n, dtype=np.int64)
    rng = np.random.default_rng(sum(grid))
    split = 0
    for trial in range(300):
        start, act = _random_box(rng, n, 4)
        args = _args(config, act, start)
        want = K.network_box(*args)
        got = S.network_box(*args)
        assert np.array_equal(got[0], want[0]), trial
        assert got[1].shape == want[1].shape and got[1].tobytes() == want[1].tobytes(), trial
        assert got[2] == want[2], trial
        parts = len(S.groups(act, ring, 7))
        assert S._one_group(act, ring, 7) == (parts <= 1), trial  # the shortcut's test
        split += parts > 1
    assert split >= min_split  # the grouped path is exercised, not only the whole-box fallback


def test_groups_cut_far_packets_and_keep_near_ones():
    n = np.array([36, 60, 60], dtype=np.int64)
    act = np.zeros((3, 30, 5))
    act[1, 2, 2] = act[1, 27, 2] = 1.0  # 24 empty cells apart along x'
    assert S.groups(act, n, 7).tolist() == [[1, 2, 2, 3, 2, 3], [1, 2, 27, 28, 2, 3]]
    act[1, 10, 2] = act[1, 18, 2] = 1.0  # gaps of 7, 7 and 8 cells: only the last is a cut
    assert S.groups(act, n, 7).tolist() == [[1, 2, 2, 19, 2, 3], [1, 2, 27, 28, 2, 3]]
    ring = np.zeros((36, 1, 1))
    ring[0] = ring[31] = 1.0  # 30 empty cells inside the box, 4 round the ring: one group
    assert len(S.groups(ring, n, 7)) == 1


def test_new_boxes_follow_the_seeded_clusters():
    rng = np.random.default_rng(3)
    n = np.array([36, 60, 60], dtype=np.int64)
    g = np.stack([rng.integers(0, m, 200) for m in n])
    energy = rng.uniform(size=200)
    todo = rng.uniform(size=200) < 0.7
    starts, shapes, values = K.boxes_of_clusters(g, energy, todo, n, 14)
    bounds = np.concatenate(([0], np.cumsum(np.prod(shapes, axis=1))))
    acts = [values[a:b].reshape(tuple(s)) for a, b, s in zip(bounds[:-1], bounds[1:], shapes)]
    # reference: the first pending cell seeds a cluster of the pending cells near it, in order
    remaining = np.flatnonzero(todo)
    want = []
    while remaining.size:
        d = np.abs(g[:, remaining] - g[:, remaining[:1]])
        near = np.all(np.minimum(d, n[:, None] - d) <= 14, axis=0)
        members, remaining = remaining[near], remaining[~near]
        want.append(K.box_of_cells(np.ascontiguousarray(g[:, members]), energy[members], n))
    assert len(starts) == len(want) > 1
    for s, a, (ws, wa) in zip(starts, acts, want):
        assert np.array_equal(s, ws) and a.tobytes() == wa.tobytes()


def test_cells_at_least_are_the_sorted_cells_above_threshold():
    rng = np.random.default_rng(5)
    for trial in range(500):
        n = rng.integers(4, 40, 3).astype(np.int64)
        shape = tuple(int(rng.integers(1, m + 1)) for m in n)
        start = np.array([rng.integers(0, m) for m in n], dtype=np.int64)
        act = rng.uniform(size=shape) * (rng.uniform(size=shape) < 0.5)
        threshold = rng.uniform(0.0, 0.5)
        lin, val = K.cells_at_least(act, start, n, threshold)
        t, x, y = np.nonzero((act > 0) & (act >= threshold))
        want = (((x + start[1]) % n[1]) * n[2] + (y + start[2]) % n[2]) * n[0] + (t + start[0]) % n[0]
        order = np.argsort(want)
        assert np.array_equal(lin, want[order]) and np.array_equal(val, act[t, x, y][order]), trial
