"""The layers around the experience map, reached by the names they had on the map.

:class:`ratslam.experience_map.ExperienceMap` holds the paper's map only; the departures from
the paper are layers (:mod:`ratslam.entry_offset`, :mod:`ratslam.reentry_policy`,
:mod:`ratslam.yaw_bias_correction`). Code written against the map's earlier methods and
attributes reaches them through :class:`MapLayers`, which forwards each to its layer.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

import numpy as np

from . import yaw_bias_correction
from .columns import Growable
from .config import RatSLAMConfig
from .entry_offset import peak_offset
from .reentry import InnovationScale, PathNoise
from .reentry_policy import ReentryPolicy

if TYPE_CHECKING:
    from .experience_map import ExperienceMap


class MapLayers:
    """Forwarders from the map to its layers (module doc)."""

    config: RatSLAMConfig
    reentry: ReentryPolicy
    _exp: Growable

    # ------------------------------------------------------------------ offset transitions
    def peak_offset(self, j: int, peak_cell: np.ndarray) -> tuple[float, float, float]:
        """Where the pose-cell peak is relative to experience ``j``'s cells, in ``j``'s frame
        (:func:`ratslam.entry_offset.peak_offset`)."""
        return peak_offset(self._exp.cols["cell"][j], peak_cell, self.config)

    # ------------------------------------------------------------------ re-entry policy
    def fuse_reentry(self, j: int, offset):
        """The re-entry fusion's offset for re-entering ``j`` at ``offset``
        (:meth:`ratslam.reentry_policy.ReentryPolicy.fuse`)."""
        return self.reentry.fuse(j, offset)

    def prediction_covariance(self, nu: np.ndarray, since_visit: np.ndarray, heading: float) -> np.ndarray:
        """:meth:`ratslam.reentry_policy.ReentryFusion.prediction_covariance`."""
        return self.reentry.fusion.prediction_covariance(nu, since_visit, heading)

    @property
    def _noise(self) -> PathNoise:
        return self.reentry.odometry

    @property
    def _view_cov(self) -> np.ndarray:
        return self.reentry.fusion.view_cov

    @property
    def _innovations(self) -> InnovationScale:
        return self.reentry.fusion.innovations

    @_innovations.setter
    def _innovations(self, value: InnovationScale) -> None:
        self.reentry.fusion.innovations = value

    @property
    def _gate_scale(self) -> InnovationScale:
        return self.reentry.gate.scale

    @property
    def _gate_view(self) -> int:
        return self.reentry.gate.view

    @property
    def _fix(self) -> np.ndarray:
        return self.reentry.fusion.fix

    @_fix.setter
    def _fix(self, value: np.ndarray) -> None:
        self.reentry.fusion.fix = value

    @property
    def _path_since_reentry(self) -> float:
        return self.reentry.path_bound.path_m

    @_path_since_reentry.setter
    def _path_since_reentry(self, value: float) -> None:
        self.reentry.path_bound.path_m = value

    # ------------------------------------------------------------------ yaw-rate bias
    def remove_yaw_bias(self, change: float, settle: bool = True) -> None:
        """:func:`ratslam.yaw_bias_correction.remove_yaw_bias` on this map."""
        yaw_bias_correction.remove_yaw_bias(cast("ExperienceMap", self), change, settle)

    def settle(self, heading_passes: int = 3) -> None:
        """:func:`ratslam.yaw_bias_correction.settle` on this map."""
        yaw_bias_correction.settle(cast("ExperienceMap", self), heading_passes)
