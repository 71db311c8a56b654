"""Sweep specifications: robustness studies over conditions, seeds and system configurations.

A spec is a TOML file::

    design = "one-at-a-time"      # or "grid"; optional
    max_runs = 1000               # refuse more runs than this without --yes; optional

    [base]
    world = "small_loop"          # a shipped world or a world file (relative to the spec), or
    # figure = "fig7"             # a figure: its world, duration, false-positive rate and grid
    duration = 600.0              # simulated seconds (default: the world's or figure's)
    lookalikes = false            # the world's look-alike regions show their own scenes (default true)

    [axes]                        # any of AXES, each a non-empty list of values
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
(:mod:`harness.config_file`): each sub-config is a sub-table, spelt with TOML's bare dotted keys
``pose_cells.nx = 40`` (as above) or as a sub-table ``[systems.ratslam.pose_cells]`` with
``nx = 40``; both are the same TOML. A quoted ``"pose_cells.nx"`` is one key, not a field, and
is refused. With a figure as the base, RatSLAM systems take the figure's pose-cell grid unless
they set their own.

Design "one-at-a-time" (default) varies each axis alone, the others at the base condition (the
world's own value), which is what a robustness curve per axis needs; "grid" runs every
combination. One run is one condition and one seed: it simulates once and runs every system on
that same stream. Every problem is one line naming the file, the key and the problem
(:class:`SweepSpecError`), raised before anything runs.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

from baselines import PoseGraphConfig
from ratslam import RatSLAMConfig
from slamkit.config_fields import ConfigError, replace
from worlds import load_world
from worlds.errors import InputError

from .config_file import read_config_table, read_preset, read_toml, where, with_preset

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
    )
}


class SweepSpecError(InputError):
    """A malformed sweep spec. The message is one line: file, key, problem."""


@dataclass(frozen=True)
class SystemSpec:
    """A named system configuration: which system and its configuration (a frozen dataclass)."""

    name: str
    kind: str  # "ratslam" or "gtsam"
    config: RatSLAMConfig | PoseGraphConfig


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep: base condition, axes, seeds and systems."""

    path: str
    world: str  # world name or file path, as load_world takes it
    duration: float
    base_fp_rate: float | None  # from a figure (None: the world's own)
    grid: tuple[int, int, int] | None  # RatSLAM grid from a figure (None: the default)
    design: str
    axes: dict  # name -> tuple of values, in file order
    seeds: Sequence[int]  # a range for count = N (never expanded before the run count is checked)
    systems: tuple[SystemSpec, ...]
    max_runs: int
    lookalikes: bool = True  # False: the world's look-alike regions show their own scenes

    def base_values(self) -> dict:
        """Each axis's value at the base condition (the world's own, or the figure's rate)."""
        world = load_world(self.world)
        return {
            "fp_rate": world.scenes.false_positive_rate if self.base_fp_rate is None else self.base_fp_rate,
            "alias_rate": world.scenes.alias_rate,
            "blank_rate": world.scenes.blank_rate,
            "odometric_bias": world.odometry.bias_deg_s,
            "pi_bias": 0.0,
            "odometry_noise_scale": 1.0,
        }

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


def _read_base(path: Path, raw: dict):
    base = raw.get("base")
    if not isinstance(base, dict):
        _fail(path, "[base]", "missing table (needs world = ... or figure = ...)")
    unknown = set(base) - {"world", "figure", "duration", "lookalikes"}
    if unknown:
        _fail(path, f"[base] {sorted(unknown)[0]}", "unknown key (expected world, figure, duration, lookalikes)")
    lookalikes = base.get("lookalikes", True)
    if not isinstance(lookalikes, bool):
        _fail(path, "[base] lookalikes", f"expected true or false, got {lookalikes!r}")
    if ("world" in base) == ("figure" in base):
        _fail(path, "[base]", "give exactly one of world = ... or figure = ...")
    fp, grid, duration = None, None, None
    if "figure" in base:
        from .figures import get_figure

        try:
            fig = get_figure(str(base["figure"]))
        except ValueError as e:
            _fail(path, "[base] figure", str(e))
        if fig.world is None:
            _fail(path, "[base] figure", f"{fig.name} replays a real log; a sweep needs a simulated world")
        world, fp, grid, duration = fig.world, fig.fp_rate, fig.grid, fig.duration
    else:
        world = base["world"]
        if not isinstance(world, str):
            _fail(path, "[base] world", f"expected a world name or file, got {world!r}")
        candidate = path.parent / world
        if world.endswith(".toml") and candidate.is_file():
            world = str(candidate)
    try:
        loaded = load_world(world)
    except (ValueError, OSError) as e:
        _fail(path, "[base] world", str(e))
    if "duration" in base:
        duration = _number(path, "[base] duration", base["duration"])
        if duration <= 0:
            _fail(path, "[base] duration", f"must be positive, got {duration!r}")
    return world, duration if duration is not None else loaded.duration, fp, grid, lookalikes


def _read_axes(path: Path, raw: dict) -> dict:
    axes = raw.get("axes")
    if not isinstance(axes, dict) or not axes:
        _fail(path, "[axes]", f"missing or empty (vary at least one of {', '.join(AXES)})")
    out = {}
    for name, values in axes.items():
        key = f"[axes] {name}"
        if name not in AXES:
            _fail(path, key, f"unknown axis (known: {', '.join(AXES)})")
        if not isinstance(values, list) or not values:
            _fail(path, key, "expected a non-empty list of values")
        axis = AXES[name]
        checked = []
        for v in values:
            v = _number(path, key, v)
            if not axis.low <= v <= axis.high:
                _fail(path, key, f"value {v!r} out of range [{axis.low:g}, {axis.high:g}] ({axis.meaning})")
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


def _read_systems(path: Path, raw: dict, grid) -> tuple[SystemSpec, ...]:
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
        if kind == "ratslam" and grid is not None:
            pose_cells = {"nx": grid[0], "ny": grid[1], "n_theta": grid[2], **fields.get("pose_cells", {})}
            fields = {**fields, "pose_cells": pose_cells}
        try:
            config = replace(config, fields)
        except ConfigError as e:
            raise SweepSpecError(f"{path}: {where(f'systems.{name}', e)}") from None
        out.append(SystemSpec(name, kind, config))
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
    world, duration, fp, grid, lookalikes = _read_base(path, raw)
    axes = _read_axes(path, raw)
    seeds = _read_seeds(path, raw)
    systems = _read_systems(path, raw, grid)
    if "pi_bias" in axes and not any(s.kind == "ratslam" for s in systems):
        _fail(path, "[axes] pi_bias", "varies RatSLAM's path integration, but no RatSLAM system is configured")
    spec = SweepSpec(
        path=str(path),
        world=world,
        duration=duration,
        base_fp_rate=fp,
        grid=grid,
        design=design,
        axes=axes,
        seeds=seeds,
        systems=systems,
        max_runs=max_runs,
        lookalikes=lookalikes,
    )
    if not spec.run_count():
        _fail(path, "[axes]", "the spec expands to zero runs")
    return spec


def check_sweep_size(spec: SweepSpec, yes: bool = False) -> None:
    """Each run's stream length and every RatSLAM system's pose-cell grid against the size budget
    (:mod:`harness.budget`), before anything runs (``yes``: go ahead anyway)."""
    from .budget import check_grid, check_ticks

    check_ticks(f"{spec.path}: [base] duration", spec.duration * load_world(spec.world).tick_rate, yes)
    for system in spec.systems:
        if isinstance(system.config, RatSLAMConfig):
            check_grid(f"{spec.path}: [systems.{system.name}]", system.config.shape, yes)


def system_config(system: SystemSpec, condition: dict):
    """The system's configuration under ``condition`` (the path-integration bias goes to RatSLAM)."""
    if system.kind == "ratslam" and "pi_bias" in condition:
        return replace(system.config, {"pose_cells": {"path_integration_bias_deg_s": float(condition["pi_bias"])}})
    return system.config
