"""The benchmark streams: whole runs, the clean case and the hard ones the harness exists to probe.

Each stream is an observation log (odometry + scene numbers; ground truth is not used by the
benchmarks), always run whole. All are deterministic (fixed seeds).

* ``small_loop``: the Fig 7 loop as shipped, 15 min (0.3 m/s, 7 Hz, 10% aliased cells, 0.2%
  false positives).
* ``small_loop_hard``: the same loop, 15 min, with 1% per-tick false positives, 10% aliasing and
  a 1.5 deg/s odometric bias (in the odometry both systems see).
* ``figure_eight``: the full floor's two left-hand corridor loops driven as a figure eight (the
  upper loop clockwise, the lower one anticlockwise, both through the shared corridor
  westwards), 12 min with a 1 deg/s odometric bias.
* ``full_floor_fast``: the Fig 11 full floor driven at 2 m/s with 10 Hz ticks (0.2 m per tick;
  turns at up to 180 deg/s), 10 min. At 5 Hz the simulated robot overshoots corners at such
  speeds and ends against a wall, which would be an easy stream, not a fast one.
* ``plaza1``, ``plaza2``: a real vehicle's wheel odometry, whole (CMU Plaza, shipped with gtsam;
  1 m/s at 5 Hz for 32 min and 3.5 m/s at 10 Hz for 7 min) with scene numbers synthesised from
  its ground truth (the figures' scene model).
* ``plaza2_hard``: Plaza 2 with 3 m scene cells, 2% false positives and 15% aliasing.
* ``office_floor``: the Fig 4 office floor (look-alike rooms B and C), 2.5 h, on Fig 4's
  40 x 40 x 36 pose-cell grid (:data:`GRIDS`).
* ``independent_square``, ``independent_eight``, ``independent_lanes``: logs from pure kinematics,
  independent of the simulator (``bench/independent_logs.py``, seed 0, at 10 Hz): a 15-min square
  loop with a 1.5 deg/s gyro bias, a 12-min figure eight with 1 deg/s, 20 min of lanes with
  -1.2 deg/s; 1 % false positives, 10 % aliased cells and 5 % blank ticks each.

Every other stream runs on the default grid (60 x 60 x 36).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from independent_logs import log_spec, make_log

from worlds import ObservationLog, load_world, simulate
from worlds.real_data import PLAZA_SCENES, load_plaza


def _small_loop_hard() -> ObservationLog:
    w = load_world("small_loop")
    w = dataclasses.replace(w, scenes=dataclasses.replace(w.scenes, alias_rate=0.1))
    return simulate(w, duration=900.0, seed=1, bias_deg_s=1.5, fp_rate=0.01)


def _figure_eight() -> ObservationLog:
    w = load_world("full_floor")
    tour = ("M0", "UL1", "UL2", "M3", "M2", "M1", "M0", "LL1", "LL2", "M1", "M0")
    w = dataclasses.replace(w, route_mode="lap", tour=tour, start=(1.0, 6.5, 1.5707963267948966))
    return simulate(w, duration=720.0, seed=0, bias_deg_s=1.0)


def _full_floor_fast() -> ObservationLog:
    w = load_world("full_floor")
    w = dataclasses.replace(
        w, tick_rate=10.0, robot=dataclasses.replace(w.robot, speed=2.0, max_turn_rate_deg=180.0, arrive_radius=0.6)
    )
    return simulate(w, duration=600.0, seed=0)


def _plaza2_hard() -> ObservationLog:
    return load_plaza("plaza2", scenes=dataclasses.replace(PLAZA_SCENES, cell_size=3.0, alias_rate=0.15), fp_rate=0.02)


def _independent(name: str) -> ObservationLog:
    return ObservationLog(**make_log(log_spec(name, 0)))


STREAMS: dict[str, Callable[[], ObservationLog]] = {
    "small_loop": lambda: simulate("small_loop", duration=900.0, seed=0),
    "small_loop_hard": _small_loop_hard,
    "figure_eight": _figure_eight,
    "full_floor_fast": _full_floor_fast,
    "plaza1": lambda: load_plaza("plaza1"),
    "plaza2": lambda: load_plaza("plaza2"),
    "plaza2_hard": _plaza2_hard,
    "office_floor": lambda: simulate("office_floor", duration=9000.0, seed=0),
    "independent_square": lambda: _independent("square"),
    "independent_eight": lambda: _independent("eight"),
    "independent_lanes": lambda: _independent("lanes"),
}

GRIDS: dict[str, tuple[int, int, int]] = {"office_floor": (40, 40, 36)}
"""Pose-cell grid (nx, ny, n_theta) of the streams that do not run on the default one."""
