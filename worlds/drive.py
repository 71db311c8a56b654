"""Closed-loop driving: step the simulator's robot with commanded velocities, one tick at a time.

:func:`worlds.simulate` drives the route network open loop and turns the whole trajectory into an
observation stream at once. A navigating robot chooses each command from what its SLAM made of
the previous observations, so :class:`Drive` produces the same observation tick by tick: the same
pymunk body among the same walls (walls still block), wheel odometry as the body's true motion
over the tick plus the world's bias and noise, and the scene number from the world's scene layout
with its flicker and false positives. The true pose is kept for metrics only; the observation
itself carries none of it.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from .scenes import NO_SCENE, SceneLayout, observe_scenes
from .simulator import Simulator, odometry_from_poses
from .world import World, load_world


class Observation(NamedTuple):
    """One tick as the SLAM sees it (the observation log's columns): seconds, m/s, rad/s, scene."""

    dt: float
    v_trans: float
    v_rot: float
    scene_id: int


class Drive:
    """The robot of ``world`` placed at ``pose`` (x, y, θ), driven by :meth:`step`.

    ``seen_scenes``: scene numbers already seen before (e.g. an exploration log's), in order of
    first sighting; false positives report one of the numbers seen so far, as in
    :func:`worlds.simulate`. ``bias_deg_s``/``fp_rate`` default to the world's. ``seed`` fixes
    the odometry noise, flicker and false positives.
    """

    def __init__(
        self,
        world: World | str,
        pose=None,
        seed: int = 0,
        *,
        seen_scenes=(),
        bias_deg_s: float | None = None,
        fp_rate: float | None = None,
        layout: SceneLayout | None = None,
    ):
        world = load_world(world)
        if pose is not None:
            world = dataclasses.replace(world, start=(float(pose[0]), float(pose[1]), float(pose[2])))
        self.world = world
        self._sim = Simulator(world, seed)
        self._layout = layout if layout is not None else SceneLayout(world)
        self._noise_rng, self._scene_rng = (np.random.default_rng([seed, k]) for k in (3, 4))
        self._bias = math.radians(world.odometry.bias_deg_s if bias_deg_s is None else float(bias_deg_s))
        self._fp_rate = world.scenes.false_positive_rate if fp_rate is None else float(fp_rate)
        self._seen: list[int] = []
        self._seen_set: set[int] = set()
        for s in seen_scenes:
            self._remember(int(s))
        x, y = self._sim.body.position
        self._pose = (float(x), float(y), float(self._sim.body.angle))
        self._false_positive = False
        self.ticks = 0

    def _remember(self, scene: int) -> None:
        if scene != NO_SCENE and scene not in self._seen_set:
            self._seen_set.add(scene)
            self._seen.append(scene)

    def step(self, v_trans: float, v_rot: float) -> Observation:
        """Command (v_trans m/s, v_rot rad/s) for one tick; returns that tick's observation."""
        w = self.world
        dt = w.dt
        before = self._pose
        after = self._sim.step_command(v_trans, v_rot)
        self._pose = after
        v_true, w_true = odometry_from_poses(np.array([before, after]), dt)
        odo = w.odometry
        v = float(v_true[0]) + float(self._noise_rng.normal(0.0, odo.noise_trans))
        wr = float(w_true[0]) + self._bias + float(self._noise_rng.normal(0.0, odo.noise_rot))
        self.ticks += 1
        return Observation(dt, v, wr, self._scene(after))

    def _scene(self, pose) -> int:
        s = self.world.scenes
        rng = self._scene_rng
        obs = observe_scenes(self._layout, [pose[0]], [pose[1]], [pose[2]], rng, s.flicker_width, s.flicker_prob, 0.0)
        scene = int(obs.scene_id[0])
        self._false_positive = False
        if self._fp_rate > 0.0 and rng.random() < self._fp_rate:
            own = int(self._layout.numbers[obs.true_cell[0]])
            candidates = [n for n in self._seen if n != own]
            if candidates:
                scene = candidates[int(rng.random() * len(candidates))]
                self._false_positive = True
        self._remember(scene)
        return scene

    # ------------------------------------------------------------------ ground truth (metrics only)
    @property
    def true_pose(self) -> tuple[float, float, float]:
        """The robot's true (x, y, θ), θ wrapped to [-π, π). For metrics only, never for control."""
        x, y, th = self._pose
        return x, y, (th + math.pi) % (2.0 * math.pi) - math.pi

    @property
    def false_positive(self) -> bool:
        """Whether the latest observation's scene number was a false positive (ground truth)."""
        return self._false_positive
