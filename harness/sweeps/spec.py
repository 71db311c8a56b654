"""Sweep specifications: robustness studies over conditions, seeds and system configurations.

A spec is a TOML file::

    design = "one-at-a-time"      # or "grid"; optional
    max_runs = 1000               # refuse more runs than this without --yes; optional

    [base]
    world = "small_loop"          # a shipped world or a world file (relative to the spec), or
    # figure = "fig7"             # a figure: its world, duration, false-positive rate and RatSLAM
                                  # fields (its pose-cell grid), or
    # log = "plaza1"              # a real odometry log: "plaza1", "plaza2" or an observation log
                                  # (CSV with ground truth, relative to the spec)
    duration = 600.0              # simulated seconds (default: the world's or figure's; a log's
                                  # start, default all of it)
    lookalikes = false            # the world's look-alike regions show their own scenes (default true)
    # camera = "forward"          # both systems see the world through the simulated camera
                                  # ("forward" or "panoramic") and the view matcher

    [axes]                        # any of the base's axes (WORLD_AXES, LOG_AXES or CAMERA_AXES)
    fp_rate = [0.0, 0.01, 0.02, 0.05]
    odometric_bias = [0.0, 1.5, 3.0]

    [seeds]
    count = 10                    # seeds 0 .. count - 1; or list = [3, 7, 11]

    [systems.ratslam]             # a named system: "system" is "ratslam" or "gtsam", every
    system = "ratslam"            # other key a field of RatSLAMConfig / PoseGraphConfig
    experience_map.energy = "sum"
    [systems.ratslam_published]   # RatSLAM as published (RatSLAMConfig.published()),
    system = "ratslam"            # the fields given going on top of it
    preset = "published"
    [systems.gtsam_gnc]
    system = "gtsam"
    backend.kind = "gnc"

A system's configuration fields are written as in a configuration file
(:mod:`harness.run.config_file`): each sub-config is a sub-table, spelt with TOML's bare dotted keys
``pose_cells.nx = 40`` (as above) or as a sub-table ``[systems.ratslam.pose_cells]`` with
``nx = 40``; both are the same TOML. A quoted ``"pose_cells.nx"`` is one key, not a field, and
is refused. With a figure as the base, RatSLAM systems take the figure's RatSLAM fields (its
pose-cell grid) unless they set their own.

A real log as the base (``log = ...``): its recorded odometry is replayed as it is and only the
place labels vary; they are synthesised from the log's ground truth by the simulator's scene
model (:func:`worlds.real_data.labelled_log`, the Plaza model :data:`~worlds.real_data.PLAZA_SCENES`
at the base condition), the seed being the label seed (flicker and false positives). Each
system's configuration is derived from the labelled log as ``replay`` derives it
(:func:`harness.run.scale.derive_configs`, from the odometry and the labels, never the ground
truth), its own fields in the spec going on top. A camera base renders every tick at its true
pose and matches the images (:func:`harness.camera.stream.camera_observations`): the template
numbers replace the scene numbers for both systems.

Design "one-at-a-time" (default) varies each axis alone, the others at the base condition (the
world's own value), which is what a robustness curve per axis needs; "grid" runs every
combination. One run is one condition and one seed: it simulates once and runs every system on
that same stream. Every problem is one line naming the file, the key and the problem
(:class:`SweepSpecError`), raised before anything runs.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

import numpy as np

from baselines import PoseGraphConfig
from ratslam import RatSLAMConfig
from slamkit.config_fields import ConfigError, replace
from worlds import load_world
from worlds.errors import InputError

from ..run.config_file import merged, read_config_table, read_preset, read_toml, where, with_preset

SYSTEM_CONFIGS = {"ratslam": RatSLAMConfig, "gtsam": PoseGraphConfig}
DESIGNS = ("one-at-a-time", "grid")
DEFAULT_MAX_RUNS = 1000


@dataclass(frozen=True)
class Axis:
    """A condition that can be varied: its allowed range and what it means."""

    name: str
    low: float
    high: float
    meaning: str


AXES = {
    a.name: a
    for a in (
        Axis("fp_rate", 0.0, 1.0, "false-positive scene reports per tick"),
        Axis("alias_rate", 0.0, 1.0, "fraction of scene cells sharing their number with a distant cell"),
        Axis("blank_rate", 0.0, 1.0, "fraction of scene cells showing nothing recognisable"),
        Axis("odometric_bias", -90.0, 90.0, "yaw-rate bias in the odometry seen by every system (deg/s)"),
        Axis("pi_bias", -90.0, 90.0, "yaw-rate bias in RatSLAM's pose-cell path integration only (deg/s)"),
        Axis("odometry_noise_scale", 0.0, 100.0, "factor on the world's odometry noise (speed and yaw rate)"),
        Axis("cell_size", 0.1, 100.0, "side of the scene cells the place labels come from (m)"),
        Axis("lighting_amplitude", 0.0, 1.0, "camera brightness gain 1 + amplitude sin(2 pi t / period)"),
        Axis("image_noise", 0.0, 1.0, "std of the camera's Gaussian pixel noise (image values in [0, 1])"),
        Axis("lookalikes", 0.0, 1.0, "the world's look-alike regions look alike (1) or show their own (0)"),
    )
}
WORLD_AXES: tuple[str, ...] = (
    "fp_rate",
    "alias_rate",
    "blank_rate",
    "odometric_bias",
    "pi_bias",
    "odometry_noise_scale",
)
"""The axes of a simulated world's sweep (its place labels and odometry), in runs.csv's order."""
LOG_AXES: tuple[str, ...] = ("cell_size", "fp_rate", "alias_rate", "blank_rate", "pi_bias")
"""The axes of a real log's sweep: the synthesised place labels (and RatSLAM's path integration)."""
CAMERA_AXES: tuple[str, ...] = (
    "lighting_amplitude",
    "image_noise",
    "lookalikes",
    "odometric_bias",
    "pi_bias",
    "odometry_noise_scale",
)
"""The axes of a camera sweep: what the camera sees, and the odometry."""
_WHOLE_VALUED = ("lookalikes",)  # 0 or 1


class SweepSpecError(InputError):
    """A malformed sweep spec. The message is one line: file, key, problem."""


@dataclass(frozen=True)
class SystemSpec:
    """A named system configuration: which system and its configuration (a frozen dataclass)."""

    name: str
    kind: str  # "ratslam" or "gtsam"
    config: RatSLAMConfig | PoseGraphConfig
    preset: str | None = None  # RatSLAM's preset, if any ("published")
    fields: dict = dataclasses.field(default_factory=dict)  # the fields the spec sets (a real log's
    # configuration is derived from the log, these going on top, as ``replay --config`` does)


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep: base condition, axes, seeds and systems."""

    path: str
    world: str | None  # world name or file path, as load_world takes it (None: a real log)
    duration: float
    base_fp_rate: float | None  # from a figure (None: the world's own)
    figure_ratslam: dict  # RatSLAM's fields from a figure (its pose-cell grid; empty: the defaults)
    design: str
    axes: dict  # name -> tuple of values, in file order
    seeds: Sequence[int]  # a range for count = N (never expanded before the run count is checked)
    systems: tuple[SystemSpec, ...]
    max_runs: int
    lookalikes: bool = True  # False: the world's look-alike regions show their own scenes
    log: str | None = None  # a real log: "plaza1", "plaza2" or an observation log file
    camera: str | None = None  # "forward" or "panoramic": the systems see the camera's views

    @property
    def axis_names(self) -> tuple[str, ...]:
        """The axes of this spec's base (every run has a value for each), in runs.csv's order."""
        if self.log is not None:
            return LOG_AXES
        return CAMERA_AXES if self.camera is not None else WORLD_AXES

    def camera_view(self):
        """The view matcher's settings for the camera's stream (matched once for every system):
        the RatSLAM systems' ``view`` fields (the defaults without one) for this camera."""
        from ..camera.stream import camera_view_config

        views = [s.config.view for s in self.systems if isinstance(s.config, RatSLAMConfig)]
        return camera_view_config(self.camera or "forward", views[0] if views else None)

    def base_values(self) -> dict:
        """Each axis's value at the base condition (the world's own, the figure's rate, or the
        Plaza scene model for a real log)."""
        if self.log is not None:
            from worlds.real_data import PLAZA_SCENES as scenes

            return {
                "cell_size": scenes.cell_size,
                "fp_rate": scenes.false_positive_rate,
                "alias_rate": scenes.alias_rate,
                "blank_rate": scenes.blank_rate,
                "pi_bias": 0.0,
            }
        world = load_world(self.world)
        values = {
            "fp_rate": world.scenes.false_positive_rate if self.base_fp_rate is None else self.base_fp_rate,
            "alias_rate": world.scenes.alias_rate,
            "blank_rate": world.scenes.blank_rate,
            "odometric_bias": world.odometry.bias_deg_s,
            "pi_bias": 0.0,
            "odometry_noise_scale": 1.0,
            "lighting_amplitude": world.camera.lighting_amplitude,
            "image_noise": world.camera.noise,
            "lookalikes": float(self.lookalikes),
        }
        return {a: values[a] for a in self.axis_names}

    def run_count(self) -> int:
        """How many runs :meth:`runs` gives, counted without expanding them."""
        if self.design == "grid":
            conditions = math.prod(len(v) for v in self.axes.values())
        else:
            conditions = sum(len(v) for v in self.axes.values())
        return conditions * len(self.seeds)

    def conditions(self) -> list[dict]:
        """Every condition to run: {axis: value} for the varied axes (empty dict = the base)."""
        if self.design == "grid":
            names = list(self.axes)
            return [dict(zip(names, values)) for values in itertools.product(*self.axes.values())]
        return [{name: v} for name, values in self.axes.items() for v in values]

    def runs(self) -> list[tuple[dict, int]]:
        """Every run, in a fixed order: (condition, seed)."""
        return [(c, s) for c in self.conditions() for s in self.seeds]


def _fail(path, key: str, problem: str) -> NoReturn:
    raise SweepSpecError(f"{path}: {key}: {problem}")


def _number(path, key: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        _fail(path, key, f"expected a finite number, got {value!r}")
    return float(value)


CAMERAS = ("forward", "panoramic")


def _read_log(path: Path, value) -> tuple[str, float]:
    """A real log's source ("plaza1", "plaza2" or a file relative to the spec) and its duration;
    a log without ground truth cannot have labels synthesised."""
    from worlds.real_data import PLAZA_SETS, RealDataError

    from .base_log import read_base_log

    if not isinstance(value, str) or not value:
        _fail(path, "[base] log", f"expected plaza1, plaza2 or an observation log file, got {value!r}")
    source = value if value.lower() in PLAZA_SETS else str(path.parent / value)
    try:
        log = read_base_log(source)
    except (RealDataError, InputError, OSError) as e:
        _fail(path, "[base] log", str(e))
    return source, float(np.sum(log.dt))


def _read_base(path: Path, raw: dict) -> dict:
    base = raw.get("base")
    if not isinstance(base, dict):
        _fail(path, "[base]", "missing table (needs world = ..., figure = ... or log = ...)")
    unknown = set(base) - {"world", "figure", "log", "duration", "lookalikes", "camera"}
    if unknown:
        _fail(
            path,
            f"[base] {sorted(unknown)[0]}",
            "unknown key (expected world, figure, log, duration, lookalikes, camera)",
        )
    lookalikes = base.get("lookalikes", True)
    if not isinstance(lookalikes, bool):
        _fail(path, "[base] lookalikes", f"expected true or false, got {lookalikes!r}")
    if sum(k in base for k in ("world", "figure", "log")) != 1:
        _fail(path, "[base]", "give exactly one of world = ..., figure = ... or log = ...")
    camera = base.get("camera")
    if camera is not None and camera not in CAMERAS:
        _fail(path, "[base] camera", f"expected one of {', '.join(CAMERAS)}, got {camera!r}")
    fp, figure_ratslam, duration, log = None, {}, None, None
    if "log" in base:
        if camera is not None:
            _fail(path, "[base] camera", "a real log has no simulated world to render")
        if "lookalikes" in base:
            _fail(path, "[base] lookalikes", "a real log has no look-alike regions (its labels: the scene model)")
        log, log_duration = _read_log(path, base["log"])
        world = None
    elif "figure" in base:
        from ..figures.registry import get_figure

        try:
            fig = get_figure(str(base["figure"]))
        except ValueError as e:
            _fail(path, "[base] figure", str(e))
        if fig.world is None:
            _fail(path, "[base] figure", f"{fig.name} replays a real log: write log = {fig.real_log!r} instead")
        world, fp, figure_ratslam, duration = fig.world, fig.fp_rate, fig.ratslam, fig.duration
    else:
        world = base["world"]
        if not isinstance(world, str):
            _fail(path, "[base] world", f"expected a world name or file, got {world!r}")
        candidate = path.parent / world
        if world.endswith(".toml") and candidate.is_file():
            world = str(candidate)
    if world is not None:
        try:
            loaded = load_world(world)
        except (ValueError, OSError) as e:
            _fail(path, "[base] world", str(e))
    if "duration" in base:
        duration = _number(path, "[base] duration", base["duration"])
        if duration <= 0:
            _fail(path, "[base] duration", f"must be positive, got {duration!r}")
    if duration is None:
        duration = log_duration if log is not None else loaded.duration
    return {
        "world": world,
        "log": log,
        "camera": camera,
        "duration": duration,
        "fp": fp,
        "figure_ratslam": figure_ratslam,
        "lookalikes": lookalikes,
    }


def _read_axes(path: Path, raw: dict, names: tuple[str, ...], base: str) -> dict:
    axes = raw.get("axes")
    if not isinstance(axes, dict) or not axes:
        _fail(path, "[axes]", f"missing or empty (vary at least one of {', '.join(names)})")
    out = {}
    for name, values in axes.items():
        key = f"[axes] {name}"
        if name not in AXES:
            _fail(path, key, f"unknown axis (known: {', '.join(AXES)})")
        if name not in names:
            _fail(path, key, f"not an axis of {base} (its axes: {', '.join(names)})")
        if not isinstance(values, list) or not values:
            _fail(path, key, "expected a non-empty list of values")
        axis = AXES[name]
        checked = []
        for v in values:
            v = _number(path, key, v)
            if not axis.low <= v <= axis.high:
                _fail(path, key, f"value {v!r} out of range [{axis.low:g}, {axis.high:g}] ({axis.meaning})")
            if name in _WHOLE_VALUED and v not in (0.0, 1.0):
                _fail(path, key, f"value {v!r}: expected 0 or 1 ({axis.meaning})")
            checked.append(v)
        if len(set(checked)) != len(checked):
            _fail(path, key, "values repeat")
        out[name] = tuple(checked)
    return out


def _read_seeds(path: Path, raw: dict) -> Sequence[int]:
    seeds = raw.get("seeds", {"count": 1})
    if not isinstance(seeds, dict) or set(seeds) - {"count", "list"} or len(seeds) != 1:
        _fail(path, "[seeds]", "expected exactly one of count = N or list = [...]")
    if "count" in seeds:
        n = seeds["count"]
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            _fail(path, "[seeds] count", f"expected an integer >= 1, got {n!r}")
        return range(n)
    values = seeds["list"]
    if (
        not isinstance(values, list)
        or not values
        or any(isinstance(s, bool) or not isinstance(s, int) or s < 0 for s in values)
    ):
        _fail(path, "[seeds] list", "expected a non-empty list of non-negative integers")
    if len(set(values)) != len(values):
        _fail(path, "[seeds] list", "seeds repeat")
    return tuple(values)


def _read_systems(path: Path, raw: dict, figure_ratslam: dict) -> tuple[SystemSpec, ...]:
    systems = raw.get("systems")
    if not isinstance(systems, dict) or not systems:
        _fail(path, "[systems]", 'missing or empty (add e.g. [systems.ratslam] system = "ratslam")')
    out = []
    for name, table in systems.items():
        at = f"[systems.{name}]"
        if not isinstance(table, dict):
            _fail(path, at, "expected a table")
        kind = table.get("system")
        if kind not in SYSTEM_CONFIGS:
            _fail(path, f"{at} system", f'expected "ratslam" or "gtsam", got {kind!r}')
        cls = SYSTEM_CONFIGS[kind]
        values = {k: v for k, v in table.items() if k != "system"}
        preset = read_preset(values, at, lambda at, problem: _fail(path, at, problem)) if kind == "ratslam" else None
        fields = read_config_table(cls, values, f"systems.{name}", lambda at, problem: _fail(path, at, problem))
        config = with_preset(cls(), preset) if kind == "ratslam" else cls()
        if kind == "ratslam":  # a figure's fields (its grid) under the system's own
            fields = merged(figure_ratslam, fields)
        try:
            config = replace(config, fields)
        except ConfigError as e:
            raise SweepSpecError(f"{path}: {where(f'systems.{name}', e)}") from None
        out.append(SystemSpec(name, kind, config, preset, fields))
    return tuple(out)


def read_sweep_spec(path) -> SweepSpec:
    """Read and validate a sweep spec (everything checked before anything runs)."""
    path = Path(path)
    raw = read_toml(path, SweepSpecError)
    unknown = set(raw) - {"design", "max_runs", "base", "axes", "seeds", "systems"}
    if unknown:
        _fail(
            path,
            sorted(unknown)[0],
            "unknown key or table (expected design, max_runs, [base], [axes], [seeds], [systems.NAME])",
        )
    design = raw.get("design", DESIGNS[0])
    if design not in DESIGNS:
        _fail(path, "design", f"expected one of {', '.join(DESIGNS)}, got {design!r}")
    max_runs = raw.get("max_runs", DEFAULT_MAX_RUNS)
    if isinstance(max_runs, bool) or not isinstance(max_runs, int) or max_runs < 1:
        _fail(path, "max_runs", f"expected an integer >= 1, got {max_runs!r}")
    base = _read_base(path, raw)
    if base["log"] is not None:
        names, what = LOG_AXES, "a real log"
    elif base["camera"] is not None:
        names, what = CAMERA_AXES, "a camera's stream"
    else:
        names, what = WORLD_AXES, "a simulated world"
    axes = _read_axes(path, raw, names, what)
    seeds = _read_seeds(path, raw)
    systems = _read_systems(path, raw, base["figure_ratslam"])
    if base["camera"] is not None:
        views = {s.name: s.config.view for s in systems if isinstance(s.config, RatSLAMConfig)}
        for name, view in views.items():
            if view != next(iter(views.values())):
                _fail(
                    path,
                    f"[systems.{name}] view",
                    "the camera's views are matched once for every system: "
                    "give every RatSLAM system the same view fields",
                )
    if "pi_bias" in axes and not any(s.kind == "ratslam" for s in systems):
        _fail(path, "[axes] pi_bias", "varies RatSLAM's path integration, but no RatSLAM system is configured")
    spec = SweepSpec(
        path=str(path),
        world=base["world"],
        duration=base["duration"],
        base_fp_rate=base["fp"],
        figure_ratslam=base["figure_ratslam"],
        design=design,
        axes=axes,
        seeds=seeds,
        systems=systems,
        max_runs=max_runs,
        lookalikes=base["lookalikes"],
        log=base["log"],
        camera=base["camera"],
    )
    if not spec.run_count():
        _fail(path, "[axes]", "the spec expands to zero runs")
    return spec


def check_sweep_size(spec: SweepSpec, yes: bool = False) -> None:
    """Each run's stream length and every RatSLAM system's pose-cell grid against the size budget
    (:mod:`harness.run.budget`), before anything runs (``yes``: go ahead anyway)."""
    from ..run.budget import check_grid, check_ticks

    if spec.log is not None:
        from .base_log import read_base_log

        check_ticks(f"{spec.path}: [base] log", len(read_base_log(spec.log, spec.duration)), yes)
    else:
        check_ticks(f"{spec.path}: [base] duration", spec.duration * load_world(spec.world).tick_rate, yes)
    for system in spec.systems:
        if isinstance(system.config, RatSLAMConfig):
            check_grid(f"{spec.path}: [systems.{system.name}]", system.config.shape, yes)


def condition_fields(system: SystemSpec, condition: dict) -> dict:
    """The configuration fields ``condition`` sets on the system (the path-integration bias goes
    to RatSLAM); empty for the others."""
    if system.kind == "ratslam" and "pi_bias" in condition:
        return {"pose_cells": {"path_integration_bias_deg_s": float(condition["pi_bias"])}}
    return {}


def system_config(system: SystemSpec, condition: dict):
    """The system's configuration under ``condition`` (:func:`condition_fields` on the spec's)."""
    fields = condition_fields(system, condition)
    return replace(system.config, fields) if fields else system.config


def system_fields(system: SystemSpec, condition: dict) -> dict:
    """The fields the spec and ``condition`` set on the system: what goes on top of a
    configuration derived from a real log (:func:`condition_fields` over the spec's)."""
    fields = {k: dict(v) if isinstance(v, dict) else v for k, v in system.fields.items()}
    for key, value in condition_fields(system, condition).items():
        fields[key] = {**fields.get(key, {}), **value}
    return fields
