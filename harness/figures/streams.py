"""A figure's variants run by stream and by system: each distinct (stream, system, configuration)
is computed once.

Variants whose streams are the same (the same world, odometry and seed: :func:`stream_key`) share
one simulated stream, and on it every distinct system configuration (the variants' RatSLAMs, their
pose graphs, RatSLAM as published) is stepped once (:func:`distinct_systems`). The systems a
recording watches, each variant's RatSLAM and pose graph, step together in one job with the
variants' recorders; when the jobs run in parallel, the RatSLAMs run beside them (e.g. as
published) are jobs of their own, so that the cores share the work system by system rather than
variant by variant. A stream from the camera is not split: rendering and matching it again would
cost more than its systems. Within a job, RatSLAMs configured alike in their front end (the
yaw-rate search, view cells and pose cells: variants that differ only in the map) compute it once
(:func:`harness.run.stream.step_stream`). Each variant's run directory is then written from its systems' traces
(:func:`harness.figures.stream_run.finish_stream`). Every system is deterministic and independent of those
stepped beside it, so the output is the same however the jobs are split or scheduled, bit for bit
(timings aside).
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import pickle
import tempfile
import time
from collections.abc import Sequence
from concurrent.futures import Future, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from baselines import PoseGraphConfig, PoseGraphSLAM
from ratslam import RatSLAM, RatSLAMConfig
from worlds import ObservationLog, World, simulate
from worlds.files import atomic_open
from worlds.odometry_model import PLAZA_WHEEL_ERRORS

from ..report.results import VariantConfig, VariantResult
from ..report.run_report import variant_panels
from ..run.conditions import condition_world
from ..run.config_file import ConfigOverrides
from ..run.runner import GTSAM, RATSLAM, PoseGraphMap, StreamResult, dead_reckon
from ..run.scale import derive_configs
from ..run.stream import Trace, step_stream
from ..run.workers import fork_context, pool, sigint_blocked, terminate, warm_kernels
from .registry import Figure, Variant, figure_configs, get_figure
from .stream_run import (
    RatSLAMChoice,
    RecorderFactory,
    alternative_names,
    finish_stream,
    progress_bar,
    ratslam_settings,
    write_configs,
)

if TYPE_CHECKING:
    from ..camera.stream import CameraViews


# --- a variant's stream and configurations -----------------------------------------------------


def variant_configs(fig: Figure, variant: Variant, log: ObservationLog) -> tuple[RatSLAMConfig, PoseGraphConfig, str]:
    """The variant's configurations (and what was derived, if anything): the figure's and the
    variant's (:func:`harness.figures.registry.figure_configs`), or those derived from the log's scale on
    top of them."""
    rs, pg = figure_configs(fig, variant)
    if variant.derived:
        return derive_configs(log, rs, pg)
    return rs, pg, ""


def stream_key(variant: Variant) -> tuple:
    """What of a variant shapes its stream (the rest configures its systems): its conditions
    (:meth:`harness.figures.registry.Variant.conditions`). Variants with equal keys share a stream."""
    return tuple(sorted(variant.conditions().items()))


def variant_world(fig: Figure, world: World | None, variant: Variant) -> World | None:
    """The world a variant runs in: as loaded, under the variant's conditions and the figure's
    false-positive rate (:func:`harness.run.conditions.condition_world`); None for a real data set."""
    if world is None:
        return world
    return condition_world(world, {"fp_rate": fig.fp_rate, **variant.conditions()})


def variant_log(fig: Figure, world: World | None, duration: float | None, seed: int) -> ObservationLog:
    """The observation stream of a variant: simulated in its world (:func:`variant_world`), or the
    figure's real data set (scene numbers synthesised from its ground truth with ``seed``)."""
    if world is None:
        from worlds.real_data import load_plaza

        assert fig.real_log is not None
        return load_plaza(fig.real_log, seed=seed, fp_rate=fig.fp_rate, duration=duration)
    return simulate(world, duration=duration, seed=seed)


def scene_cell_size(world: World | None) -> float:
    """Side (m) of the scene cells a figure's scene numbers come from (the Plaza model's for a
    real data set)."""
    if world is not None:
        return world.scenes.cell_size
    from worlds.real_data import PLAZA_SCENES

    return PLAZA_SCENES.cell_size


def lap_length(world: World, gt: np.ndarray) -> float | None:
    """Mean lap length of a lap world's run: distance driven over laps around the tour's centre."""
    if world.route_mode != "lap":
        return None
    centre = np.mean([world.nodes[n] for n in world.tour[:-1]], axis=0)
    angle = np.unwrap(np.arctan2(gt[:, 1] - centre[1], gt[:, 0] - centre[0]))
    laps = abs(angle[-1] - angle[0]) / (2 * math.pi)
    dist = float(np.hypot(np.diff(gt[:, 0]), np.diff(gt[:, 1])).sum())
    return dist / laps if laps >= 1 else None


@dataclass(frozen=True)
class RunOptions:
    """What every variant of one figure run shares (see :func:`harness.figures.run.run_figure`)."""

    world: World | None
    duration: float | None
    seed: int
    show_progress: bool
    recorder_factory: RecorderFactory | None
    config: ConfigOverrides | None
    ratslam: RatSLAMChoice
    camera: str | None
    redraw: bool | None  # None: the bar decides; False in parallel workers (their bars would clash)


@dataclass(frozen=True)
class VariantSetup:
    """A variant ready to step: its run directory, the run's RatSLAM and pose-graph
    configurations, the RatSLAMs run beside them (name -> configuration) and the derivation text
    of each (key "" for the run's own)."""

    variant: Variant
    run_dir: Path
    ratslam: RatSLAMConfig
    gtsam: PoseGraphConfig
    alternatives: dict[str, RatSLAMConfig]
    derivations: dict[str, str]

    def roles(self) -> dict[str, RatSLAMConfig | PoseGraphConfig]:
        """Each system the variant reads, by its role: ``ratslam``, ``gtsam`` and the alternatives' names."""
        return {RATSLAM: self.ratslam, GTSAM: self.gtsam, **self.alternatives}


@dataclass
class SharedStream:
    """One stream and the variants run on it: the world it was simulated in (None for a real data
    set), the observation log the systems see, a camera stream's views (for the recordings) and
    each variant's set-up."""

    world: World | None
    log: ObservationLog
    views: CameraViews | None
    setups: list[VariantSetup]


Member = tuple[Variant, Path]
"""A variant of a stream and its run directory."""


def setup_stream(
    fig: Figure, members: Sequence[Member], options: RunOptions, scene_log: ObservationLog | None = None
) -> SharedStream:
    """The stream of ``members`` (variants with one :func:`stream_key`) simulated once (or
    ``scene_log``, the same stream simulated by another job), and each member's configurations on
    it: the figure's and the variant's, the camera's settings if the systems see the camera, a
    configuration file's values on top, and the RatSLAMs that ``options.ratslam`` runs beside the
    run's own."""
    world = variant_world(fig, options.world, members[0][0])
    if scene_log is None:
        scene_log = variant_log(fig, world, options.duration, options.seed)
    log, views, view = scene_log, None, None
    setups = []
    for variant, run_dir in members:
        rs, pg, derivation = variant_configs(fig, variant, scene_log)
        if options.camera is not None:
            from ..camera.stream import camera_view_config

            rs = rs.replace(view=camera_view_config(options.camera))
        if options.config is not None:
            rs, pg = options.config.apply(rs, pg)
        if options.camera is not None and world is not None:  # the scene numbers replaced by the camera's views
            from ..camera.stream import camera_configs, camera_views

            if view is None:  # rendered and matched once for the stream's variants
                view = rs.view
                log, views = camera_views(world, scene_log, options.camera, options.seed, view)
            assert rs.view == view, "the variants of one stream share the camera's matcher settings"
            rs, pg, camera_derivation = camera_configs(log, rs.view, rs, pg)
            if options.config is not None:  # a configuration file's values still have the last word
                rs, pg = options.config.apply(rs, pg)
            derivation = (derivation + "\n" if derivation else "") + camera_derivation
        rs, alternatives, derivations = ratslam_settings(rs, options.ratslam, derivation)
        setups.append(VariantSetup(variant, run_dir, rs, pg, alternatives, derivations))
    return SharedStream(world, log, views, setups)


# --- systems and jobs --------------------------------------------------------------------------


def distinct_systems(
    setups: Sequence[VariantSetup], roles: Sequence[str] | None = None
) -> tuple[dict[str, RatSLAMConfig | PoseGraphConfig], list[dict[str, str]]]:
    """Every distinct configuration among the set-ups' systems (of the given ``roles`` only, if
    given) under a key of its own, and for each set-up its roles' keys: two variants whose pose
    graphs (or RatSLAMs) are configured alike read one system."""
    configs: dict[str, RatSLAMConfig | PoseGraphConfig] = {}
    keys = []
    for setup in setups:
        mine = {}
        for role, config in setup.roles().items():
            if roles is not None and role not in roles:
                continue
            key = next((k for k, c in configs.items() if type(c) is type(config) and c == config), None)
            if key is None:
                key = f"{GTSAM if isinstance(config, PoseGraphConfig) else RATSLAM}_{len(configs)}"
                configs[key] = config
            mine[role] = key
        keys.append(mine)
    return configs, keys


def _system(config: RatSLAMConfig | PoseGraphConfig) -> RatSLAM | PoseGraphSLAM:
    return PoseGraphSLAM(config) if isinstance(config, PoseGraphConfig) else RatSLAM(config)


@dataclass(frozen=True)
class StreamJob:
    """Systems of one stream to step in one process: the figure (by name: its claims are closures,
    which do not pickle), the stream's members, the run's options, the roles whose systems it steps
    (None: all) and whether it records (the members' RatSLAMs and pose graphs, watched by their
    recorders; this job also hands back the stream for the variants' outputs)."""

    figure: str
    members: tuple[Member, ...]
    options: RunOptions
    roles: tuple[str, ...] | None
    recorded: bool
    handoff: Path | None = None  # where the recording job leaves the stream for the stream's other jobs


@dataclass
class JobResult:
    """A job's traces, for each member by role (pose graphs as :class:`PoseGraphMap`), the seconds
    its pass spent outside the systems (recording and bookkeeping) and, from a recording job, the
    stream with its lap length and the distance within which a closure is true."""

    traces: list[dict[str, Trace]]
    other_s: float
    stream: SharedStream | None = None
    lap_length_m: float | None = None
    closure_true_distance: float = math.nan


def step_job(job: StreamJob) -> JobResult:
    """Step the job's systems through its stream, each distinct configuration once, with a
    recorder per member if the job records and the run records."""
    fig, options = get_figure(job.figure), job.options
    received = None if job.recorded or job.handoff is None else _received(job.handoff)
    stream = setup_stream(fig, job.members, options, received)
    if job.recorded and job.handoff is not None:
        with atomic_open(job.handoff, "wb") as f:
            pickle.dump(stream.log, f, protocol=pickle.HIGHEST_PROTOCOL)
    configs, keys = distinct_systems(stream.setups, job.roles)
    systems = {key: _system(config) for key, config in configs.items()}
    names = "+".join(v.name for v, _ in job.members)
    label = f"{fig.name}/{names}" + ("" if job.recorded else f" ({', '.join(job.roles or ())})")
    with contextlib.ExitStack() as stack:
        watched: list[tuple[Any, str, str]] = []
        if job.recorded and options.recorder_factory is not None:
            odometry = dead_reckon(stream.log)
            shown = {} if stream.views is None else {"camera": stream.views}
            for setup, mine in zip(stream.setups, keys):
                recorder = options.recorder_factory(
                    setup.run_dir, stream.world, stream.log, setup.ratslam, odometry, **shown
                )
                watched.append((stack.enter_context(recorder), mine[RATSLAM], mine[GTSAM]))

        def on_tick(k: int, stepped) -> None:
            for recorder, rs_key, pg_key in watched:
                recorder.on_tick(k, stepped[rs_key], stepped[pg_key])

        progress = progress_bar(stream.log, label, options.show_progress, options.redraw)
        traces, other_s = step_stream(stream.log, systems, on_tick=on_tick if watched else None, progress=progress)
    for trace in traces.values():  # iSAM2 does not pickle: the pose graph's final map goes back
        if isinstance(trace.system, PoseGraphSLAM):
            trace.system = PoseGraphMap.of(trace.system)
    result = JobResult([{role: traces[key] for role, key in mine.items()} for mine in keys], other_s)
    if job.recorded:
        world = stream.world
        result.stream = dataclasses.replace(stream, world=None, views=None)  # what the outputs need
        result.lap_length_m = lap_length(world, stream.log.ground_truth()) if world is not None else None
        result.closure_true_distance = 1.5 * scene_cell_size(world)
    return result


def _received(handoff: Path) -> ObservationLog:
    """The stream a recording job left at ``handoff``: it started before this job (jobs start in
    their order, recording jobs first), and simulates its stream first thing. If it fails, the
    run stops every worker, this one too."""
    while not handoff.exists():
        time.sleep(0.02)
    with open(handoff, "rb") as f:
        return pickle.load(f)


def plan_jobs(
    fig: Figure, members: Sequence[Member], options: RunOptions, split: bool, handoffs: Path | None = None
) -> list[StreamJob]:
    """The jobs of a figure run: per stream, one job recording its members' RatSLAMs and pose
    graphs and, if ``split`` (parallel workers, scene numbers), one job per RatSLAM run beside
    them, which takes the stream the recording job simulated (left in the folder ``handoffs``);
    otherwise one job steps all of a stream's systems. A run without a recording splits the pose
    graphs off into jobs of their own too (nothing watches the two systems tick by tick). The
    stream's own jobs come first (the others wait for their streams), then the side jobs role by
    role, the pose graphs (the longest) first, so that the shorter jobs fill in around them."""
    streams: dict[tuple, list[Member]] = {}
    for variant, run_dir in members:
        streams.setdefault(stream_key(variant), []).append((variant, run_dir))
    split = split and options.camera is None
    own: tuple[str, ...] | None = (RATSLAM, GTSAM) if split else None
    side = alternative_names(options.ratslam) if split else ()
    if split and options.recorder_factory is None:
        own, side = (RATSLAM,), (GTSAM, *side)
    handoff = [None if not side or handoffs is None else handoffs / f"stream{i}.pickle" for i in range(len(streams))]
    recording = [StreamJob(fig.name, tuple(m), options, own, True, handoff[i]) for i, m in enumerate(streams.values())]
    return recording + [
        StreamJob(fig.name, tuple(m), options, (name,), False, handoff[i])
        for name in side
        for i, m in enumerate(streams.values())
    ]


@dataclass(frozen=True)
class VariantRun:
    """What one variant's run hands back to its figure: its metrics, the mean lap of a lap
    world's run (None otherwise), the duration of its stream, and the metrics of the other
    RatSLAM configurations run beside it (e.g. ``published``)."""

    result: VariantResult
    lap_length_m: float | None
    duration_s: float
    alternatives: dict[str, VariantResult] = dataclasses.field(default_factory=dict)
    panels: list[Path] = dataclasses.field(default_factory=list)  # its report's PNG panels


@dataclass(frozen=True)
class VariantOutput:
    """One variant's stepped systems, ready to write: the figure's name, the variant's set-up on
    its stream, the stream's log, its traces by role, and what its recording job measured."""

    figure: str
    setup: VariantSetup
    log: ObservationLog
    traces: dict[str, Trace]
    other_s: float
    lap_length_m: float | None
    closure_true_distance: float
    seed: int
    world: World | None = None  # the figure's world, for the panels


def write_variant(out: VariantOutput) -> VariantRun:
    """A variant's run directory from its systems' traces: its configuration files, TUM
    trajectories, maps.npz, metrics (:func:`harness.figures.stream_run.finish_stream`) and report
    panels (:func:`harness.report.run_report.variant_panels`)."""
    fig, setup, log = get_figure(out.figure), out.setup, out.log
    variant, derivation = setup.variant, setup.derivations[""]
    write_configs(
        setup.run_dir,
        setup.ratslam,
        setup.gtsam,
        setup.alternatives,
        f"Effective configuration of {fig.name}, variant {variant.name} (seed {out.seed}).\n"
        + (f"{derivation}\n" if derivation else "")
        + "Reproduce on its log: ratslam-harness replay LOG.csv --config config.toml",
    )
    res = StreamResult.from_traces(
        log,
        dead_reckon(log),
        out.traces[RATSLAM],
        out.traces[GTSAM],
        {name: out.traces[name] for name in setup.alternatives},
        out.other_s,
    )
    result, alt_results = finish_stream(
        setup.run_dir,
        log,
        res,
        setup.ratslam,
        setup.alternatives,
        out.closure_true_distance,
        fig.extra_metrics,
    )

    def recorded(r: VariantResult, cfg: RatSLAMConfig, name: str = "") -> VariantResult:
        return dataclasses.replace(
            r,
            config=VariantConfig(
                ratslam=dataclasses.asdict(cfg),
                gtsam=dataclasses.asdict(setup.gtsam),
                odometric_bias_deg_s=variant.odometric_bias,
                pi_bias_deg_s=cfg.pose_cells.path_integration_bias_deg_s,
                wheel_errors=dict(PLAZA_WHEEL_ERRORS) if variant.wheel_errors else None,
            ),
            derived_scale=setup.derivations[name] or None,
        )

    return VariantRun(
        recorded(result, setup.ratslam),
        out.lap_length_m,
        log.duration,
        {name: recorded(r, setup.alternatives[name], name) for name, r in alt_results.items()},
        variant_panels(setup.run_dir, out.world),
    )


def run_variants(fig: Figure, members: Sequence[Member], options: RunOptions, workers: int) -> list[VariantRun]:
    """Every member variant of ``fig`` stepped (:func:`plan_jobs`, on ``workers`` processes) and
    written into its run directory with its panels (:func:`write_variant`), each as soon as all
    its systems have run; their runs in the members' order."""
    with tempfile.TemporaryDirectory(prefix="ratslam-streams-") as handoffs:
        return _run_jobs(fig, members, options, workers, Path(handoffs))


def _run_jobs(
    fig: Figure, members: Sequence[Member], options: RunOptions, workers: int, handoffs: Path
) -> list[VariantRun]:
    """:func:`run_variants` with the streams handed from job to job in the folder ``handoffs``."""
    jobs = plan_jobs(fig, members, options, workers > 1, handoffs)
    if workers < 2 or len(jobs) < 2:
        done = _Assembly(fig, jobs, options)
        for job in jobs:
            done.add(job, step_job(job))
        return [write_variant(done.outputs[v.name]) for v, _ in members]
    warm_kernels()  # compiled once here, inherited by the forked workers
    ex = pool(min(workers, len(jobs)), fork_context())
    try:
        with sigint_blocked():  # the workers start here
            stepping = {ex.submit(step_job, job): job for job in jobs}
        done = _Assembly(fig, jobs, options)
        writing: dict[str, Future] = {}
        for future in as_completed(stepping):
            for name in done.add(stepping[future], future.result()):
                writing[name] = ex.submit(write_variant, done.outputs[name])
        runs = [writing[v.name].result() for v, _ in members]
    except BaseException:
        terminate(ex)
        raise
    ex.shutdown()
    return runs


class _Assembly:
    """The variants' outputs gathered from their jobs' results, in whatever order they finish."""

    def __init__(self, fig: Figure, jobs: Sequence[StreamJob], options: RunOptions):
        self.fig, self.options = fig, options
        self.outputs: dict[str, VariantOutput] = {}
        self._side: dict[str, dict[str, Trace]] = {}  # traces of side jobs finished before the stream's
        self._waiting: dict[str, int] = {}  # jobs still to finish, per variant
        for job in jobs:
            for variant, _ in job.members:
                self._waiting[variant.name] = self._waiting.get(variant.name, 0) + 1

    def add(self, job: StreamJob, result: JobResult) -> list[str]:
        """Take a job's result; returns the variants it completed (every job of theirs done)."""
        if job.recorded:
            assert result.stream is not None
            for setup, traces in zip(result.stream.setups, result.traces):
                name = setup.variant.name
                self.outputs[name] = VariantOutput(
                    self.fig.name,
                    setup,
                    result.stream.log,
                    {**traces, **self._side.pop(name, {})},
                    result.other_s,
                    result.lap_length_m,
                    result.closure_true_distance,
                    self.options.seed,
                    self.options.world,
                )
        else:
            for (variant, _), traces in zip(job.members, result.traces):
                if variant.name in self.outputs:
                    self.outputs[variant.name].traces.update(traces)
                else:
                    self._side.setdefault(variant.name, {}).update(traces)
        complete = []
        for variant, _ in job.members:
            self._waiting[variant.name] -= 1
            if self._waiting[variant.name] == 0:
                complete.append(variant.name)
        return complete
