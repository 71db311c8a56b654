"""Conditions of a stream, applied in one place: the sweeps' axes and the figure variants' stream
fields (the same names) change a world, its odometry, its camera or a real log's place labels here.

A condition is a mapping of names to values; a name it lacks keeps the world's (or scene model's)
own value. ``cell_size``, ``alias_rate``, ``blank_rate``, ``fp_rate``: the place labels
(:func:`condition_scenes`); ``odometric_bias``, ``odometry_noise_scale``, ``wheel_errors``: the
odometry (:func:`condition_odometry`); ``lighting_amplitude``, ``image_noise``: the camera
(:func:`condition_camera`); ``lookalikes``: whether the world's look-alike regions look alike
(:func:`condition_world`). RatSLAM's path-integration bias (``pi_bias``) is not a condition of the
stream but a RatSLAM configuration field (``pose_cells.path_integration_bias_deg_s``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

from worlds import World
from worlds.odometry_model import PLAZA_WHEEL_ERRORS
from worlds.world import CameraSpec, OdometrySpec, SceneSpec

Condition = Mapping[str, Any]


def condition_scenes(scenes: SceneSpec, condition: Condition) -> SceneSpec:
    """The scene model with the condition's place-label values (cell size, aliasing, blank cells,
    false positives)."""
    return dataclasses.replace(
        scenes,
        cell_size=condition.get("cell_size", scenes.cell_size),
        alias_rate=condition.get("alias_rate", scenes.alias_rate),
        blank_rate=condition.get("blank_rate", scenes.blank_rate),
        false_positive_rate=condition.get("fp_rate", scenes.false_positive_rate),
    )


def condition_odometry(odometry: OdometrySpec, condition: Condition) -> OdometrySpec:
    """The simulated odometry with the condition's yaw-rate bias, noise factor and (if
    ``wheel_errors``) the systematic wheel-odometry errors calibrated on the CMU Plaza vehicle."""
    scale = condition.get("odometry_noise_scale", 1.0)
    odometry = dataclasses.replace(
        odometry,
        bias_deg_s=condition.get("odometric_bias", odometry.bias_deg_s),
        noise_trans=odometry.noise_trans * scale,
        noise_rot=odometry.noise_rot * scale,
    )
    if condition.get("wheel_errors", False):
        odometry = dataclasses.replace(odometry, **PLAZA_WHEEL_ERRORS)
    return odometry


def condition_camera(camera: CameraSpec, condition: Condition) -> CameraSpec:
    """The camera with the condition's lighting change and sensor noise."""
    return dataclasses.replace(
        camera,
        lighting_amplitude=condition.get("lighting_amplitude", camera.lighting_amplitude),
        noise=condition.get("image_noise", camera.noise),
    )


def condition_world(world: World, condition: Condition) -> World:
    """``world`` under ``condition`` (scenes, odometry, camera); ``lookalikes`` false gives the
    world's look-alike regions their own scenes and, to the camera, their own walls."""
    scenes = condition_scenes(world.scenes, condition)
    camera = condition_camera(world.camera, condition)
    if not bool(condition.get("lookalikes", True)):
        scenes = dataclasses.replace(scenes, lookalikes=())
        if camera.same_as:
            camera = dataclasses.replace(camera, same_as=())
    odometry = condition_odometry(world.odometry, condition)
    return dataclasses.replace(world, scenes=scenes, odometry=odometry, camera=camera)
