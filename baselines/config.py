"""Configuration of the GTSAM Pose2 pose-graph baseline: small frozen sub-configs.

``PoseGraphConfig(keyframes=..., odometry=..., closures=..., backend=..., optimisation=...,
yaw_bias=...)``. The numbers that come from the simulated robot (odometry noise, scene-cell
size, heading sectors) are the simulator's world defaults (7 Hz ticks, 0.3 m/s,
1 m x 1 m x 90 deg scene cells). Why each default is what it is (the measured trade-offs) is in
``docs/configuration.md``, one section per sub-config.

Fields are checked by the validator RatSLAM's configuration uses too, :mod:`slamkit.config_fields`
(``baselines/`` imports nothing from ``ratslam/``).
"""

from __future__ import annotations

import math
import typing
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

from slamkit.config_fields import ConfigError, Renamed, check_fields, param, replace
from slamkit.yaw_bias import YawBiasSearchConfig

Backend = Literal["gaussian", "robust", "gnc"]
Estimator = Literal["cauchy", "huber", "dcs", "geman_mcclure"]
GncLoss = Literal["tls", "gm"]
BACKENDS: tuple[str, ...] = typing.get_args(Backend)
ESTIMATORS: tuple[str, ...] = typing.get_args(Estimator)
GNC_LOSSES: tuple[str, ...] = typing.get_args(GncLoss)

# Kernel width (in whitened residual units, i.e. Mahalanobis distance) used when
# ``estimator_k`` is left at None.  Cauchy and Huber take the usual 95%-efficiency
# constants; DCS takes Agarwal et al.'s recommended Phi = 1; Geman-McClure is
# given k = 3 so that an inlier at about 3 sigma still keeps about half its weight.
DEFAULT_ESTIMATOR_K = {
    "cauchy": 2.3849,
    "huber": 1.345,
    "dcs": 1.0,
    "geman_mcclure": 3.0,
}


@dataclass(frozen=True)
class KeyframeConfig:
    """When a keyframe is taken (docs/configuration.md#pose-graph-keyframes)."""

    SECTION: ClassVar[str] = "keyframes"

    distance_m: float = param(0.5, gt=0)
    """Travel (path length of the integrated odometry) since the last keyframe that takes a new one."""
    angle_rad: float = param(math.radians(30.0), gt=0)
    """... or turn since the last keyframe (30 deg)."""
    on_scene_change: bool = True
    """Also take a keyframe when a new scene number begins. See the docs section."""
    min_distance_m: float = param(0.1, ge=0)
    """Minimum travel for a scene-change keyframe."""

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class OdometryNoiseConfig:
    """Odometry noise and the prior on the first keyframe (docs/configuration.md#pose-graph-odometry-noise)."""

    SECTION: ClassVar[str] = "odometry"

    sigma_v_m_s: float = param(0.01, gt=0)
    """Per-tick noise on the measured forward speed (the simulator's 0.01 m/s)."""
    sigma_w_rad_s: float = param(0.01, gt=0)
    """Per-tick noise on the measured yaw rate (the simulator's 0.01 rad/s)."""
    sigma_lateral_m_s: float = param(0.001, gt=0)
    """Per-tick noise on a sideways velocity the robot cannot have (a positive-definite floor)."""
    prior_sigma_xy_m: float = param(1e-3, gt=0)
    """Prior on the first keyframe's position (fixes the map frame)."""
    prior_sigma_theta_rad: float = param(1e-3, gt=0)
    """Prior on the first keyframe's heading."""

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class LoopClosureConfig:
    """Loop closures from matching scene numbers (docs/configuration.md#pose-graph-loop-closures)."""

    SECTION: ClassVar[str] = "closures"

    sigma_xy_m: float = param(1.0 / math.sqrt(6.0), gt=0)
    """What a matching scene number tells about position: one 1 m scene cell, 1 m / sqrt(6)."""
    sigma_theta_rad: float = param((math.pi / 2.0) / math.sqrt(6.0), gt=0)
    """... and about heading: one 90 deg sector, (pi/2) / sqrt(6)."""
    min_travel_m: float = param(4.0, ge=0)
    """Earlier keyframes less than this path length back are the same visit: never candidates."""
    max_candidates: int = param(1, ge=1)
    """How many earlier sightings of the same scene number a new keyframe is linked to."""
    candidate_window: int = param(12, ge=1)
    """Only the most recent this-many sightings of a scene number are ranked. See the docs section."""
    recent_tolerance_m: float = param(0.0, ge=0)
    """If positive, link the most recent of the sightings this near the nearest. See the docs section."""
    early_tolerance_m: float = param(0.0, ge=0)
    """If positive, link the earliest of the sightings this near the nearest. See the docs section."""
    chain_correlation: float = param(0.0, ge=0, le=1)
    """Share of a closure's variance common to its chain (consecutive closures between the same two
    passages, :class:`~baselines.closures.ClosureChains`); 0: closures independent. See the docs section."""
    chain_gap_keyframes: int = param(3, ge=1)
    """Keyframes a chain may skip on either passage and still continue (``chain_correlation`` > 0)."""
    batch_keyframes: int | None = param(None, ge=1)
    """Closures handed to iSAM2 at most every this-many keyframes (None: 8, or 4 with the yaw bias)."""
    flush_distance: float = param(1.0, gt=0, finite=False)
    """A closure whose residual's Mahalanobis distance exceeds this is added at once (inf: never)."""

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class BackendConfig:
    """How closures are trusted: least squares, robust kernel or GNC
    (docs/configuration.md#pose-graph-back-end)."""

    SECTION: ClassVar[str] = "backend"

    kind: Backend = "robust"
    """Back-end: "gaussian" (every closure trusted), "robust" (M-estimator) or "gnc". See the docs."""
    estimator: Estimator = "geman_mcclure"
    """Kernel of the robust back-end. See the docs section."""
    estimator_k: float | None = param(None, gt=0)
    """Kernel width in Mahalanobis units; None = ``DEFAULT_ESTIMATOR_K``."""
    accept_weight: float = param(0.5, gt=0, le=1)
    """A closure counts as accepted (inlier) if its weight at the solution is at least this."""
    gnc_loss: GncLoss = "tls"
    """GNC surrogate: "tls" (truncated least squares) or "gm" (Geman-McClure)."""
    gnc_inlier_probability: float = param(0.99, gt=0, lt=1)
    """Chi-square probability that sets GNC's inlier threshold per closure."""
    gnc_interval_keyframes: int = param(50, ge=1)
    """Online GNC: re-run the inlier selection every this many keyframes. See the docs section."""

    def __post_init__(self) -> None:
        check_fields(self)

    @property
    def kernel_width(self) -> float:
        """Robust kernel width actually used (``estimator_k`` or the estimator's default)."""
        return DEFAULT_ESTIMATOR_K[self.estimator] if self.estimator_k is None else float(self.estimator_k)


@dataclass(frozen=True)
class OptimisationConfig:
    """Incremental (iSAM2) and batch optimisation (docs/configuration.md#pose-graph-optimisation)."""

    SECTION: ClassVar[str] = "optimisation"

    online: bool = True
    """Optimise incrementally with iSAM2 after every keyframe (False: only at ``finalize``)."""
    final_batch: bool = False
    """``finalize()`` runs a batch LM (or GNC) optimisation of the whole graph."""
    isam2_relinearize_threshold: float = param(0.1, ge=0)
    """iSAM2's relinearisation threshold on the tangent-space delta (gtsam's default)."""
    isam2_relinearize_skip: int | None = param(None, ge=1)
    """Updates between relinearisation checks (None: 10, or 1 with the yaw bias). See the docs."""
    isam2_extra_updates: int = param(0, ge=0)
    """Extra iSAM2 iterations right after a keyframe that added loop closures."""
    batch_max_iterations: int = param(100, ge=1)
    """Iteration cap of the batch LM / GNC inner optimiser."""
    odometry_batch_keyframes: int = param(8, ge=1)
    """Keyframes bringing only odometry wait for the next update, at most this many. See the docs."""

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class YawBiasConfig(YawBiasSearchConfig):
    """A constant yaw-rate (gyro) bias: searched from revisits by default (the search's fields,
    in deg/s, and the search itself are RatSLAM's too, :mod:`slamkit.yaw_bias`; revisits are
    scored with the closures' travel and sigmas), or a graph variable (``estimate``, then
    ``search`` is ignored) (docs/configuration.md#pose-graph-yaw-rate-bias)."""

    RENAMED: ClassVar[dict[str, Renamed]] = {
        "search_max_rad_s": Renamed("search_max_deg_s", "deg/s", math.degrees),
        "search_step_rad_s": Renamed("search_step_deg_s", "deg/s", math.degrees),
    }

    estimate: bool = False
    """Add one constant yaw-rate bias variable to the graph (not with the "gnc" back-end). See the docs."""
    prior_sigma_rad_s: float = param(0.2, gt=0)
    """Zero-mean prior on the bias (0.2 rad/s ~ 11 deg/s)."""
    isam2_relinearize_threshold_rad_s: float = param(1e-4, ge=0)
    """iSAM2 relinearisation threshold of the bias; far below the poses'. See the docs section."""


@dataclass(frozen=True)
class PoseGraphConfig:
    """Parameters of :class:`baselines.PoseGraphSLAM`.

    The default is what a practitioner picks for aliased, false-positive-prone place labels:
    online (iSAM2) optimisation with a robust (Geman-McClure) loop-closure kernel, no batch pass
    at the end, a yaw-rate bias searched from revisits (see the sub-configs and ``docs/configuration.md``).
    """

    keyframes: KeyframeConfig = field(default_factory=KeyframeConfig)
    odometry: OdometryNoiseConfig = field(default_factory=OdometryNoiseConfig)
    closures: LoopClosureConfig = field(default_factory=LoopClosureConfig)
    backend: BackendConfig = field(default_factory=BackendConfig)
    optimisation: OptimisationConfig = field(default_factory=OptimisationConfig)
    yaw_bias: YawBiasConfig = field(default_factory=YawBiasConfig)

    def __post_init__(self) -> None:
        check_fields(self)
        if self.yaw_bias.estimate and self.backend.kind == "gnc":
            raise ConfigError(
                "yaw_bias.estimate",
                "not available with backend.kind 'gnc' (gtsam's GNC clones every factor "
                "and the Python CustomFactor carrying the bias cannot be cloned)",
            )

    @property
    def closure_batch(self) -> int:
        """Closure batch size actually used (see ``closures.batch_keyframes``)."""
        if self.closures.batch_keyframes is not None:
            return self.closures.batch_keyframes
        return 4 if self.yaw_bias.estimate else 8

    @property
    def relinearize_skip(self) -> int:
        """iSAM2 relinearisation interval actually used (see ``optimisation.isam2_relinearize_skip``)."""
        if self.optimisation.isam2_relinearize_skip is not None:
            return self.optimisation.isam2_relinearize_skip
        return 1 if self.yaw_bias.estimate else 10

    def replace(self, **changes: Any) -> PoseGraphConfig:
        """A copy with some sub-configs changed (validated); a sub-config may be given whole or as
        a mapping of its changes: ``cfg.replace(backend={"kind": "gnc"})``."""
        return replace(self, changes)
