"""RatSLAM as published: every configuration field at the paper's value, and where each comes from.

The project's defaults (``RatSLAMConfig()``) depart from the paper where measurement showed the
paper's algorithm failing here (docs/fidelity.md). ``RatSLAMConfig.published()`` gives the
paper's algorithm instead: :data:`PUBLISHED` holds, for every field of :class:`RatSLAMConfig`,
the preset's value and its source -- Table 1, an equation or the text of the paper, or, where the
paper is silent or its printed form cannot run, the reading chosen here, stated in one line.

Fields whose source is :data:`SCALE` set the size of the network for a robot and an environment
(grid, cell size); the preset leaves them as they are in the configuration it is applied to, so
that a figure's grid or the scale derived from a user's log carries over. Every other field is
fixed by the preset.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from slamkit.config_fields import subconfigs

if TYPE_CHECKING:
    from .config import RatSLAMConfig

TABLE_1 = "paper, Table 1"
TEXT = "paper, text"
SILENT = "paper silent: our reading"
SCALE = "scale: kept from the configuration the preset is applied to"
DEPARTURE = "not in the paper: off"


@dataclass(frozen=True)
class Reading:
    """The published preset's value of one field and where it comes from (``source``: one of
    the sources above, with ``note`` saying which equation or what was read)."""

    value: Any
    source: str
    note: str
    inert: bool = False  # a field the published algorithm never reads (a switched-off departure's)


_KEEP = object()  # a SCALE field: no value of its own


def _scale(note: str) -> Reading:
    return Reading(_KEEP, SCALE, note)


def _inert(value: Any, what: str = "") -> Reading:
    """A field of a departure the published algorithm switches off: the default kept, never read."""
    return Reading(value, DEPARTURE, (what + " " if what else "") + "(unused with it off)", inert=True)


PUBLISHED: dict[str, Reading] = {
    # --- pose cells
    "pose_cells.nx": _scale("grid size; the paper's grid wraps, its size is set per environment"),
    "pose_cells.ny": _scale("grid size along y'"),
    "pose_cells.n_theta": Reading(36, TEXT, "10 degree heading cells (indoor cell size 0.25 m x 0.25 m x 10 deg)"),
    "pose_cells.cell_size_m": _scale("0.25 m indoors (paper, text); a user's log may derive another"),
    "pose_cells.excite_sigma_cells": Reading(1.0, SILENT, "local excitation width: the paper gives no value"),
    "pose_cells.excite_sigma_theta_cells": Reading(0.6, SILENT, "excitation width in heading: no value given"),
    "pose_cells.excite_radius_cells": Reading(2, SILENT, "excitation kernel truncation: no value given"),
    "pose_cells.inhibit_sigma_cells": Reading(2.0, SILENT, "wider local inhibition: no value given"),
    "pose_cells.inhibit_sigma_theta_cells": Reading(1.0, SILENT, "inhibition width in heading: no value given"),
    "pose_cells.inhibit_radius_cells": Reading(3, SILENT, "inhibition kernel truncation: no value given"),
    "pose_cells.inhibit_weight": Reading(0.5, SILENT, "weight of local inhibition: no value given"),
    "pose_cells.global_inhibition": Reading(3e-5, SILENT, "global inhibition constant: no value given"),
    "pose_cells.peak_radius_cells": Reading(3, SILENT, "the paper reads the peak; its refinement is ours"),
    "pose_cells.trans_gain": Reading(1.0, TEXT, "path integration shifts the packet by the odometry, no gain"),
    "pose_cells.path_integration_bias_deg_s": _scale("a figure's manipulation (Figs 8-10), not a parameter"),
    "pose_cells.snap_threshold_cells": Reading(3.0, SILENT, "what counts as a snap in the metrics only"),
    # --- local view cells
    "local_view.learn_rate": Reading(1.0, SILENT, "Hebbian association rate: no value given"),
    "local_view.inject": Reading(0.1, SILENT, "view injection strength: no value given"),
    "local_view.learn_threshold": Reading(0.1, SILENT, "association threshold: no value given"),
    "local_view.fatigue_rate": Reading(
        0.1, SILENT, "no habituation is described; kept, since a view seen for a while pins the packet without it"
    ),
    "local_view.fatigue_recovery": Reading(0.05, SILENT, "recovery of that habituation (kept with it)"),
    "local_view.min_age_ticks": Reading(
        70, SILENT, "fresh associations must not inject or the packet is pinned (DESIGN's trap); kept"
    ),
    # --- experience map, eqs 2-14
    "experience_map.view_confirm_ticks": Reading(1, TEXT, "the map acts on every tick's view"),
    "experience_map.snap_settle_ticks": Reading(0, TEXT, "the map follows the peak at once, snaps included"),
    "experience_map.offset_transitions": Reading(False, TEXT, "eqs 10-11: a transition is the odometry between"),
    "experience_map.r_inf_cells": Reading(2.0, SILENT, "eqs 2-3 define r_inf; its value is our reading"),
    "experience_map.theta_inf_cells": Reading(2.0, SILENT, "eqs 4-5 define theta_inf; its value is our reading"),
    "experience_map.energy": Reading("sum", TEXT, "eq 9: E = E_V (E_xy + E_theta)"),
    "experience_map.alpha_theta": Reading(0.5, TABLE_1, "alpha_theta of eqs 12-14"),
    "experience_map.alpha_d": Reading(0.5, TABLE_1, "alpha_d of eqs 12-14"),
    "experience_map.correction": Reading(
        "stable",
        SILENT,
        "eqs 12-14 as printed sum residuals and diverge at experiences with > 2 links; read as alpha x their mean",
    ),
    "experience_map.correction_iterations": Reading(1, TEXT, "one correction per iteration"),
    "experience_map.relocalise_path_bound": Reading(False, DEPARTURE, "a re-entry is wherever the pose cells say"),
    "experience_map.relocalise_slack_cells": _inert(4.0, "slack of that bound"),
    "experience_map.loop_closure_sequence": Reading(False, DEPARTURE, "one view closes a loop"),
    "experience_map.odometry_gate_chi2": Reading(math.inf, DEPARTURE, "no odometry gate on re-entries"),
    # --- re-entry fusion: not in the paper
    "reentry.position_sigma_m": Reading(0.0, DEPARTURE, "re-entries not fused with the odometry"),
    "reentry.heading_sigma_deg": Reading(0.0, DEPARTURE, "re-entries not fused with the odometry"),
    "reentry.odom_speed_noise_m_s": _inert(0.01, "the fusion's odometry model"),
    "reentry.odom_heading_noise_rad_s": _inert(0.01, "the fusion's odometry model"),
    "reentry.innovation_window": _inert(15, "the fusion's noise scaling"),
    "reentry.odometry_trust_limit": _inert(2.0, "the fusion's trust limit"),
    "reentry.chain_fixes": Reading(False, DEPARTURE, "no chained fixes"),
    # --- yaw-rate bias search: not in the paper
    "yaw_bias.search": Reading(False, DEPARTURE, "no yaw-rate bias search"),
    "yaw_bias.search_max_deg_s": _inert(3.0),
    "yaw_bias.search_step_deg_s": _inert(0.05),
    "yaw_bias.search_max_span_s": _inert(300.0),
    "yaw_bias.search_kernel": _inert(3.0),
    "yaw_bias.search_min_gain": _inert(4.0),
    "yaw_bias.search_still_m_s": _inert(0.04),
    "yaw_bias.revisit_min_travel_m": _inert(4.0),
    "yaw_bias.revisit_sigma_xy_m": _inert(1.0 / math.sqrt(6.0)),
    "yaw_bias.revisit_sigma_heading_deg": _inert(90.0 / math.sqrt(6.0)),
    "yaw_bias.settle_turn_deg": _inert(0.0),
    "yaw_bias.rebuild": _inert(True),
    # --- the view-template matcher (camera streams only)
    "view.crop_top": _scale("the camera's image: what to crop is a property of the robot's camera"),
    "view.crop_bottom": _scale("the camera's image"),
    "view.crop_left": _scale("the camera's image"),
    "view.crop_right": _scale("the camera's image"),
    "view.template_width": _scale("template size: the paper gives none; set per camera"),
    "view.template_height": _scale("template size: set per camera"),
    "view.field_of_view_deg": _scale("the camera's field of view (the paper's robot: 50 deg)"),
    "view.max_shift_deg": _scale("rotation searched: set per camera"),
    "view.match_threshold": Reading(0.04, SILENT, "new-or-seen threshold of the matcher: no value given"),
    "view.global_normalisation": Reading(False, TEXT, "a sum of absolute differences, no normalisation"),
    "view.patch_normalisation_radius": Reading(0, TEXT, "a sum of absolute differences, no normalisation"),
    "view.mean_prefilter": _scale("an exact bound: the same matches either way, only faster"),
}
"""Every field of :class:`RatSLAMConfig` by dotted path: the published preset's reading."""


def field_paths(cls: type, prefix: str = "") -> list[str]:
    """Every leaf field of config class ``cls`` as a dotted path, in declaration order."""
    subs = subconfigs(cls)
    out: list[str] = []
    for f in dataclasses.fields(cls):
        path = f"{prefix}{f.name}"
        out += field_paths(subs[f.name], path + ".") if f.name in subs else [path]
    return out


def published_changes(paths: list[str] | None = None) -> dict[str, dict[str, Any]]:
    """The preset's fixed values (``SCALE`` fields left out) as ``RatSLAMConfig.replace`` changes;
    ``paths`` restricts them to some fields."""
    out: dict[str, dict[str, Any]] = {}
    for path, reading in PUBLISHED.items():
        if reading.value is _KEEP or (paths is not None and path not in paths):
            continue
        section, name = path.split(".")
        out.setdefault(section, {})[name] = reading.value
    return out


def departures(config: RatSLAMConfig, inert: bool = True) -> list[str]:
    """The fields of ``config`` whose value differs from the published preset's (``SCALE``
    fields aside; ``inert`` False: also those the published algorithm never reads), as
    ``path = value (published: value)``."""
    out = []
    for path, reading in PUBLISHED.items():
        if reading.value is _KEEP or (reading.inert and not inert):
            continue
        section, name = path.split(".")
        value = getattr(getattr(config, section), name)
        if value != reading.value:
            out.append(f"{path} = {value!r} (published: {reading.value!r})")
    return out


# The paper's re-entries alone (wherever the pose cells say: no bound, no sequence, no fusion), the
# re-entry part of the preset: ``RatSLAMConfig().replace(**PAPER_REENTRIES)``.
PAPER_REENTRIES = published_changes(
    [
        "experience_map.relocalise_path_bound",
        "experience_map.loop_closure_sequence",
        "reentry.position_sigma_m",
        "reentry.heading_sigma_deg",
    ]
)


def _shown(value: Any) -> str:
    if value is _KEEP:
        return "(kept)"
    if isinstance(value, bool):
        return "`true`" if value else "`false`"
    if isinstance(value, float) and math.isinf(value):
        return "`inf`"
    return f"`{value!r}`"


def markdown_table() -> str:
    """The preset as a markdown table: every field, its default, its published value, the source
    and the reading (docs/configuration.md holds this table; a test keeps the two equal)."""
    from .config import RatSLAMConfig

    defaults = RatSLAMConfig()
    lines = ["| field | default | published | source | reading |", "|---|---|---|---|---|"]
    for path, reading in PUBLISHED.items():
        section, name = path.split(".")
        default = getattr(getattr(defaults, section), name)
        lines.append(f"| `{path}` | {_shown(default)} | {_shown(reading.value)} | {reading.source} | {reading.note} |")
    return "\n".join(lines) + "\n"
