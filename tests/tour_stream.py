"""A stream from outside the simulator: a robot touring random waypoints in an open area.

Written apart from ``worlds`` (no pymunk, no route network, no scene layout of its own), so the
SLAM is tested on a stream the simulator did not make: headings at any angle (not along the
pose-cell grid's axes), a 10 Hz tick, 1.5 m scene cells crossed with 8 heading sectors, aliased
and blank cells, false positives, and a gyro bias. Deterministic for a seed.
"""

from __future__ import annotations

import numpy as np

from worlds import ObservationLog

AREA = (30.0, 20.0)  # m
WAYPOINTS = 12  # toured in order, over and over: the revisits
TICK_HZ = 10.0
SPEED = 0.5  # m/s
MAX_TURN = 0.8  # rad/s
CELL = 1.5  # m
SECTORS = 8
ALIASED = BLANK = 0.05  # fractions of the scene cells
FALSE_POSITIVES = 0.005  # per tick


def waypoint_tour(seed: int, bias_deg_s: float, duration_s: float = 1800.0, noise: float = 0.01) -> ObservationLog:
    """The tour's observation log (ground truth included) with ``bias_deg_s`` on the gyro and white
    noise of ``noise`` (m/s, rad/s) on the speed and the yaw rate."""
    rng = np.random.default_rng(seed)
    dt, n = 1.0 / TICK_HZ, int(duration_s * TICK_HZ)
    waypoints = rng.uniform((2.0, 2.0), (AREA[0] - 2.0, AREA[1] - 2.0), size=(WAYPOINTS, 2))
    gt, v, w = np.zeros((n, 3)), np.zeros(n), np.zeros(n)
    x, y, th, target = waypoints[0, 0], waypoints[0, 1], 0.0, 1
    for k in range(n):
        tx, ty = waypoints[target % WAYPOINTS]
        if np.hypot(tx - x, ty - y) < 0.5:
            target += 1
        err = (np.arctan2(ty - y, tx - x) - th + np.pi) % (2.0 * np.pi) - np.pi
        w[k] = np.clip(1.5 * err, -MAX_TURN, MAX_TURN)
        v[k] = SPEED * max(0.2, np.cos(err))
        th += w[k] * dt
        x, y = x + v[k] * dt * np.cos(th), y + v[k] * dt * np.sin(th)
        gt[k] = x, y, th
    v_odo = 1.01 * v + rng.normal(0.0, noise, n)
    w_odo = w + np.radians(bias_deg_s) + rng.normal(0.0, noise, n)
    # scene numbers: (cell, heading sector) -> a number, some cells showing another's or nothing
    sector = np.floor((gt[:, 2] % (2.0 * np.pi)) / (2.0 * np.pi) * SECTORS).astype(np.int64) % SECTORS
    key = (np.floor(gt[:, 0] / CELL).astype(np.int64) * 1000 + np.floor(gt[:, 1] / CELL).astype(np.int64)) * 10
    key += sector
    cells, index = np.unique(key, return_inverse=True)
    number = rng.permutation(len(cells)) + 100
    aliased = rng.choice(len(cells), size=int(ALIASED * len(cells)), replace=False)
    number[aliased] = number[rng.integers(len(cells), size=len(aliased))]
    blank = rng.choice(len(cells), size=int(BLANK * len(cells)), replace=False)
    number[blank] = -1
    scene = number[index]
    fp = rng.random(n) < FALSE_POSITIVES
    scene[fp] = rng.choice(np.unique(scene[scene >= 0]), size=int(fp.sum()))
    return ObservationLog(
        t=np.arange(1, n + 1) * dt,
        dt=np.full(n, dt),
        v_trans=v_odo,
        v_rot=w_odo,
        scene_id=scene,
        gt_x=gt[:, 0],
        gt_y=gt[:, 1],
        gt_theta=gt[:, 2],
        false_positive=fp,
    )
