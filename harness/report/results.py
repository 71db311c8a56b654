"""Typed results of a run: one :class:`VariantResult` per variant run, one :class:`RunResult` per run.

``metrics.json`` is written from a :class:`RunResult` (:meth:`RunResult.to_json`) and read back
into one (:meth:`RunResult.from_json`); the JSON layout (keys, their order, values) is the run
directory's contract. A quantity a run could not measure is absent from the JSON and ``None``
here (e.g. the accuracy of a replay without ground truth, the experience map's ATE of a run
that made no experience); a measured value may still be NaN (e.g. an ATE over one pose).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar

import numpy as np

from worlds.errors import InputError
from worlds.files import read_json, write_json

T = TypeVar("T")


class ResultsError(InputError):
    """A metrics.json that is not a run's metrics (one line: file, problem)."""


def _omit_none(pairs: dict[str, Any]) -> dict[str, Any]:
    """The pairs whose value is not None (an unmeasured quantity is absent from the JSON)."""
    return {k: v for k, v in pairs.items() if v is not None}


@dataclass(frozen=True)
class PerTrajectory(Generic[T]):
    """One value per trajectory compared with ground truth (None: that trajectory is absent).

    ``odometry`` dead reckoning, ``ratslam_online`` RatSLAM's experience-map pose at every tick,
    ``pose_cell_path`` the pose-cell peak in metres (unwrapped), ``experience_map`` the final map
    (absent without experiences), ``gtsam`` the pose graph's keyframes, ``gtsam_online`` its
    estimate at every tick (both absent when the pose graph did not run); ``ratslam_final`` and
    ``gtsam_final`` every tick as the final map places it (the node its pose hung from, at its
    final pose, composed with the offset from it: ``harness.run.stream.Trace.final_pose``)."""

    odometry: T | None = None
    ratslam_online: T | None = None
    pose_cell_path: T | None = None
    experience_map: T | None = None
    gtsam: T | None = None
    gtsam_online: T | None = None
    ratslam_final: T | None = None
    gtsam_final: T | None = None

    @staticmethod
    def names() -> tuple[str, ...]:
        """The trajectory names, in the JSON's order."""
        return tuple(f.name for f in dataclasses.fields(PerTrajectory))

    def items(self) -> list[tuple[str, T]]:
        """(name, value) of the trajectories present, in the JSON's order."""
        return [(n, v) for n in self.names() if (v := getattr(self, n)) is not None]

    def get(self, name: str) -> T | None:
        """The value of trajectory ``name`` (None if absent); an unknown name is an error."""
        if name not in self.names():
            raise AttributeError(f"unknown trajectory {name!r} (known: {', '.join(self.names())})")
        return getattr(self, name)

    @classmethod
    def from_mapping(cls, values: dict[str, Any], convert=lambda v: v) -> PerTrajectory:
        unknown = set(values) - set(cls.names())
        if unknown:
            raise KeyError(f"unknown trajectories {sorted(unknown)}")
        return cls(**{k: convert(v) for k, v in values.items()})


@dataclass(frozen=True)
class RelativeError:
    """RPE of one trajectory over a fixed distance travelled."""

    translation_m: float
    rotation_deg: float

    def to_json(self) -> dict[str, Any]:
        return {"translation_m": self.translation_m, "rotation_deg": self.rotation_deg}


@dataclass(frozen=True)
class Rpe:
    """Relative pose error over ``distance_m`` of travel, per online trajectory."""

    distance_m: float
    errors: PerTrajectory[RelativeError]

    def to_json(self) -> dict[str, Any]:
        return {"distance_m": self.distance_m, **{n: e.to_json() for n, e in self.errors.items()}}

    @classmethod
    def from_json(cls, doc: dict[str, Any]) -> Rpe:
        rest = {k: v for k, v in doc.items() if k != "distance_m"}
        return cls(doc["distance_m"], PerTrajectory.from_mapping(rest, lambda e: RelativeError(**e)))


@dataclass(frozen=True)
class LoopClosureQuality:
    """The pose graph's loop closures judged against ground truth: a closure is true if its
    keyframes were within ``true_distance_m`` in truth (None when nothing was proposed);
    precision and recall are None where undefined."""

    proposed: int
    accepted: int
    true: int
    precision: float | None
    recall: float | None
    true_distance_m: float | None = None

    def to_json(self) -> dict[str, Any]:
        out = dataclasses.asdict(self)
        if self.true_distance_m is None:
            del out["true_distance_m"]
        return out


@dataclass(frozen=True)
class Timing:
    """Wall-clock seconds per system (and for the recording and bookkeeping around them), and
    the resulting speeds against the stream's duration (None when a system did not run)."""

    ratslam_s: float
    gtsam_s: float
    recording_and_bookkeeping_s: float
    ratslam_realtime_factor: float | None
    ratslam_steps_per_s: float | None
    gtsam_realtime_factor: float | None
    gtsam_steps_per_s: float | None

    def to_json(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class VariantConfig:
    """The effective configurations of a variant run (field values of ``RatSLAMConfig`` and
    ``PoseGraphConfig``) and, for a figure's variant, where its bias went."""

    ratslam: dict[str, Any]
    gtsam: dict[str, Any]
    odometric_bias_deg_s: float | None = None
    pi_bias_deg_s: float | None = None
    wheel_errors: dict[str, float] | None = None  # systematic odometry errors added to the world's

    def to_json(self) -> dict[str, Any]:
        return _omit_none(dataclasses.asdict(self))


# The JSON's key order: with ground truth (evaluated) and without (summarised).
_EVALUATED_ORDER = (
    "ticks",
    "simulated_s",
    "ate",
    "alignment_yaw_deg",
    "rpe",
    "snaps",
    "experiences",
    "links",
    "multiple_representations",
    "hash_collisions",
    "timing",
    "loop_closure",
    "keyframes",
    "isam2_recoveries",
    "closures_dropped",
)
_SUMMARY_ORDER = (
    "ticks",
    "simulated_s",
    "snaps",
    "experiences",
    "links",
    "keyframes",
    "loop_closures_proposed",
    "isam2_recoveries",
    "closures_dropped",
    "timing",
)


@dataclass(frozen=True)
class VariantResult:
    """Every metric of one variant's run (one stream through both systems).

    Accuracy (``ate``, ``alignment_yaw_deg``, ``rpe``, ``multiple_representations``,
    ``hash_collisions``, ``loop_closure``) needs ground truth: None without it, where
    ``loop_closures_proposed`` counts the pose graph's closures instead. ``extras`` holds a
    figure's own metrics (:attr:`harness.figures.registry.Figure.extra_metrics`), JSON-ready."""

    ticks: int
    simulated_s: float
    snaps: int
    experiences: int
    links: int
    timing: Timing
    ate: PerTrajectory[float] | None = None  # m, after SE(2) alignment
    alignment_yaw_deg: PerTrajectory[float] | None = None
    rpe: Rpe | None = None
    multiple_representations: int | None = None
    hash_collisions: int | None = None
    loop_closure: LoopClosureQuality | None = None
    keyframes: int | None = None
    loop_closures_proposed: int | None = None
    isam2_recoveries: int | None = None
    closures_dropped: int | None = None
    config: VariantConfig | None = None
    derived_scale: str | None = None  # what was derived from the log's scale, if anything
    extras: dict[str, Any] = field(default_factory=dict)

    @property
    def has_ground_truth(self) -> bool:
        return self.ate is not None

    def to_json(self) -> dict[str, Any]:
        """The variant's entry of ``metrics.json``."""
        values: dict[str, Any] = {
            "ticks": self.ticks,
            "simulated_s": self.simulated_s,
            "ate": None if self.ate is None else dict(self.ate.items()),
            "alignment_yaw_deg": None if self.alignment_yaw_deg is None else dict(self.alignment_yaw_deg.items()),
            "rpe": None if self.rpe is None else self.rpe.to_json(),
            "snaps": self.snaps,
            "experiences": self.experiences,
            "links": self.links,
            "multiple_representations": self.multiple_representations,
            "hash_collisions": self.hash_collisions,
            "timing": self.timing.to_json(),
            "loop_closure": None if self.loop_closure is None else self.loop_closure.to_json(),
            "keyframes": self.keyframes,
            "loop_closures_proposed": self.loop_closures_proposed,
            "isam2_recoveries": self.isam2_recoveries,
            "closures_dropped": self.closures_dropped,
        }
        order = _EVALUATED_ORDER if self.has_ground_truth else _SUMMARY_ORDER
        out = _omit_none({k: values[k] for k in order})
        out.update(
            _omit_none(
                {"config": None if self.config is None else self.config.to_json(), "derived_scale": self.derived_scale}
            )
        )
        clash = set(self.extras) & (set(values) | {"config", "derived_scale"})
        if clash:
            raise ValueError(f"extra metrics {sorted(clash)} would overwrite the standard ones")
        out.update(self.extras)
        return out

    @classmethod
    def from_json(cls, doc: dict[str, Any]) -> VariantResult:
        """A variant's entry of ``metrics.json`` (keys other than the standard ones are extras)."""
        doc = dict(doc)

        def pop(key: str, convert=lambda v: v):
            return convert(doc.pop(key)) if key in doc else None

        kwargs = dict(
            ticks=doc.pop("ticks"),
            simulated_s=doc.pop("simulated_s"),
            snaps=doc.pop("snaps"),
            experiences=doc.pop("experiences"),
            links=doc.pop("links"),
            timing=Timing(**doc.pop("timing")),
            ate=pop("ate", PerTrajectory.from_mapping),
            alignment_yaw_deg=pop("alignment_yaw_deg", PerTrajectory.from_mapping),
            rpe=pop("rpe", Rpe.from_json),
            multiple_representations=pop("multiple_representations"),
            hash_collisions=pop("hash_collisions"),
            loop_closure=pop("loop_closure", lambda d: LoopClosureQuality(**d)),
            keyframes=pop("keyframes"),
            loop_closures_proposed=pop("loop_closures_proposed"),
            isam2_recoveries=pop("isam2_recoveries"),
            closures_dropped=pop("closures_dropped"),
            config=pop("config", lambda d: VariantConfig(**d)),
            derived_scale=pop("derived_scale"),
        )
        return cls(**kwargs, extras=doc)


@dataclass(frozen=True)
class FigureInfo:
    """The registered figure a run reproduces."""

    name: str
    title: str
    notes: str = ""


@dataclass(frozen=True)
class WorldSource:
    """The simulated world a figure ran in (``lap_length_m``: mean lap of a lap world, else None)."""

    name: str
    file: str
    lap_length_m: float | None = None


@dataclass(frozen=True)
class ClaimResult:
    """A paper claim checked on the run: the statement, what was measured, whether it held."""

    key: str
    statement: str
    measured: str
    held: bool


@dataclass(frozen=True)
class RunResult:
    """Everything ``metrics.json`` holds about one run: a figure's (its source: a simulated
    ``world`` or a ``real_log``; seed, false-positive rate, variants, claims) or a replay's
    (``figure`` None; ``title`` and ``log`` name it). ``extras`` repeats the primary variant's
    figure-specific metrics at the top level; ``provenance`` is free-form
    (:func:`harness.run.directory.provenance`). ``published``: the same run with RatSLAM as published
    (:meth:`ratslam.RatSLAMConfig.published`) on the same streams, its variants' metrics (the
    pose graph's are the same run's) and its claims; None when it was not run."""

    figure: FigureInfo | None
    variants: dict[str, VariantResult]
    duration_s: float | None
    provenance: dict[str, Any] = field(default_factory=dict)
    world: WorldSource | None = None
    real_log: str | None = None
    seed: int | None = None
    fp_rate: float | None = None
    variant_labels: dict[str, str] | None = None
    extras: dict[str, Any] = field(default_factory=dict)
    claims: list[ClaimResult] | None = None
    title: str | None = None  # a replay's
    log: str | None = None  # a replay's observation log
    published: RunResult | None = None  # the same streams with RatSLAM as published (its own claims)
    trajectory_sha256: dict[str, str] | None = None  # the run's TUM files (regenerated, not kept)

    @property
    def primary(self) -> VariantResult:
        """The first variant: the figure's own run (a replay's only one)."""
        return next(iter(self.variants.values()))

    def variant(self, name: str) -> VariantResult:
        """The variant run ``name``; an unknown name is an error naming the known ones."""
        try:
            return self.variants[name]
        except KeyError:
            raise KeyError(f"no variant {name!r} in this run (ran: {', '.join(self.variants)})") from None

    def label(self, name: str) -> str:
        """A variant's label (its name when the run has none)."""
        return (self.variant_labels or {}).get(name, name)

    def to_json(self) -> dict[str, Any]:
        """The ``metrics.json`` document."""
        out: dict[str, Any] = {"figure": None if self.figure is None else dataclasses.asdict(self.figure)}
        out.update(
            _omit_none(
                {
                    "title": self.title,
                    "log": self.log,
                    "world": None if self.world is None else dataclasses.asdict(self.world),
                    "real_log": self.real_log,
                    "duration_s": self.duration_s,
                    "seed": self.seed,
                    "fp_rate": self.fp_rate,
                    "variant_labels": self.variant_labels,
                }
            )
        )
        out["variants"] = {name: v.to_json() for name, v in self.variants.items()}
        out.update(self.extras)
        if self.claims is not None:
            out["claims"] = [dataclasses.asdict(c) for c in self.claims]
        if self.published is not None:
            out["published"] = self.published._alternative_json()
        if self.trajectory_sha256 is not None:
            out["trajectory_sha256"] = self.trajectory_sha256
        out["provenance"] = self.provenance
        return out

    def _alternative_json(self) -> dict[str, Any]:
        """What an alternative RatSLAM's run adds to its parent's document: variants, extras, claims."""
        out: dict[str, Any] = {"variants": {name: v.to_json() for name, v in self.variants.items()}}
        out.update(self.extras)
        if self.claims is not None:
            out["claims"] = [dataclasses.asdict(c) for c in self.claims]
        return out

    def write(self, path) -> Path:
        """Write ``metrics.json`` at ``path`` (atomically). A value that is not a finite number
        (an infinity or NaN: not JSON) is written as null, and ``non_finite`` says which and why."""
        values: dict[str, str] = {}
        doc = _finite_json(self.to_json(), "", values)
        if values:
            doc["non_finite"] = {
                "reason": "not a finite number (an infinity or NaN is not JSON), written as null",
                "values": values,
            }
        return write_json(path, doc)

    @classmethod
    def from_dict(cls, doc: dict[str, Any]) -> RunResult:
        """A parsed ``metrics.json`` document."""
        doc = dict(doc)
        doc.pop("non_finite", None)  # which values are null for being non-finite (see write)
        figure, world = doc.pop("figure"), doc.pop("world", None)
        claims = doc.pop("claims", None)
        published = doc.pop("published", None)
        checksums = doc.pop("trajectory_sha256", None)
        run = cls(
            figure=None if figure is None else FigureInfo(**figure),
            variants={name: VariantResult.from_json(v) for name, v in doc.pop("variants").items()},
            duration_s=doc.pop("duration_s", None),
            provenance=doc.pop("provenance", {}),
            world=None if world is None else WorldSource(**world),
            real_log=doc.pop("real_log", None),
            seed=doc.pop("seed", None),
            fp_rate=doc.pop("fp_rate", None),
            variant_labels=doc.pop("variant_labels", None),
            claims=None if claims is None else [ClaimResult(**c) for c in claims],
            title=doc.pop("title", None),
            log=doc.pop("log", None),
            extras=doc,
            trajectory_sha256=checksums,
        )
        if published is None:
            return run
        published = dict(published)
        alt_claims = published.pop("claims", None)
        alternative = dataclasses.replace(
            run,
            variants={name: VariantResult.from_json(v) for name, v in published.pop("variants").items()},
            claims=None if alt_claims is None else [ClaimResult(**c) for c in alt_claims],
            extras=published,
        )
        return dataclasses.replace(run, published=alternative)

    @classmethod
    def from_json(cls, path) -> RunResult:
        """Read ``metrics.json`` at ``path``; a file that is not a run's metrics is a one-line
        :class:`ResultsError`."""
        try:
            doc = read_json(path)
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
            raise ResultsError(f"{path}: cannot be read as JSON ({e})") from None
        if not isinstance(doc, dict):
            raise ResultsError(f"{path}: not a run's metrics (expected a JSON object)")
        try:
            return cls.from_dict(doc)
        except (KeyError, TypeError, AttributeError) as e:  # a missing, unknown or mistyped entry
            raise ResultsError(f"{path}: not a run's metrics ({type(e).__name__}: {e})") from None


def _finite_json(value, where: str, non_finite: dict[str, str]):
    """``value`` with every non-finite float replaced by None, its dotted path and value noted in
    ``non_finite``."""
    if isinstance(value, dict):
        return {k: _finite_json(v, f"{where}.{k}" if where else str(k), non_finite) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_json(v, f"{where}[{i}]", non_finite) for i, v in enumerate(value)]
    if isinstance(value, np.ndarray):
        return _finite_json(value.tolist(), where, non_finite)
    if isinstance(value, (float, np.floating)) and not math.isfinite(value):
        non_finite[where] = repr(float(value))
        return None
    return value
