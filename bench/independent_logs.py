"""Observation logs from pure kinematics, independent of the simulator (no ``worlds``).

A check on logs the systems were not tuned on: each log is a route of straight segments and
circular arcs driven with a speed profile (slower in turns, bounded acceleration, a slowly
wandering cruise speed and an occasional stop), sampled at a fixed tick, written in the
observation-log contract (``t,dt,v_trans,v_rot,scene_id,gt_x,gt_y,gt_theta,false_positive``;
``scene_id`` -1 where nothing is recognised).

* Odometry: the true speed and yaw rate plus white Gaussian noise, the yaw rate also plus a
  constant bias (a gyro's), so the dead-reckoned heading drifts by the bias times the time.
* Scene numbers: the true position's cell on a square grid (``cell_m``), each cell a random
  number (numbers do not encode position); a fraction ``alias_rate`` of the visited cells shows
  the number of another visited cell at least ``alias_min_m`` away; on a fraction ``fp_rate`` of
  the ticks the number is that of a random visited cell (a false positive, flagged in
  ``false_positive``); on a fraction ``blank_rate`` of the ticks nothing is recognised (-1),
  in short runs.

Every log is a deterministic function of its :class:`LogSpec` (the seed included).

Run:  python bench/independent_logs.py --out DIR [--seeds 0,1,2] [--logs square,eight,...] [--no-stops]
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

# A route: (length m, curvature 1/m) segments, driven in order and repeated.
Route = tuple[tuple[float, float], ...]


def rounded_square(side_m: float = 10.0, corner_radius_m: float = 1.0) -> Route:
    """An anticlockwise square loop of ``side_m`` with quarter-circle corners."""
    straight = side_m - 2.0 * corner_radius_m
    arc = (0.5 * math.pi * corner_radius_m, 1.0 / corner_radius_m)
    return ((straight, 0.0), arc) * 4


def figure_eight(lobe_radius_m: float = 3.0) -> Route:
    """Two 270-degree lobes (one anticlockwise, one clockwise) joined by two straights that
    cross at right angles in the middle."""
    r = lobe_radius_m
    straight = 2.0 * r  # tangent length from the crossing to each lobe, twice over
    arc = 1.5 * math.pi * r
    return ((straight, 0.0), (arc, 1.0 / r), (straight, 0.0), (arc, -1.0 / r))


def lanes(length_m: float = 16.0, spacing_m: float = 2.5, count: int = 4) -> Route:
    """A lawn: ``count`` (even) parallel lanes mowed in turn, joined by half-turns, then back
    along the side to the first lane's start."""
    r = 0.5 * spacing_m
    segs: list[tuple[float, float]] = []
    sign = 1.0
    for i in range(count):
        segs.append((length_m, 0.0))
        if i < count - 1:
            segs.append((math.pi * r, sign / r))
            sign = -sign
    quarter = (0.5 * math.pi * r, 1.0 / r)
    return (*segs, quarter, ((count - 1) * spacing_m - 2.0 * r, 0.0), quarter)


SQUARE = rounded_square()


@dataclass(frozen=True)
class LogSpec:
    """Everything that makes one log (defaults: a 15-min square loop, 1.5 deg/s bias)."""

    name: str = "square"
    route: Route = SQUARE
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    duration_s: float = 900.0
    rate_hz: float = 10.0
    cruise_m_s: float = 0.4  # speed on straights
    lateral_accel_m_s2: float = 0.08  # turns are taken at sqrt(a / curvature) at most
    accel_m_s2: float = 0.2
    speed_wander: float = 0.1  # relative std of the slowly varying cruise speed
    stop_every_s: float = 120.0  # mean time between stops (exponential; inf: none)
    stop_s: float = 4.0
    sigma_v_m_s: float = 0.015
    sigma_w_rad_s: float = 0.015
    bias_deg_s: float = 1.5
    cell_m: float = 1.5
    alias_rate: float = 0.1
    alias_min_m: float = 5.0
    fp_rate: float = 0.01
    blank_rate: float = 0.05
    blank_run_ticks: int = 5
    seed: int = 0


LOGS: dict[str, LogSpec] = {
    "square": LogSpec(),
    "small_square": LogSpec(name="small_square", route=rounded_square(5.0, 0.75), cruise_m_s=0.3),
    "eight": LogSpec(name="eight", route=figure_eight(), duration_s=720.0, bias_deg_s=1.0, cell_m=1.5),
    "lanes": LogSpec(
        name="lanes",
        route=lanes(),
        duration_s=1200.0,
        bias_deg_s=-1.2,
        cell_m=2.0,
        cruise_m_s=0.6,
        sigma_v_m_s=0.02,
        sigma_w_rad_s=0.01,
    ),
}
"""The shipped logs: a 15-min square loop (10 m sides, 1.5 deg/s bias, 1.5 m cells), the same on
5 m sides at 0.3 m/s (the dead reckoning errs half as much), a 12-min figure eight (3 m lobes,
1 deg/s) and a 20-min lawn of four 16 m lanes and the way back (-1.2 deg/s, 2 m cells, faster)."""


def _speed_limits(route: Route, spec: LogSpec, ds: float) -> tuple[np.ndarray, np.ndarray]:
    """Curvature and the speed limit over one lap sampled every ``ds`` metres (forward and
    backward passes bound the acceleration; the lap is periodic, so it is laid out twice)."""
    kappa = np.concatenate([np.full(max(1, round(length / ds)), k) for length, k in route])
    limit = np.where(kappa == 0.0, spec.cruise_m_s, np.sqrt(spec.lateral_accel_m_s2 / np.maximum(np.abs(kappa), 1e-9)))
    limit = np.minimum(limit, spec.cruise_m_s)
    n = len(limit)
    v = np.tile(limit, 3)
    for _ in range(2):
        for i in range(1, len(v)):
            v[i] = min(v[i], math.sqrt(v[i - 1] ** 2 + 2.0 * spec.accel_m_s2 * ds))
        for i in range(len(v) - 2, -1, -1):
            v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2.0 * spec.accel_m_s2 * ds))
    return kappa, v[n : 2 * n]


def ground_truth(spec: LogSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """True (x, y, theta) after each tick and the true speed and yaw rate over it."""
    rng = np.random.default_rng([spec.seed, 1])
    dt = 1.0 / spec.rate_hz
    n = int(round(spec.duration_s * spec.rate_hz))
    ds = 0.01
    kappa, vmax = _speed_limits(spec.route, spec, ds)
    lap = len(kappa) * ds
    x, y, th = spec.start
    s = 0.0
    wander = 0.0  # Ornstein-Uhlenbeck, relative, time constant 30 s
    tau = 30.0
    stop_left = 0.0
    v = 0.0
    pose = np.empty((n, 3))
    vt, wt = np.empty(n), np.empty(n)
    for k in range(n):
        wander += -wander * dt / tau + spec.speed_wander * math.sqrt(2.0 * dt / tau) * rng.standard_normal()
        if stop_left <= 0.0 and rng.random() < dt / spec.stop_every_s:
            stop_left = spec.stop_s
        i = int(s / ds) % len(kappa)
        target = 0.0 if stop_left > 0.0 else vmax[i] * (1.0 + wander)
        stop_left -= dt
        dv = float(np.clip(target - v, -spec.accel_m_s2 * dt * 2.0, spec.accel_m_s2 * dt))
        v = max(0.0, v + dv)
        # integrate the arc length of this tick through the route's curvature, in sub-steps
        step, turn = v * dt, 0.0
        sub = max(1, int(math.ceil(step / ds)))
        h = step / sub
        for _ in range(sub):
            kk = kappa[int(s / ds) % len(kappa)]
            th_mid = th + 0.5 * kk * h
            x += h * math.cos(th_mid)
            y += h * math.sin(th_mid)
            th += kk * h
            turn += kk * h
            s = (s + h) % lap
        pose[k] = (x, y, math.atan2(math.sin(th), math.cos(th)))
        vt[k], wt[k] = step / dt, turn / dt
    return pose, vt, wt, np.full(n, dt)


def scene_numbers(spec: LogSpec, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Scene number per tick (-1 blank) and whether it is a false positive."""
    rng = np.random.default_rng([spec.seed, 2])
    n = len(pose)
    cells = np.floor(pose[:, :2] / spec.cell_m).astype(np.int64)
    visited, index = np.unique(cells, axis=0, return_inverse=True)
    index = index.reshape(-1)
    numbers = rng.permutation(len(visited) * 7)[: len(visited)] + 1000
    centres = (visited + 0.5) * spec.cell_m
    shown = numbers.copy()
    n_alias = int(round(spec.alias_rate * len(visited)))
    for i in rng.permutation(len(visited))[:n_alias]:
        far = np.flatnonzero(np.hypot(*(centres - centres[i]).T) >= spec.alias_min_m)
        if far.size:
            shown[i] = numbers[rng.choice(far)]
    scene = shown[index]
    fp = rng.random(n) < spec.fp_rate
    scene[fp] = shown[rng.integers(0, len(visited), size=int(fp.sum()))]
    fp &= scene != shown[index]
    starts = rng.random(n) < spec.blank_rate / spec.blank_run_ticks
    blank = np.zeros(n, dtype=bool)
    for k in np.flatnonzero(starts):
        blank[k : k + spec.blank_run_ticks] = True
    scene[blank] = -1
    fp &= ~blank
    return scene, fp


def log_spec(name: str, seed: int, duration_s: float | None = None, stops: bool = True) -> LogSpec:
    """The spec of log ``name`` with ``seed``, its duration replaced if given, without stops if asked."""
    spec = replace(LOGS[name], seed=seed)
    if duration_s:
        spec = replace(spec, duration_s=duration_s)
    if not stops:
        spec = replace(spec, stop_every_s=math.inf)
    return spec


def make_log(spec: LogSpec) -> dict[str, np.ndarray]:
    """The log's columns (the contract's names)."""
    pose, vt, wt, dt = ground_truth(spec)
    rng = np.random.default_rng([spec.seed, 3])
    n = len(dt)
    v_log = vt + spec.sigma_v_m_s * rng.standard_normal(n)
    w_log = wt + math.radians(spec.bias_deg_s) + spec.sigma_w_rad_s * rng.standard_normal(n)
    scene, fp = scene_numbers(spec, pose)
    return {
        "t": np.cumsum(dt),
        "dt": dt,
        "v_trans": v_log,
        "v_rot": w_log,
        "scene_id": scene,
        "gt_x": pose[:, 0],
        "gt_y": pose[:, 1],
        "gt_theta": pose[:, 2],
        "false_positive": fp.astype(int),
    }


def write_log(columns: dict[str, np.ndarray], path: Path) -> None:
    """Write the columns as an observation-log CSV (to a temporary name, then moved into place)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(",".join(columns) + "\n")
            cols = list(columns.values())
            for k in range(len(cols[0])):
                f.write(
                    f"{cols[0][k]:.3f},{cols[1][k]:.3f},{cols[2][k]:.6f},{cols[3][k]:.6f},{int(cols[4][k])},"
                    f"{cols[5][k]:.5f},{cols[6][k]:.5f},{cols[7][k]:.6f},{int(cols[8][k])}\n"
                )
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path, help="folder for the logs (NAME_sSEED.csv)")
    ap.add_argument("--seeds", default="0,1,2", help="comma-separated seeds (default 0,1,2)")
    ap.add_argument("--logs", default=",".join(LOGS), help=f"comma-separated logs (default {','.join(LOGS)})")
    ap.add_argument("--duration", type=float, help="seconds (default: each log's own)")
    ap.add_argument("--no-stops", action="store_true", help="the robot never stands still")
    args = ap.parse_args(argv)
    for name in args.logs.split(","):
        if name not in LOGS:
            ap.error(f"--logs: unknown log {name!r} (known: {', '.join(LOGS)})")
        for seed in (int(s) for s in args.seeds.split(",")):
            spec = log_spec(name, seed, args.duration, stops=not args.no_stops)
            path = args.out / f"{name}_s{seed}.csv"
            write_log(make_log(spec), path)
            print(path)


if __name__ == "__main__":
    main()
