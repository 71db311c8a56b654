"""Offset transitions (ratslam/entry_offset.py; not in the paper): where the robot stands in a
re-entered experience's frame, from the peak's offset from the experience's cells; the paper's
(the switch off) on the experience itself."""

import math

import numpy as np
import pytest

from ratslam import RatSLAMConfig
from ratslam.entry_offset import ON_THE_EXPERIENCE, EntryOffset, peak_offset

CFG = RatSLAMConfig()  # 0.25 m cells, 36 heading cells of 10 deg, a 60 x 60 grid


def test_the_peaks_offset_is_in_the_experiences_frame():
    """An experience facing +y' (heading cell 9 = 90 deg): a peak one cell along +x' is a
    quarter metre to its right, one heading cell more is 10 deg to the left."""
    off = peak_offset(np.array([10.0, 10.0, 9.0]), np.array([11.0, 10.0, 10.0]), CFG)
    assert off == pytest.approx((0.0, -0.25, math.radians(10.0)), abs=1e-12)


def test_the_offset_wraps_across_the_grids_faces():
    off = peak_offset(np.array([59.5, 10.0, 35.0]), np.array([0.5, 10.0, 0.0]), CFG)
    assert off[0] == pytest.approx(math.cos(math.radians(350.0)) * 0.25)
    assert off[2] == pytest.approx(math.radians(10.0))


def test_the_switch_off_puts_the_robot_on_the_experience():
    cell, peak = np.array([10.0, 10.0, 0.0]), np.array([11.0, 11.0, 1.0])
    assert EntryOffset(CFG)(cell, peak) == pytest.approx((0.25, 0.25, math.radians(10.0)))
    off = CFG.replace(experience_map={"offset_transitions": False})
    assert EntryOffset(off)(cell, peak) == ON_THE_EXPERIENCE == (0.0, 0.0, 0.0)
