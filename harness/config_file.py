"""Configuration files: ``[ratslam]`` and ``[gtsam]`` tables of ``RatSLAMConfig`` and
``PoseGraphConfig`` fields, in TOML.

Reading validates everything and reports a problem as one line naming the file, the table, the
key and the problem (:class:`ConfigFileError`). Every run directory gets the effective
configuration as ``config.toml``; feeding that file back (``replay LOG --config RUN/config.toml``)
reproduces the run bit for bit, since floats are written with ``repr`` (exact round trip).
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path

from baselines import PoseGraphConfig
from ratslam import RatSLAMConfig
from worlds.errors import InputError
from worlds.observation_log import atomic_write_text, read_text

TABLES = {"ratslam": RatSLAMConfig, "gtsam": PoseGraphConfig}


class ConfigFileError(InputError):
    """A malformed configuration file. The message is one line: file, table, key, problem."""


@dataclass(frozen=True)
class ConfigOverrides:
    """Field values read from a configuration file, per system (unset fields keep defaults)."""

    ratslam: dict = field(default_factory=dict)
    gtsam: dict = field(default_factory=dict)
    source: str | None = None

    def apply(self, ratslam: RatSLAMConfig, gtsam: PoseGraphConfig) -> tuple[RatSLAMConfig, PoseGraphConfig]:
        """The two configurations with the file's values on top (validated by the configs)."""
        return (self._replace("ratslam", ratslam, self.ratslam), self._replace("gtsam", gtsam, self.gtsam))

    def _replace(self, table: str, config, values: dict):
        try:
            return dataclasses.replace(config, **values)
        except ValueError as e:
            raise ConfigFileError(f"{self.source}: [{table}] {e}") from None


def _field_types(cls) -> dict[str, tuple[type, bool]]:
    """Per field: its scalar type and whether None is allowed."""
    hints = typing.get_type_hints(cls)
    out = {}
    for f in dataclasses.fields(cls):
        hint = hints[f.name]
        optional = False
        if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
            args = [a for a in typing.get_args(hint) if a is not type(None)]
            optional = len(args) < len(typing.get_args(hint))
            hint = args[0]
        out[f.name] = (hint, optional)
    return out


def _typed(path, table: str, key: str, value, kind: type):
    """The TOML value as the field's type, or a one-line error."""

    def fail(expected):
        raise ConfigFileError(f"{path}: [{table}] {key}: expected {expected}, got {value!r} ({type(value).__name__})")

    if kind is bool:
        if not isinstance(value, bool):
            fail("true or false")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            fail("an integer")
        return value
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            fail("a number")
        return float(value)
    if kind is str:
        if not isinstance(value, str):
            fail("a string")
        return value
    raise ConfigFileError(f"{path}: [{table}] {key}: cannot be set from a file")


def read_toml(path: Path, error: type[Exception]) -> dict:
    """The parsed TOML file, or ``error`` with one line naming the file and the problem."""
    text = read_text(path, error)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise error(f"{path}: not valid TOML ({e})") from None


def read_config_file(path) -> ConfigOverrides:
    """Read and validate a configuration file (types here, values when applied)."""
    path = Path(path)
    raw = read_toml(path, ConfigFileError)
    tables = {}
    for table, values in raw.items():
        if table not in TABLES:
            raise ConfigFileError(f"{path}: [{table}]: unknown table (expected {', '.join(f'[{t}]' for t in TABLES)})")
        if not isinstance(values, dict):
            raise ConfigFileError(f"{path}: {table}: expected a table [{table}], got a {type(values).__name__}")
        types_ = _field_types(TABLES[table])
        out = {}
        for key, value in values.items():
            if key not in types_:
                raise ConfigFileError(f"{path}: [{table}] {key}: unknown key (not a field of {TABLES[table].__name__})")
            out[key] = _typed(path, table, key, value, types_[key][0])
        tables[table] = out
    overrides = ConfigOverrides(ratslam=tables.get("ratslam", {}), gtsam=tables.get("gtsam", {}), source=str(path))
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


def config_toml(ratslam: RatSLAMConfig, gtsam: PoseGraphConfig, header: str = "") -> str:
    """The TOML text of two configurations (every field; a None field as a comment)."""
    lines = [f"# {line}" for line in header.splitlines()]
    for table, config in (("ratslam", ratslam), ("gtsam", gtsam)):
        lines += ["", f"[{table}]"]
        for f in dataclasses.fields(config):
            value = getattr(config, f.name)
            lines.append(f"# {f.name}: unset (None)" if value is None else f"{f.name} = {_toml_value(value)}")
    return "\n".join(lines).lstrip("\n") + "\n"


def write_config_toml(path, ratslam: RatSLAMConfig, gtsam: PoseGraphConfig, header: str = "") -> Path:
    """Write the effective configuration of a run (atomically)."""
    return atomic_write_text(path, config_toml(ratslam, gtsam, header))
