"""Simulated worlds: world files, the pymunk simulator, the scene model and the observation log;
:mod:`worlds.files` reads and writes files (atomically) for this package and the harness."""

from .errors import InputError
from .observation_log import ObservationLog, ObservationLogError
from .scenes import SceneLayout
from .simulator import Simulator, simulate
from .world import World, WorldFileError, list_worlds, load_world

__all__ = [
    "InputError",
    "ObservationLog",
    "ObservationLogError",
    "SceneLayout",
    "Simulator",
    "World",
    "WorldFileError",
    "list_worlds",
    "load_world",
    "simulate",
]
