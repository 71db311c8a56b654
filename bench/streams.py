"""The benchmark streams: the clean case and the hard ones the harness exists to probe.

Each stream is an observation log (odometry + scene numbers; ground truth is not used by the
benchmarks). All are deterministic (fixed seeds).

* ``small_loop``: the Fig 7 loop as shipped (0.3 m/s, 7 Hz, 10% aliased cells, 0.2% false positives).
* ``small_loop_hard``: the same loop with 1% per-tick false positives, 10% aliasing and a
  1.5 deg/s odometric bias (in the odometry both systems see).
* ``office_floor``: the Fig 4 office floor (look-alike rooms B and C) for 20 minutes.
* ``full_floor_fast``: the Fig 11 full floor driven at 2 m/s with 10 Hz ticks (0.2 m per tick;
  turns at up to 180 deg/s). At 5 Hz the simulated robot overshoots corners at such speeds and
  ends against a wall, which would be an easy stream, not a fast one.
* ``plaza1``, ``plaza2``: a real vehicle's wheel odometry (CMU Plaza, shipped with gtsam;
  1 m/s at 5 Hz and 3.5 m/s at 10 Hz) with scene numbers synthesised from its ground truth.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from worlds import ObservationLog, load_world, simulate
from worlds.real_data import load_plaza


def _small_loop_hard() -> ObservationLog:
    w = load_world("small_loop")
    w = dataclasses.replace(
        w,
        scenes=dataclasses.replace(w.scenes, alias_rate=0.1, false_positive_rate=0.01),
        odometry=dataclasses.replace(w.odometry, bias_deg_s=1.5),
    )
    return simulate(w, duration=900.0, seed=1)


def _full_floor_fast() -> ObservationLog:
    w = load_world("full_floor")
    w = dataclasses.replace(
        w, tick_rate=10.0, robot=dataclasses.replace(w.robot, speed=2.0, max_turn_rate_deg=180.0, arrive_radius=0.6)
    )
    return simulate(w, duration=600.0, seed=0)


STREAMS: dict[str, Callable[[], ObservationLog]] = {
    "small_loop": lambda: simulate("small_loop", duration=900.0, seed=0),
    "small_loop_hard": _small_loop_hard,
    "office_floor": lambda: simulate("office_floor", duration=1200.0, seed=0),
    "full_floor_fast": _full_floor_fast,
    "plaza1": lambda: load_plaza("plaza1"),
    "plaza2": lambda: load_plaza("plaza2"),
}
