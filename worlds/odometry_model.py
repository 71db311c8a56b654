"""Wheel odometry as a real robot measures it: the body's true motion with systematic errors.

Per tick, from the true forward speed ``v`` and yaw rate ``w`` (midpoint-heading unicycle):

- scale error ``scale_error``: a wheel-radius error, every distance reported ``1 + scale_error``
  times too long;
- turn error ``turn_scale_error``: an effective-wheel-base error, every turn reported
  ``1 + turn_scale_error`` times too large (a heading error proportional to the angle turned,
  0.5% = 1.8 deg per full turn);
- heading drift ``drift_deg_per_m``: unequal wheel radii, a heading error proportional to the
  distance driven (the wheel-odometry form of a yaw bias: it scales with speed);
- wheel slip: episodes starting at ``slip_rate`` per second and lasting ``slip_duration`` s, in
  which one wheel (either side, at random) turns ``slip_fraction`` of the speed faster than the
  ground goes by; the odometry then reports half of that as extra distance and the difference
  over the wheel base as a spurious yaw rate;
- a constant yaw-rate bias ``bias_deg_s`` (a gyro's, or Figs 8-10's manipulation);
- white noise ``noise_trans`` (m/s) and ``noise_rot`` (rad/s) on every tick.

The errors of a real vehicle's wheel odometry (the CMU Plaza logs), as calibrated for the figures'
``wheel_errors`` variants, and how: docs/results.md. Slip is off by default.
"""

from __future__ import annotations

import math

import numpy as np

from .world import OdometrySpec

# The worse of the two CMU Plaza vehicles' calibrated errors, per kind (see above): what a figure's
# "wheel errors" variant adds to a world's odometry.
PLAZA_WHEEL_ERRORS = {"scale_error": 0.0008, "turn_scale_error": -0.0129, "drift_deg_per_m": -0.107}


def measured_odometry(
    v_true: np.ndarray,
    w_true: np.ndarray,
    spec: OdometrySpec,
    dt: float,
    wheel_base: float,
    noise_rng: np.random.Generator,
    slip_rng: np.random.Generator,
    bias_deg_s: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The odometry (v_trans, v_rot) per tick for the true body velocities (arrays of one
    length). ``bias_deg_s`` overrides ``spec.bias_deg_s``. The noise is drawn from ``noise_rng``
    (two normal draws per tick, translation first), slip from its own ``slip_rng`` (only when
    slip is on), so a stream without slip is the same with or without this model."""
    n = len(v_true)
    bias = spec.bias_deg_s if bias_deg_s is None else float(bias_deg_s)
    v = v_true * (1.0 + spec.scale_error) + noise_rng.normal(0.0, spec.noise_trans, n)
    w = w_true * (1.0 + spec.turn_scale_error) + math.radians(bias) + noise_rng.normal(0.0, spec.noise_rot, n)
    if spec.drift_deg_per_m != 0.0:
        w = w + math.radians(spec.drift_deg_per_m) * v_true
    if spec.slip_rate > 0.0 and spec.slip_fraction > 0.0:
        extra = slip_per_tick(n, dt, spec, slip_rng) * np.abs(v_true)  # m/s the slipping wheel over-reports
        v = v + np.abs(extra) / 2.0
        w = w + extra / wheel_base
    return v, w


def slip_per_tick(n: int, dt: float, spec: OdometrySpec, rng: np.random.Generator) -> np.ndarray:
    """Per tick: 0 outside a slip episode, ±``slip_fraction`` inside one (the sign is the side of
    the slipping wheel: + the right wheel, which turns the reported heading left)."""
    starts = np.flatnonzero(rng.random(n) < spec.slip_rate * dt)
    sides = np.where(rng.random(len(starts)) < 0.5, -1.0, 1.0)
    length = max(1, int(round(spec.slip_duration / dt)))
    out = np.zeros(n)
    for k, side in zip(starts, sides):
        out[k : k + length] = side * spec.slip_fraction
    return out
