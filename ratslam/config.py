"""Configuration of the RatSLAM pipeline: small frozen sub-configs with documented defaults.

``RatSLAMConfig(pose_cells=PoseCellConfig(...), local_view=LocalViewConfig(...),
experience_map=ExperienceMapConfig(...), reentry=ReentryFusionConfig(...),
yaw_bias=YawBiasConfig(...), view=ViewConfig(...))``; every field is
checked by :func:`slamkit.config_fields.check_fields`. Units: pose-cell quantities are in cell
units (x', y' cells of ``cell_size_m``, θ' cells of ``360 / n_theta`` degrees); map quantities
are in metres and radians; rates per second. Why each default is what it is (the measured
trade-offs) is in ``docs/configuration.md``, one section per sub-config.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar, Literal

from slamkit.config_fields import ConfigError, check_fields, param, replace
from slamkit.yaw_bias import YawBiasSearchConfig

from .published import published_changes

Energy = Literal["sum", "product"]
Correction = Literal["stable", "printed"]


@dataclass(frozen=True)
class PoseCellConfig:
    """Pose cells: a competitive attractor network wrapping on every axis
    (docs/configuration.md#ratslam-pose-cells)."""

    SECTION: ClassVar[str] = "pose_cells"

    nx: int = param(60, ge=4)
    """Grid size along x' (cells); 60 cells of 0.25 m wrap every 15 m. See the docs section."""
    ny: int = param(60, ge=4)
    """Grid size along y' (cells)."""
    n_theta: int = param(36, ge=4)
    """Heading cells (36 of 10 degrees)."""
    cell_size_m: float = param(0.25, gt=0)
    """Side of an (x', y') cell (the paper's indoor 0.25 m)."""
    excite_sigma_cells: float = param(1.0, gt=0)
    """Width of the Gaussian local excitation in (x', y')."""
    excite_sigma_theta_cells: float = param(0.6, gt=0)
    """Width of the local excitation in θ'."""
    excite_radius_cells: int = param(2, ge=0)
    """Truncation radius of the excitation kernel."""
    inhibit_sigma_cells: float = param(2.0, gt=0)
    """Width of the wider Gaussian local inhibition in (x', y')."""
    inhibit_sigma_theta_cells: float = param(1.0, gt=0)
    """Width of the local inhibition in θ'."""
    inhibit_radius_cells: int = param(3, ge=0)
    """Truncation radius of the inhibition kernel."""
    inhibit_weight: float = param(0.5, ge=0)
    """Weight of the inhibition-blurred activity subtracted after excitation."""
    global_inhibition: float = param(3e-5, ge=0)
    """Constant subtracted from every cell (then clipped at zero). See the docs section."""
    peak_radius_cells: int = param(3, ge=0)
    """Half-width of the neighbourhood whose weighted circular mean refines the peak."""
    trans_gain: float = param(1.05, gt=0)
    """Gain on the translation fed to path integration (lattice-lag compensation). See the docs section."""
    path_integration_bias_deg_s: float = param(0.0)
    """Constant added to the yaw rate of the pose cells' path integration only (Figs 8-10); 0 = off."""
    snap_threshold_cells: float = param(3.0, gt=0)
    """A tick whose peak moves further than this (wrap-aware) is reported as a snap."""

    def __post_init__(self) -> None:
        check_fields(self)
        widest = max(self.excite_radius_cells, self.inhibit_radius_cells, self.peak_radius_cells)
        if 2 * widest + 1 > min(self.nx, self.ny, self.n_theta):
            raise ConfigError(
                "pose_cells.excite_radius_cells/inhibit_radius_cells/peak_radius_cells",
                f"kernel wider than the grid ({2 * widest + 1} cells > {min(self.nx, self.ny, self.n_theta)})",
            )

    @property
    def theta_cell_rad(self) -> float:
        """Size of one heading cell in radians."""
        return 2.0 * math.pi / self.n_theta

    @property
    def shape(self) -> tuple[int, int, int]:
        """Pose-cell grid shape (nx, ny, n_theta)."""
        return (self.nx, self.ny, self.n_theta)


@dataclass(frozen=True)
class LocalViewConfig:
    """Local view cells: one per scene number, -1 has none
    (docs/configuration.md#ratslam-local-view-cells)."""

    SECTION: ClassVar[str] = "local_view"

    learn_rate: float = param(1.0, gt=0)
    """Hebbian rate λ: association β <- max(β, λ · V · P) with the active cells."""
    inject: float = param(0.1, ge=0)
    """Injection strength δ: a familiar view adds δ · V · β to the pose cells."""
    learn_threshold: float = param(0.1, ge=0, lt=1)
    """Pose cells weaker than this fraction of the packet maximum are not associated."""
    fatigue_rate: float = param(0.1, gt=0)
    """Fatigue added on each tick the scene is in view (habituation). See the docs section."""
    fatigue_recovery: float = param(0.05, ge=0)
    """Fatigue recovered on every other tick."""
    min_age_ticks: int = param(70, ge=1)
    """Associations younger than this never inject."""

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class ExperienceMapConfig:
    """Experience map, paper eqs 2-14 (docs/configuration.md#ratslam-experience-map)."""

    SECTION: ClassVar[str] = "experience_map"

    view_confirm_ticks: int = param(2, ge=1)
    """Consecutive ticks a scene must be reported before the map acts on it (1 = the paper). See the docs."""
    snap_settle_ticks: int = param(50, ge=0)
    """Ticks after a snap during which the map neither switches nor creates (0 = the paper). See the docs."""
    offset_transitions: bool = True
    """Transitions measured to the re-entered experience's own place (False = the paper's). See the docs."""
    r_inf_cells: float = param(2.0, gt=0)
    """Zone of influence radius in (x', y') cells (eqs 2-3)."""
    theta_inf_cells: float = param(2.0, gt=0)
    """Zone of influence in θ' cells (eqs 4-5)."""
    energy: Energy = "product"
    """Energy form: "sum" = paper eq 9, "product" = the stricter E_V E_xy E_θ. See the docs section."""
    alpha_theta: float = param(0.5, ge=0, le=1)
    """Heading correction rate of eqs 12-14 (paper Table 1: 0.5)."""
    alpha_d: float = param(0.5, ge=0, le=1)
    """Position correction rate of eqs 12-14 (paper Table 1: 0.5)."""
    correction: Correction = "stable"
    """Correction form: "stable" = α times the mean residual, "printed" = eqs 12-14 (diverges). See the docs."""
    correction_iterations: int = param(1, ge=0)
    """Correction passes per tick (the paper runs one)."""
    relocalise_path_bound: bool = True
    """No re-entry into a place further from the predicted pose than the path driven since the
    latest re-entry (False = the paper's: wherever the pose cells say). See the docs section."""
    relocalise_slack_cells: float = param(4.0, ge=0)
    """Slack of that bound, in (x', y') cells (1 m at 0.25 m cells): a view places the robot only
    to within about its scene."""
    loop_closure_sequence: bool = True
    """A re-entry the map's links do not already lead to (a new loop closure) waits until the next
    scene's re-entry agrees with it, as a sequence (False = the paper's: one view). See the docs."""
    odometry_gate_chi2: float = param(100.0, gt=0, finite=False)
    """No re-entry whose innovation lies beyond this squared Mahalanobis distance of the odometry's
    prediction since the robot was last at the place, its noise scaled as the re-entries of the
    odometry have shown, refused ones included (inf = no gate). Needs the re-entry fusion and acts
    only while the odometry is trusted (``reentry.odometry_trust_limit``). A re-entry taken with an
    innovation beyond it (before the gate acts) is not fused: the pose cells' pose. See the docs
    section."""

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class ReentryFusionConfig:
    """Re-entry fusion: not in the paper, on by default (both sigmas 0 = the paper's re-entries);
    see :mod:`ratslam.reentry` and docs/configuration.md#ratslam-re-entry-fusion."""

    SECTION: ClassVar[str] = "reentry"

    position_sigma_m: float = param(0.25, ge=0)
    """1-sigma per axis of where a re-entry places the robot (one pose cell); 0 (with heading 0) = off."""
    heading_sigma_deg: float = param(5.0, ge=0)
    """1-sigma in heading of a re-entry; 0 (with position 0) = off."""
    odom_speed_noise_m_s: float = param(0.01, ge=0)
    """White noise on the odometry's speed per tick, for the prediction's covariance."""
    odom_heading_noise_rad_s: float = param(0.01, ge=0)
    """White noise on the odometry's yaw rate per tick, for the prediction's covariance."""
    innovation_window: int = param(15, ge=0)
    """Re-entries whose innovations scale the odometry's noise up where it errs more (0 = off)."""
    odometry_trust_limit: float = param(2.0, ge=1, finite=False)
    """Noise scale beyond which re-entries ignore the odometry (a bias the model lacks; inf = never)."""
    chain_fixes: bool = False
    """The prediction's covariance may come from the latest re-entry's fused one, carried by the
    odometry (a filter on a known map), where the innovation is likelier under it than under the
    odometry's since the robot was last at the place. On for navigation and in configurations derived
    for a vehicle's log (harness/run/scale.py), off for mapping the simulator's streams."""

    def __post_init__(self) -> None:
        check_fields(self)
        if (self.position_sigma_m > 0) != (self.heading_sigma_deg > 0):
            raise ConfigError(
                "reentry.position_sigma_m/heading_sigma_deg",
                f"both 0 (off) or both positive, got {self.position_sigma_m!r} and {self.heading_sigma_deg!r}",
            )

    @property
    def enabled(self) -> bool:
        """Whether the fusion is on (both sigmas positive)."""
        return self.position_sigma_m > 0.0


@dataclass(frozen=True)
class YawBiasConfig(YawBiasSearchConfig):
    """A constant yaw-rate (gyro) bias in the odometry, searched from revisited scene numbers and
    taken off: not in the paper, on by default (the search's fields and the search itself are the
    pose graph's too, :mod:`slamkit.yaw_bias`; docs/configuration.md#ratslam-yaw-rate-bias).
    ``search`` on: once a bias is adopted, the transitions and the yaw rate fed on are corrected."""

    revisit_min_travel_m: float = param(4.0, ge=0)
    """Path between two sightings of a scene for them to score a revisit."""
    revisit_sigma_xy_m: float = param(1.0 / math.sqrt(6.0), gt=0)
    """How well a scene places the robot (per axis; uniform over a 1 m scene cell)."""
    revisit_sigma_heading_deg: float = param(90.0 / math.sqrt(6.0), gt=0)
    """How well a scene gives the heading (one 90 deg sector)."""
    settle_turn_deg: float = param(0.0, ge=0, finite=False)
    """An adopted bias change that turns the map by more than this over the time it spans has the
    map correction solved to its fixed point at once (below it the per-tick correction carries
    the corrected transitions; inf: never). See the docs section."""
    rebuild: bool = True
    """An adopted bias rebuilds the system from the first tick: the pose cells, view cells and
    experience map stepped again through the ticks so far with the bias taken off (the pose
    graph rebuilds its graph alike). Off: the map built so far is corrected
    (``settle_turn_deg``), while the pose cells and view cells keep the places where the biased
    odometry laid them. See the docs section."""


@dataclass(frozen=True)
class ViewConfig:
    """The view-template matcher (:mod:`ratslam.view_matcher`): camera images to template numbers
    and relative rotations. Used only when a stream carries images; a stream of scene numbers never
    reads it (docs/camera.md)."""

    SECTION: ClassVar[str] = "view"

    crop_top: int = param(0, ge=0)
    """Image rows removed at the top before downsampling."""
    crop_bottom: int = param(0, ge=0)
    """Image rows removed at the bottom."""
    crop_left: int = param(0, ge=0)
    """Image columns removed on the left (a forward camera only: a panoramic image wraps)."""
    crop_right: int = param(0, ge=0)
    """Image columns removed on the right (a forward camera only)."""
    template_width: int = param(32, ge=2)
    """Columns of a template (the cropped image is averaged down to it)."""
    template_height: int = param(8, ge=1)
    """Rows of a template."""
    field_of_view_deg: float = param(50.0, gt=0, le=360)
    """Horizontal field of view of the cropped image; 360 = panoramic (shifts wrap). The paper's
    camera: 50 degrees."""
    max_shift_deg: float = param(20.0, ge=0)
    """Largest rotation searched either way (forward camera; a panoramic one searches all shifts)."""
    match_threshold: float = param(0.04, gt=0)
    """A view whose least mean absolute difference to a stored template (over the shifts) is below
    this is that template; otherwise it becomes a new one. See docs/camera.md."""
    global_normalisation: bool = False
    """Scale each template to mean intensity 0.5 (undoes a global lighting gain)."""
    patch_normalisation_radius: int = param(0, ge=0)
    """Each pixel as its z-score in the (2r+1)^2 patch around it, mapped to [0, 1] (0 = off)."""
    mean_prefilter: bool = True
    """Skip a template at a shift where the mean intensities of the overlapping parts (upper and
    lower halves) differ by the threshold or more: an exact lower bound of the difference, one
    subtraction per shift (per template for a panoramic camera). Off only to measure it."""

    def __post_init__(self) -> None:
        check_fields(self)

    @property
    def panoramic(self) -> bool:
        """Whether the image covers the whole circle (shifts wrap around)."""
        return self.field_of_view_deg >= 360.0


@dataclass(frozen=True)
class RatSLAMConfig:
    """All RatSLAM parameters, with the defaults used for the paper's figures (see the sub-configs
    and ``docs/configuration.md``)."""

    pose_cells: PoseCellConfig = field(default_factory=PoseCellConfig)
    local_view: LocalViewConfig = field(default_factory=LocalViewConfig)
    experience_map: ExperienceMapConfig = field(default_factory=ExperienceMapConfig)
    reentry: ReentryFusionConfig = field(default_factory=ReentryFusionConfig)
    yaw_bias: YawBiasConfig = field(default_factory=YawBiasConfig)
    view: ViewConfig = field(default_factory=ViewConfig)

    def __post_init__(self) -> None:
        check_fields(self)

    @property
    def shape(self) -> tuple[int, int, int]:
        """Pose-cell grid shape (nx, ny, n_theta)."""
        return self.pose_cells.shape

    @classmethod
    def published(cls, base: RatSLAMConfig | None = None) -> RatSLAMConfig:
        """RatSLAM as published: every field at the paper's value or, where the paper is silent
        or its printed form cannot run, at the stated reading (:data:`ratslam.published.PUBLISHED`).
        The fields that size the network for a robot and environment (grid, cell size) and a
        figure's path-integration bias are kept from ``base`` (default: the defaults)."""
        return (base if base is not None else cls()).replace(**published_changes())

    def replace(self, **changes: Any) -> RatSLAMConfig:
        """A copy with some sub-configs changed (validated); a sub-config may be given whole or as
        a mapping of its changes: ``cfg.replace(experience_map={"energy": "sum"})``."""
        return replace(self, changes)
