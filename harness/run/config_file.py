"""Configuration files: ``[ratslam]`` and ``[gtsam]`` tables of ``RatSLAMConfig`` and
``PoseGraphConfig`` fields, in TOML.

Each sub-config is a sub-table, e.g.::

    [ratslam.pose_cells]
    nx = 40
    [ratslam.experience_map]
    energy = "sum"
    [gtsam.backend]
    kind = "gnc"

(TOML's dotted keys are the same thing: ``pose_cells.nx = 40`` under ``[ratslam]``). Fields not
given keep the configuration they are applied to. ``preset = "published"`` under ``[ratslam]``
first puts RatSLAM at the paper's published algorithm (:meth:`ratslam.RatSLAMConfig.published`);
the file's fields then go on top of it (one departure switched on over the paper, say).
Reading validates everything and reports a problem as one line naming the file, the table, the key and the problem
(:class:`ConfigFileError`), e.g. ``c.toml: [ratslam.pose_cells] nx: must be an integer >= 4,
got 3``. A field given by an earlier name (a unit changed) is read under its new name, converted,
with one line on stderr saying so. Every run directory gets the effective configuration as ``config.toml``; feeding that
file back (``replay LOG --config RUN/config.toml``) reproduces the run bit for bit, since floats
are written with ``repr`` (exact round trip).
"""

from __future__ import annotations

import dataclasses
import math
import sys
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NoReturn

from baselines import PoseGraphConfig
from ratslam import PAPER_REENTRIES, RatSLAMConfig
from slamkit.config_fields import ConfigError, renamed, replace, subconfigs
from worlds.errors import InputError
from worlds.files import atomic_write_text, read_text

TABLES: dict[str, type] = {"ratslam": RatSLAMConfig, "gtsam": PoseGraphConfig}
PRESETS: dict[str, Callable[[RatSLAMConfig], RatSLAMConfig]] = {
    # the paper's algorithm (RatSLAMConfig.published: every field's published value, the scale kept)
    "published": RatSLAMConfig.published,
    # the paper's re-entries alone: wherever the pose cells say (ratslam.PAPER_REENTRIES)
    "paper_reentries": lambda config: config.replace(**PAPER_REENTRIES),
    # the paper's re-entry poses (no fusion with the odometry), the relocalisation bound kept
    "paper_reentry_poses": lambda config: config.replace(reentry=PAPER_REENTRIES["reentry"]),
}
"""RatSLAM presets a configuration file, a sweep's system or a figure's variant may name, each
applied to a configuration (the fields given beside it go on top)."""


def read_preset(table: dict, at: str, fail: Callable[[str, str], NoReturn]) -> str | None:
    """The ``preset`` key of a RatSLAM table (removed from it), checked; None if absent."""
    if "preset" not in table:
        return None
    preset = table.pop("preset")
    if preset not in PRESETS:
        fail(f"{at} preset", f"expected one of {', '.join(repr(p) for p in PRESETS)}, got {preset!r}")
    return preset


def merged(base: dict, over: dict) -> dict:
    """Configuration fields ``over`` on top of ``base`` (nested mappings, one per sub-config,
    merged field by field)."""
    out = dict(base)
    for key, value in over.items():
        both = isinstance(value, dict) and isinstance(out.get(key), dict)
        out[key] = merged(out[key], value) if both else value
    return out


def with_preset(config: RatSLAMConfig, preset: str | None) -> RatSLAMConfig:
    """``config`` with the named preset applied (its scale fields kept); unchanged for None."""
    return config if preset is None else PRESETS[preset](config)


class ConfigFileError(InputError):
    """A malformed configuration file. The message is one line: file, table, key, problem."""


def where(table: str, error: ConfigError) -> str:
    """``[table.section] key: problem`` for a configuration error of the config in ``[table]``."""
    section, _, key = error.field.rpartition(".")
    return f"[{table}.{section}] {key}: {error.problem}" if section else f"[{table}] {key}: {error.problem}"


@dataclass(frozen=True)
class ConfigOverrides:
    """Field values read from a configuration file, per system, as nested mappings like the
    file's tables (unset fields keep the configuration they are applied to)."""

    ratslam: dict = field(default_factory=dict)
    gtsam: dict = field(default_factory=dict)
    source: str | None = None
    preset: str | None = None  # RatSLAM's preset, applied before the file's values

    def apply(self, ratslam: RatSLAMConfig, gtsam: PoseGraphConfig) -> tuple[RatSLAMConfig, PoseGraphConfig]:
        """The two configurations with the file's preset and values on top (validated by the configs)."""
        ratslam = with_preset(ratslam, self.preset)
        return (self._replace("ratslam", ratslam, self.ratslam), self._replace("gtsam", gtsam, self.gtsam))

    def _replace(self, table: str, config, values: dict):
        try:
            return replace(config, values)
        except ConfigError as e:
            raise ConfigFileError(f"{self.source}: {where(table, e)}") from None


def renamed_note(where_: str, key: str, new_key: str, unit: str, value: Any) -> str:
    """The one line said when a file gives a field by an earlier name."""
    return f"{where_} {key}: now {new_key} ({unit}); read as {new_key} = {value!r}"


def _note(line: str) -> None:
    print(f"note: {line}", file=sys.stderr)


def read_config_table(
    cls: type,
    values: dict,
    table: str,
    fail: Callable[[str, str], NoReturn],
    note: Callable[[str], None] = _note,
) -> dict:
    """The entries of TOML table ``[table]`` for config class ``cls``, checked for known keys and
    for sub-tables where the class has sub-configs (values are checked when applied). Problems go
    to ``fail(where, problem)``, ``where`` like ``[ratslam.pose_cells] nx``. A field given by an
    earlier name (``cls.RENAMED``) is read under its new name, converted, with one line to
    ``note`` (stderr by default) saying so."""
    names = {f.name for f in dataclasses.fields(cls)}
    subs = subconfigs(cls)
    out: dict[str, Any] = {}
    for key, value in values.items():
        earlier = renamed(cls, key, value)
        if earlier is not None:
            entry, value = earlier
            if entry.name in values:
                fail(f"[{table}] {key}", f"an earlier name of {entry.name}, which is given too")
            note(renamed_note(f"[{table}]", key, entry.name, entry.unit, value))
            key = entry.name
        if key not in names:
            hint = f"; a quoted dotted key? write it bare: {key} = ..." if "." in key else ""
            fail(f"[{table}] {key}", f"unknown key (not a field of {cls.__name__}){hint}")
        if key in subs:
            if not isinstance(value, dict):
                fail(f"[{table}] {key}", f"expected a table [{table}.{key}], got {value!r}")
            out[key] = read_config_table(subs[key], value, f"{table}.{key}", fail, note)
        elif isinstance(value, dict):
            fail(f"[{table}] {key}", "expected a value, got a table")
        else:
            out[key] = value
    return out


def read_toml(path: Path, error: type[Exception]) -> dict:
    """The parsed TOML file, or ``error`` with one line naming the file and the problem."""
    text = read_text(path, error)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise error(f"{path}: not valid TOML ({e})") from None


def read_config_file(path) -> ConfigOverrides:
    """Read and validate a configuration file (keys here, values by applying them to the defaults)."""
    path = Path(path)
    raw = read_toml(path, ConfigFileError)

    def fail(where_: str, problem: str) -> NoReturn:
        raise ConfigFileError(f"{path}: {where_}: {problem}")

    def note(line: str) -> None:
        _note(f"{path}: {line}")

    tables = {}
    preset = None
    for table, values in raw.items():
        if table not in TABLES:
            fail(f"[{table}]", f"unknown table (expected {', '.join(f'[{t}]' for t in TABLES)})")
        if not isinstance(values, dict):
            fail(table, f"expected a table [{table}], got a {type(values).__name__}")
        if table == "ratslam":
            values = dict(values)
            preset = read_preset(values, "[ratslam]", fail)
        tables[table] = read_config_table(TABLES[table], values, table, fail, note)
    overrides = ConfigOverrides(
        ratslam=tables.get("ratslam", {}), gtsam=tables.get("gtsam", {}), source=str(path), preset=preset
    )
    overrides.apply(RatSLAMConfig(), PoseGraphConfig())  # values checked now, before any work
    return overrides


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    raise TypeError(f"cannot write {value!r} to TOML")


def _table_lines(table: str, config) -> list[str]:
    """``[table]`` with the config's own fields (if any), then a sub-table per sub-config."""
    subs = subconfigs(type(config))
    own = [f.name for f in dataclasses.fields(config) if f.name not in subs]
    lines = ["", f"[{table}]"] if own else []
    for name in own:
        value = getattr(config, name)
        lines.append(f"# {name}: unset (None)" if value is None else f"{name} = {_toml_value(value)}")
    for name in subs:
        lines += _table_lines(f"{table}.{name}", getattr(config, name))
    return lines


def config_toml(ratslam: RatSLAMConfig, gtsam: PoseGraphConfig, header: str = "") -> str:
    """The TOML text of two configurations (every field; a None field as a comment)."""
    lines = [f"# {line}" for line in header.splitlines()]
    for table, config in (("ratslam", ratslam), ("gtsam", gtsam)):
        lines += _table_lines(table, config)
    return "\n".join(lines).lstrip("\n") + "\n"


def write_config_toml(path, ratslam: RatSLAMConfig, gtsam: PoseGraphConfig, header: str = "") -> Path:
    """Write the effective configuration of a run (atomically)."""
    return atomic_write_text(path, config_toml(ratslam, gtsam, header))
