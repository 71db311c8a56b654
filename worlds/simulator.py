"""The pymunk world simulator: a disc robot drives the route network among static walls.

One physics step per tick (7 Hz by default). The controller's command reaches the body through
``velocity_func`` so that the contact solver still acts on it and the robot never passes through
a wall. Wheel odometry is the body's true motion over each tick with the world's systematic
errors, bias and noise (:mod:`worlds.odometry_model`); scene numbers come from the scene model.
Ground truth is kept alongside for metrics.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pymunk

from .errors import InputError
from .geometry import wrap_angle
from .observation_log import ObservationLog
from .odometry_model import measured_odometry
from .route import RouteFollower
from .scenes import SceneLayout, observe_scenes
from .world import MAX_TICKS, World, load_world, max_bias_deg_s

WALL_THICKNESS = 0.02  # m (pymunk segment radius)


class Simulator:
    """Physics and route following for one world; produces the ground-truth trajectory."""

    def __init__(self, world: World, seed: int = 0):
        self.world = world
        self.rng = np.random.default_rng(seed)
        self.space = pymunk.Space()
        self.space.collision_slop = 0.002  # m of allowed overlap: walls are walls
        static = self.space.static_body
        for (x0, y0), (x1, y1) in world.walls:
            seg = pymunk.Segment(static, (x0, y0), (x1, y1), WALL_THICKNESS)
            seg.friction = 0.0
            self.space.add(seg)
        self.body = pymunk.Body(1.0, math.inf)  # infinite moment: contacts never spin the robot
        self.body.position = world.start[:2]
        self.body.angle = world.start[2]
        shape = pymunk.Circle(self.body, world.robot.radius)
        shape.friction = 0.0  # slide along walls rather than stick
        self.space.add(self.body, shape)
        self._command = (0.0, 0.0)
        self.body.velocity_func = self._apply_command
        self.route = RouteFollower(world, self.rng)

    def _apply_command(self, body: pymunk.Body, gravity, damping, dt):
        v, w = self._command
        # pymunk moves the body by this velocity on the next step while the heading turns by
        # w*dt: aim along the midpoint heading so the motion is a unicycle's (as odometry assumes).
        heading = body.angle + 0.5 * w * dt
        body.velocity = (v * math.cos(heading), v * math.sin(heading))
        body.angular_velocity = w

    def step_command(self, v_trans: float, v_rot: float) -> tuple[float, float, float]:
        """One physics tick under a commanded (v_trans m/s, v_rot rad/s) instead of the route
        follower's (closed-loop driving, see :mod:`worlds.drive`); returns the true pose after it."""
        self._command = (float(v_trans), float(v_rot))
        self.space.step(self.world.dt)
        x, y = self.body.position
        return float(x), float(y), float(self.body.angle)

    def run(self, n_ticks: int, progress: Callable[[int, int], None] | None = None) -> np.ndarray:
        """Drive ``n_ticks`` ticks; return ground-truth poses (n_ticks + 1, 3), row 0 the start."""
        dt = self.world.dt
        poses = np.empty((n_ticks + 1, 3))
        body, route, step = self.body, self.route, self.space.step
        x, y = body.position
        theta = body.angle
        poses[0] = x, y, theta
        report_every = max(1, n_ticks // 100)
        for k in range(1, n_ticks + 1):
            self._command = route.command(x, y, theta, dt)
            step(dt)
            x, y = body.position
            theta = body.angle
            poses[k] = x, y, theta
            if progress is not None and k % report_every == 0:
                progress(k, n_ticks)
        poses[:, 2] = wrap_angle(poses[:, 2])
        return poses


def odometry_from_poses(poses: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """True body-frame velocities over each tick between consecutive poses (midpoint heading)."""
    d = np.diff(poses, axis=0)
    dtheta = wrap_angle(d[:, 2])
    mid = poses[:-1, 2] + dtheta / 2
    v_trans = (d[:, 0] * np.cos(mid) + d[:, 1] * np.sin(mid)) / dt
    return v_trans, dtheta / dt


def simulate(
    world,
    duration: float | None = None,
    seed: int = 0,
    bias_deg_s: float | None = None,
    fp_rate: float | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> ObservationLog:
    """Simulate a run and return its observation log with ground-truth columns.

    ``world`` is a :class:`World`, a shipped world's name or a path to a world file. ``None``
    arguments take the world's defaults. One ``seed`` fixes the whole run (route choices,
    odometry noise, flicker, false positives); the scene layout is a property of the world.
    """
    world = load_world(world)
    duration = world.duration if duration is None else float(duration)
    bias = world.odometry.bias_deg_s if bias_deg_s is None else float(bias_deg_s)
    fp = world.scenes.false_positive_rate if fp_rate is None else float(fp_rate)
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration: must be a positive number of seconds, got {duration!r}")
    if duration * world.tick_rate > MAX_TICKS:
        raise InputError(f"duration: {duration:g} s at {world.tick_rate:g} Hz is more than {MAX_TICKS:.0e} ticks")
    if not math.isfinite(bias):
        raise ValueError(f"bias: must be a finite number of deg/s, got {bias!r}")
    if abs(bias) > max_bias_deg_s(world.tick_rate):
        raise InputError(
            f"bias: {bias:g} deg/s turns the heading more than half a turn per tick at {world.tick_rate:g} Hz "
            f"(at most {max_bias_deg_s(world.tick_rate):g} deg/s)"
        )
    if not (0.0 <= fp <= 1.0):
        raise ValueError(f"fp: false-positive rate must be in [0, 1], got {fp!r}")

    layout = SceneLayout(world)  # a world that cannot hold its aliasing fails before the drive
    dt = world.dt
    n = max(1, int(round(duration / dt)))
    sim = Simulator(world, seed)
    poses = sim.run(n, progress)

    # Noise, slip and scenes are drawn from their own streams so the route does not depend on them.
    noise_rng, scene_rng, slip_rng = (np.random.default_rng([seed, k]) for k in (1, 2, 3))
    v_true, w_true = odometry_from_poses(poses, dt)
    v_trans, v_rot = measured_odometry(
        v_true, w_true, world.odometry, dt, 2.0 * world.robot.radius, noise_rng, slip_rng, bias_deg_s=bias
    )

    gt = poses[1:]
    s = world.scenes
    scenes = observe_scenes(layout, gt[:, 0], gt[:, 1], gt[:, 2], scene_rng, s.flicker_width, s.flicker_prob, fp)
    t = dt * np.arange(1, n + 1)
    return ObservationLog(
        t=t,
        dt=np.full(n, dt),
        v_trans=v_trans,
        v_rot=v_rot,
        scene_id=scenes.scene_id,
        gt_x=gt[:, 0].copy(),
        gt_y=gt[:, 1].copy(),
        gt_theta=gt[:, 2].copy(),
        false_positive=scenes.false_positive,
    )
