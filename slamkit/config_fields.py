"""Configuration fields: constraints declared once per field, and the one validator for them.

Every configuration of the project (``RatSLAMConfig``, ``baselines.PoseGraphConfig`` and their
sub-configs) is a frozen dataclass whose fields are declared with :func:`param`; its
``__post_init__`` calls :func:`check_fields`, which checks each field against its annotation
and declared range:

- ``int``: a real integer (``numpy`` integers too, stored as ``int``), never a bool;
- ``float``: a real number (ints and ``numpy`` numbers too, stored as ``float``), never a bool,
  finite unless declared ``finite=False`` (then +/-inf pass, NaN never);
- ``bool``: ``True`` or ``False`` only;
- ``Literal[...]``: one of the choices;
- ``X | None``: ``None`` or an ``X``;
- a sub-config dataclass: an instance of it.

A problem is a :class:`ConfigError`, one line naming the field by its dotted path, e.g.
``pose_cells.nx: must be an integer >= 4, got 2``. Cross-field checks stay with the dataclass
that owns the fields.

A field renamed (say for a change of unit) keeps its earlier name readable: the config class
declares ``RENAMED = {old_name: Renamed(new_name, unit, convert)}`` and :func:`renamed` gives a
reader of users' files the new name and the converted value.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import types
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal, TypeVar

T = TypeVar("T")


class ConfigError(ValueError):
    """An invalid configuration value. The message is one line: ``<field path>: <problem>``."""

    def __init__(self, field: str, problem: str):
        super().__init__(f"{field}: {problem}")
        self.field, self.problem = field, problem


@dataclass(frozen=True)
class Bounds:
    """Allowed range of a number; an open end excludes its value, ``None`` is unbounded."""

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    finite: bool = True  # floats only: False lets +/-inf through

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies in the range."""
        if self.low is not None and (value <= self.low if self.low_open else value < self.low):
            return False
        return not (self.high is not None and (value >= self.high if self.high_open else value > self.high))

    def describe(self) -> str:
        """The range as text: ``" >= 4"``, ``" in [0, 1)"`` or ``""``."""
        if self.low is not None and self.high is not None:
            return f" in {'(' if self.low_open else '['}{self.low:g}, {self.high:g}{')' if self.high_open else ']'}"
        if self.low is not None:
            return f" {'>' if self.low_open else '>='} {self.low:g}"
        if self.high is not None:
            return f" {'<' if self.high_open else '<='} {self.high:g}"
        return ""


@dataclass(frozen=True)
class Renamed:
    """A field's earlier name (declared in its class's ``RENAMED``): the field now, the unit it is
    in, and what turns a value in the earlier unit into it."""

    name: str
    unit: str
    convert: Callable[[float], float]


def renamed(config_class: type, key: str, value: Any) -> tuple[Renamed, Any] | None:
    """If ``key`` is an earlier name of a field of ``config_class``: its :class:`Renamed` and
    ``value`` converted (a number only: anything else is left for the validator to refuse under
    the new name); else None."""
    entry = getattr(config_class, "RENAMED", {}).get(key)
    if entry is None:
        return None
    number = isinstance(value, numbers.Real) and not isinstance(value, bool)
    return entry, entry.convert(float(value)) if number else value


def param(
    default: Any,
    *,
    ge: float | None = None,
    gt: float | None = None,
    le: float | None = None,
    lt: float | None = None,
    finite: bool = True,
) -> Any:
    """A configuration field with its default and its allowed range (``ge``/``gt`` lower,
    ``le``/``lt`` upper bound; ``finite=False`` allows infinity in a float field)."""
    bounds = Bounds(
        low=gt if gt is not None else ge,
        high=lt if lt is not None else le,
        low_open=gt is not None,
        high_open=lt is not None,
        finite=finite,
    )
    return dataclasses.field(default=default, metadata={"bounds": bounds})


def section_of(config_or_class: Any) -> str:
    """The dotted path of a config class within its parent (its ``SECTION``; '' at the top)."""
    return getattr(config_or_class, "SECTION", "")


def qualified(config_or_class: Any, name: str) -> str:
    """A field's dotted path, e.g. ``pose_cells.nx``."""
    section = section_of(config_or_class)
    return f"{section}.{name}" if section else name


_FIELD_TYPES: dict[type, dict[str, Any]] = {}


def field_types(cls: type) -> dict[str, Any]:
    """Each field's resolved annotation (``typing.get_type_hints``), in declaration order."""
    if cls not in _FIELD_TYPES:
        hints = typing.get_type_hints(cls)
        _FIELD_TYPES[cls] = {f.name: hints[f.name] for f in dataclasses.fields(cls)}
    return _FIELD_TYPES[cls]


def _is_config_class(hint: Any) -> bool:
    return isinstance(hint, type) and dataclasses.is_dataclass(hint)


def subconfigs(cls: type) -> dict[str, type]:
    """The fields of ``cls`` that hold a sub-config, with the sub-config class."""
    return {name: hint for name, hint in field_types(cls).items() if _is_config_class(hint)}


def _split_optional(hint: Any) -> tuple[Any, bool]:
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        if len(args) != 1:
            raise TypeError(f"unsupported configuration type {hint!r}")
        return args[0], True
    return hint, False


def _describe(kind: Any, bounds: Bounds) -> str:
    if kind is bool:
        return "True or False"
    if kind is int:
        return "an integer" + bounds.describe()
    if kind is float:
        return ("a finite number" if bounds.finite else "a number (inf allowed)") + bounds.describe()
    if typing.get_origin(kind) is Literal:
        return "one of " + ", ".join(repr(c) for c in typing.get_args(kind))
    return f"a {kind.__name__}"


def checked_value(name: str, value: Any, hint: Any, bounds: Bounds | None = None) -> Any:
    """``value`` checked against the annotation ``hint`` and ``bounds``, as the field stores it
    (numpy scalars as ``int``/``float``, an int in a float field as ``float``); else
    :class:`ConfigError` naming ``name``."""
    kind, optional = _split_optional(hint)
    bounds = bounds or Bounds()
    if optional and value is None:
        return None

    def fail() -> typing.NoReturn:
        what = _describe(kind, bounds)
        raise ConfigError(name, f"must be {'None or ' if optional else ''}{what}, got {value!r}")

    if kind is bool:
        if not isinstance(value, bool):
            fail()
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not bounds.contains(int(value)):
            fail()
        return int(value)
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            fail()
        number = float(value)
        if math.isnan(number) or (bounds.finite and math.isinf(number)) or not bounds.contains(number):
            fail()
        return number
    if typing.get_origin(kind) is Literal:
        choices = typing.get_args(kind)
        if not any(type(value) is type(c) and value == c for c in choices):
            fail()
        return value
    if _is_config_class(kind):
        if not isinstance(value, kind):
            fail()
        return value
    raise TypeError(f"{name}: unsupported configuration type {hint!r}")


def check_fields(config: Any) -> None:
    """Check every field of a config dataclass (see the module doc) and store numbers in their
    declared type. Call it first in ``__post_init__``; cross-field checks follow it."""
    for f in dataclasses.fields(config):
        hint = field_types(type(config))[f.name]
        bounds = f.metadata.get("bounds")
        value = checked_value(qualified(config, f.name), getattr(config, f.name), hint, bounds)
        object.__setattr__(config, f.name, value)  # frozen: normalised in place, once


def replace(config: T, changes: Mapping[str, Any]) -> T:
    """A copy of ``config`` with ``changes`` (validated). A sub-config's entry may be a whole
    sub-config or a mapping of its own changes, e.g. ``{"pose_cells": {"nx": 40}}``."""
    subs = subconfigs(type(config))
    names = {f.name for f in dataclasses.fields(config)}  # type: ignore[arg-type]
    updates = {}
    for key, value in changes.items():
        if key not in names:
            raise ConfigError(qualified(config, key), f"unknown field of {type(config).__name__}")
        if key in subs and isinstance(value, Mapping):
            value = replace(getattr(config, key), value)
        updates[key] = value
    return dataclasses.replace(config, **updates)  # type: ignore[type-var]


def from_dict(cls: type[T], data: Mapping[str, Any]) -> T:
    """A config built from nested mappings (the inverse of ``dataclasses.asdict``); missing
    fields take their defaults."""
    names = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    subs = subconfigs(cls)
    values = {}
    for key, value in data.items():
        if key not in names:
            raise ConfigError(qualified(cls, key), f"unknown field of {cls.__name__}")
        values[key] = from_dict(subs[key], value) if key in subs and isinstance(value, Mapping) else value
    return cls(**values)
