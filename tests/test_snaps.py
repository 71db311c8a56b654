"""Snaps: the step's scalar check and the arrays' check are the same computation."""

import numpy as np

from ratslam.snaps import is_snap, peak_jump, snapped


def test_the_scalar_check_is_the_array_check_bit_for_bit():
    """On random peak pairs (many jumping round the torus), ``snapped`` says a snap exactly where
    ``is_snap`` does, at a threshold on either side of each pair's jump distance: the two compute
    the same distance to the last bit."""
    rng = np.random.default_rng(0)
    grid = (60.0, 60.0, 36.0)
    old = rng.uniform(0.0, 1.0, (500, 3)) * grid
    new = np.where(
        rng.random((500, 1)) < 0.5, old + rng.normal(0.0, 2.0, (500, 3)), rng.uniform(0.0, 1.0, (500, 3)) * grid
    )
    new %= grid
    jumps = peak_jump(old, new, grid)
    for o, p, d in zip(old, new, jumps):
        for threshold in (d, np.nextafter(d, 0.0), np.nextafter(d, np.inf)):
            assert snapped(o, p, grid, threshold) == bool(is_snap(o, p, grid, threshold))
        assert not snapped(o, p, grid, d) and snapped(o, p, grid, np.nextafter(d, 0.0))
