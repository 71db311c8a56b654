"""Run a paper figure (or replay a user's log) end to end into a run directory.

simulate -> RatSLAM and GTSAM on the same observations -> recording, metrics, TUM files,
maps.npz, report.md and PNG panels, all staged and moved into place when complete. A figure's
variants and a replay take the same path through one stream (:func:`run_single_stream`) and
write their run the same way (:func:`write_run`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from baselines import PoseGraphConfig, YawBiasConfig
from ratslam import PAPER_REENTRIES, PoseCellConfig, RatSLAMConfig
from ratslam.published import departures
from worlds import ObservationLog, World, load_world, simulate
from worlds.errors import InputError
from worlds.files import atomic_open, write_tum
from worlds.odometry_model import PLAZA_WHEEL_ERRORS

from .budget import check_grid, check_ticks
from .config_file import ConfigOverrides, write_config_toml
from .evaluate import CLOSURE_TRUE_DISTANCE, evaluate_stream
from .figures import ExtraMetrics, Figure, FigureError, Variant, evaluate_claims, get_figure
from .progress import Progress
from .report import write_report
from .results import FigureInfo, RunResult, VariantConfig, VariantResult, WorldSource
from .run_dir import provenance, staged_directory
from .runner import StreamResult, TickError, dead_reckon, run_stream
from .scale import derive_configs
from .workers import fork_context, free_cores, map_in_processes, warm_kernels

if TYPE_CHECKING:
    from .camera_stream import CameraViews
    from .recorder import StreamRecorder

RecorderFactory = Callable[[Path, World | None, ObservationLog, RatSLAMConfig, np.ndarray], "StreamRecorder"]
"""``(run directory, world or None, observation log, RatSLAM's configuration) -> StreamRecorder``
(e.g. :func:`harness.recorder.recorder_factory`)."""

REPORTS_DIR = Path("reports")  # the committed reports: regenerated only with an explicit out
RUNS_DIR = Path("runs")  # default output: a fresh, git-ignored folder


def lap_length(world: World, gt: np.ndarray) -> float | None:
    """Mean lap length of a lap world's run: distance driven over laps around the tour's centre."""
    if world.route_mode != "lap":
        return None
    centre = np.mean([world.nodes[n] for n in world.tour[:-1]], axis=0)
    angle = np.unwrap(np.arctan2(gt[:, 1] - centre[1], gt[:, 0] - centre[0]))
    laps = abs(angle[-1] - angle[0]) / (2 * math.pi)
    dist = float(np.hypot(np.diff(gt[:, 0]), np.diff(gt[:, 1])).sum())
    return dist / laps if laps >= 1 else None


def write_stream_outputs(run_dir: Path, log: ObservationLog, res: StreamResult) -> None:
    """TUM trajectories and maps.npz (everything the report's panels need) of one stream."""
    traj = run_dir / "trajectories"
    traj.mkdir(parents=True, exist_ok=True)
    t = log.t
    if log.has_ground_truth:
        write_tum(traj / "ground_truth.tum", t, *log.ground_truth().T)
    write_tum(traj / "odometry.tum", t, *res.odometry.T)
    write_tum(traj / "ratslam.tum", t, *res.ratslam_pose.T)
    write_tum(traj / "gtsam.tum", t, *res.gtsam_pose.T)
    rs, pg = res.ratslam, res.gtsam
    order = np.argsort(rs.experience_first_tick)
    write_tum(traj / "ratslam_experiences.tum", t[rs.experience_first_tick[order]], *rs.experience_poses[order].T)
    if len(pg.keyframe_ticks):
        write_tum(traj / "gtsam_keyframes.tum", t[pg.keyframe_ticks], *pg.keyframe_poses.T)
    maps: dict[str, Any] = {
        "grid_shape": np.array(rs.config.shape),
        "peak_cells": res.peak_cells,
        "snapped": res.snapped,
        "experience_poses": rs.experience_poses,
        "experience_cells": rs.experience_cells,
        "experience_last_tick": rs.experience_last_tick,
        "experience_first_tick": rs.experience_first_tick,
        "links": rs.links,
        "keyframe_poses": pg.keyframe_poses,
        "keyframe_ticks": pg.keyframe_ticks,
        "loop_closures": pg.loop_closures,
        "closure_accepted": np.asarray(pg.closure_accepted, dtype=bool),
    }
    if log.has_ground_truth:  # the panels' references, so that a report is redrawn from maps.npz alone
        maps |= {"false_positive": log.false_positive, "ground_truth": log.ground_truth(), "odometry": res.odometry}
    for name, trace in res.alternatives.items():  # other RatSLAM configurations, e.g. the published one
        alt = trace.system
        write_tum(traj / f"ratslam_{name}.tum", t, *trace.pose.T)
        order = np.argsort(alt.experience_first_tick)
        write_tum(
            traj / f"ratslam_{name}_experiences.tum",
            t[alt.experience_first_tick[order]],
            *alt.experience_poses[order].T,
        )
        maps |= {
            f"{name}_peak_cells": trace.peak_cells,
            f"{name}_snapped": trace.snapped,
            f"{name}_experience_poses": alt.experience_poses,
            f"{name}_experience_first_tick": alt.experience_first_tick,
            f"{name}_links": alt.links,
        }
    with atomic_open(run_dir / "maps.npz", "wb") as f:
        np.savez_compressed(f, **maps)


def _configs(fig: Figure, variant: Variant, log: ObservationLog) -> tuple[RatSLAMConfig, PoseGraphConfig, str]:
    """The variant's configurations (and what was derived, if anything): the figure's grid and
    the variant's biases, on the defaults or on those derived from the log's scale."""
    nx, ny, nth = fig.grid
    rs = RatSLAMConfig(
        pose_cells=PoseCellConfig(nx=nx, ny=ny, n_theta=nth, path_integration_bias_deg_s=variant.pi_bias)
    )
    if variant.reentries == "unfused":  # the paper's re-entry poses, the relocalisation bound kept
        rs = rs.replace(reentry=PAPER_REENTRIES["reentry"])
    elif variant.reentries == "paper":
        rs = rs.replace(**PAPER_REENTRIES)
    pg = PoseGraphConfig(yaw_bias=YawBiasConfig(estimate=variant.gtsam_yaw_bias))
    if variant.derived_scale:
        return derive_configs(log, rs, pg)
    return rs, pg, ""


def _variant_world(world: World | None, variant: Variant) -> World | None:
    """The world a variant runs in: as loaded, with its look-alike regions showing their own scenes
    (and walls, to the camera) if the variant says so, and with the Plaza-calibrated wheel-odometry
    errors if it asks for them."""
    if world is None:
        return world
    if not variant.lookalikes and world.scenes.lookalikes:
        world = dataclasses.replace(world, scenes=dataclasses.replace(world.scenes, lookalikes=()))
    if not variant.lookalikes and world.camera.same_as:  # the camera's look-alike walls too
        world = dataclasses.replace(world, camera=dataclasses.replace(world.camera, same_as=()))
    if variant.wheel_errors:
        world = dataclasses.replace(world, odometry=dataclasses.replace(world.odometry, **PLAZA_WHEEL_ERRORS))
    return world


def _scene_cell_size(fig: Figure, world: World | None) -> float:
    """Side (m) of the scene cells the figure's scene numbers come from."""
    if world is not None:
        return world.scenes.cell_size
    from worlds.real_data import PLAZA_SCENES

    return PLAZA_SCENES.cell_size


def _variant_log(
    fig: Figure, variant: Variant, world: World | None, duration: float | None, seed: int
) -> ObservationLog:
    """The observation stream of a variant: simulated in its world, or the figure's real data set
    (scene numbers synthesised from its ground truth with ``seed``)."""
    if fig.real_log is not None:
        from worlds.real_data import load_plaza

        return load_plaza(fig.real_log, seed=seed, fp_rate=fig.fp_rate, duration=duration)
    return simulate(world, duration=duration, seed=seed, bias_deg_s=variant.odometric_bias, fp_rate=fig.fp_rate)


RatSLAMChoice = Literal["defaults", "published", "both"]
"""Which RatSLAM a run steps: the project's ``defaults``, the paper's algorithm (``published``:
:meth:`ratslam.RatSLAMConfig.published`), or ``both`` on the same stream (the defaults primary)."""

PUBLISHED = "published"


def ratslam_settings(
    rs_cfg: RatSLAMConfig, choice: RatSLAMChoice, derivation: str = ""
) -> tuple[RatSLAMConfig, dict[str, RatSLAMConfig], dict[str, str]]:
    """The run's RatSLAM configuration, the alternatives run beside it, and the derivation text
    of each (key "" for the run's own): for the published preset it also names the values, set
    by the log's derivation or by a configuration file, that the preset's fixed values replace
    (none is overwritten silently)."""
    if choice == "defaults":
        return rs_cfg, {}, {"": derivation}
    published = RatSLAMConfig.published(rs_cfg)
    replaced = [d for d in departures(rs_cfg, inert=False) if d not in departures(RatSLAMConfig(), inert=False)]
    published_derivation = derivation
    if replaced:
        published_derivation = (derivation + "\n" if derivation else "") + (
            "The published preset fixes the paper's values over those derived or given: " + "; ".join(replaced) + "."
        )
    if choice == "published":
        return published, {}, {"": published_derivation}
    return rs_cfg, {PUBLISHED: published}, {"": derivation, PUBLISHED: published_derivation}


def run_single_stream(
    run_dir: Path,
    log: ObservationLog,
    ratslam_config: RatSLAMConfig,
    gtsam_config: PoseGraphConfig,
    *,
    config_header: str,
    progress: Progress,
    world: World | None = None,
    recorder_factory: RecorderFactory | None = None,
    closure_true_distance: float = CLOSURE_TRUE_DISTANCE,
    extra_metrics: ExtraMetrics | None = None,
    alternatives: dict[str, RatSLAMConfig] | None = None,
    camera: CameraViews | None = None,
) -> tuple[VariantResult, dict[str, VariantResult]]:
    """One stream through both systems (and the ``alternatives``: name -> another RatSLAM
    configuration, on the same stream in the same pass) into ``run_dir``: its effective
    ``config.toml`` (headed by ``config_header``), the recording (if a ``recorder_factory`` is
    given; removed if the run fails), the TUM trajectories and maps.npz, and its metrics (with the
    ``extra_metrics`` of a figure that has them; the caller adds the configuration record): the
    run's, and each alternative's measured the same way (the pose graph's metrics are shared).
    ``camera``: a camera stream's views and templates, for the recording."""
    alternatives = alternatives or {}
    write_config_toml(run_dir / "config.toml", ratslam_config, gtsam_config, config_header)
    for name, config in alternatives.items():
        write_config_toml(
            run_dir / f"config_{name}.toml",
            config,
            gtsam_config,
            config_header + f"\nRatSLAM here: the {name!r} configuration run beside it on the same stream.",
        )
    odometry = dead_reckon(log)  # once: the runner and the recorder share it
    shown = {} if camera is None else {"camera": camera}  # a scene-number run's factory call as ever
    recorder = recorder_factory(run_dir, world, log, ratslam_config, odometry, **shown) if recorder_factory else None
    with recorder if recorder is not None else contextlib.nullcontext():
        on_tick = recorder.on_tick if recorder is not None else None
        res = run_stream(
            log,
            ratslam_config,
            gtsam_config,
            on_tick=on_tick,
            progress=progress,
            odometry=odometry,
            alternatives=alternatives,
        )
    write_stream_outputs(run_dir, log, res)

    def measured(stream: StreamResult, config: RatSLAMConfig) -> VariantResult:
        result = evaluate_stream(stream, log, closure_true_distance=closure_true_distance)
        if extra_metrics is not None:
            result = dataclasses.replace(result, extras=extra_metrics(stream, log, config))
        return result

    return measured(res, ratslam_config), {
        name: measured(res.with_ratslam(name), config) for name, config in alternatives.items()
    }


def trajectory_checksums(run_dir: Path) -> dict[str, str]:
    """SHA-256 of every TUM file of a run (its variants' too), by path relative to ``run_dir``: the
    trajectories are regenerated by the run's command, not kept, and these say they came out the same."""
    return {
        f.relative_to(run_dir).as_posix(): hashlib.sha256(f.read_bytes()).hexdigest()
        for f in sorted(run_dir.rglob("*.tum"))
    }


def write_run(run_dir: Path, run: RunResult) -> None:
    """A run's ``metrics.json`` (with its trajectories' checksums) and its report (report.md and
    the PNG panels)."""
    run = dataclasses.replace(run, trajectory_sha256=trajectory_checksums(run_dir))
    run.write(run_dir / "metrics.json")
    write_report(run_dir, run)


def _progress(log: ObservationLog, label: str, show: bool, redraw: bool | None = None) -> Progress:
    return Progress(len(log), label, float(np.median(log.dt)), enabled=show, redraw=redraw)


@dataclass(frozen=True)
class VariantRun:
    """What one variant's run hands back to its figure: its metrics, the mean lap of a lap
    world's run (None otherwise), the duration of its stream, and the metrics of the other
    RatSLAM configurations run beside it (e.g. ``published``)."""

    result: VariantResult
    lap_length_m: float | None
    duration_s: float
    alternatives: dict[str, VariantResult] = dataclasses.field(default_factory=dict)


def _run_variant(
    run_dir: Path,
    fig: Figure,
    variant: Variant,
    world: World | None,
    duration: float | None,
    seed: int,
    show_progress: bool,
    recorder_factory: RecorderFactory | None = None,
    config: ConfigOverrides | None = None,
    redraw: bool | None = None,
    ratslam: RatSLAMChoice = "both",
    camera: str | None = None,
) -> VariantRun:
    world = _variant_world(world, variant)
    log = _variant_log(fig, variant, world, duration, seed)
    rs_cfg, pg_cfg, derivation = _configs(fig, variant, log)
    views = None
    if camera is not None:
        from .camera_stream import camera_view_config

        rs_cfg = rs_cfg.replace(view=camera_view_config(camera))
    if config is not None:
        rs_cfg, pg_cfg = config.apply(rs_cfg, pg_cfg)
    if camera is not None and world is not None:  # the scene numbers replaced by the camera's views
        from .camera_stream import camera_configs, camera_views

        log, views = camera_views(world, log, camera, seed, rs_cfg.view)
        rs_cfg, pg_cfg, camera_derivation = camera_configs(log, rs_cfg.view, rs_cfg, pg_cfg)
        if config is not None:  # a configuration file's values still have the last word
            rs_cfg, pg_cfg = config.apply(rs_cfg, pg_cfg)
        derivation = (derivation + "\n" if derivation else "") + camera_derivation
    rs_cfg, alternatives, derivations = ratslam_settings(rs_cfg, ratslam, derivation)
    derivation = derivations[""]
    result, alt_results = run_single_stream(
        run_dir,
        log,
        rs_cfg,
        pg_cfg,
        config_header=f"Effective configuration of {fig.name}, variant {variant.name} (seed {seed}).\n"
        + (f"{derivation}\n" if derivation else "")
        + "Reproduce on its log: ratslam-harness replay LOG.csv --config config.toml",
        progress=_progress(log, f"{fig.name}/{variant.name}", show_progress, redraw),
        world=world,
        recorder_factory=recorder_factory,
        closure_true_distance=1.5 * _scene_cell_size(fig, world),
        extra_metrics=fig.extra_metrics,
        alternatives=alternatives,
        camera=views,
    )

    def recorded(r: VariantResult, cfg: RatSLAMConfig, name: str = "") -> VariantResult:
        return dataclasses.replace(
            r,
            config=VariantConfig(
                ratslam=dataclasses.asdict(cfg),
                gtsam=dataclasses.asdict(pg_cfg),
                odometric_bias_deg_s=variant.odometric_bias,
                pi_bias_deg_s=variant.pi_bias,
                wheel_errors=dict(PLAZA_WHEEL_ERRORS) if variant.wheel_errors else None,
            ),
            derived_scale=derivations[name] or None,
        )

    lap = lap_length(world, log.ground_truth()) if world is not None else None
    return VariantRun(
        recorded(result, rs_cfg),
        lap,
        log.duration,
        {name: recorded(r, alternatives[name], name) for name, r in alt_results.items()},
    )


def _variant_job(job: tuple[str, Path, Variant, dict[str, Any]]) -> VariantRun:
    """One variant's run from its job: the figure by name (its claims are closures, which do not
    pickle), the variant's directory, the variant, and :func:`_run_variant`'s other arguments."""
    fig_name, run_dir, variant, kwargs = job
    return _run_variant(run_dir, get_figure(fig_name), variant, **kwargs)


def default_workers(n_jobs: int) -> int:
    """Processes for ``n_jobs`` independent runs: one per job, at most one per free core."""
    return max(1, min(n_jobs, free_cores()))


def run_figure(
    name: str,
    out=None,
    seed: int | None = None,
    duration: float | None = None,
    show_progress: bool = True,
    recorder_factory: RecorderFactory | None = None,
    variants: tuple[str, ...] | None = None,
    workers: int | None = None,
    config: ConfigOverrides | None = None,
    ratslam: RatSLAMChoice = "both",
    camera: str | None = None,
) -> Path:
    """Run every variant of figure ``name`` (or only those named in ``variants``; the primary
    always runs) into ``out`` (default ``runs/<name>``, ``runs/<name>_<camera>`` from a camera;
    ``reports/<name>`` regenerates the committed report). ``config`` (from a configuration file) is
    applied on top of each variant's own
    configuration. ``ratslam``: the project's defaults, the published algorithm, or both on each
    variant's stream (the default; the claims are judged for each, the published run's under
    ``published`` in metrics.json). ``camera`` ("forward" or "panoramic"): both systems see the
    simulated camera's views through the view matcher (:mod:`harness.camera_stream`) instead of
    scene numbers.

    The variants are independent runs: with ``workers`` > 1 (default: one process per variant,
    at most one per core) they run in parallel processes; each is deterministic, so the output
    is the same as a sequential run (``workers=1``) bit for bit, timings aside."""
    fig = get_figure(name)
    if variants is not None:
        unknown = set(variants) - {v.name for v in fig.variants}
        if unknown:
            raise FigureError(f"{name}: unknown variant(s) {sorted(unknown)} (known: {[v.name for v in fig.variants]})")
        fig = dataclasses.replace(
            fig, variants=tuple(v for i, v in enumerate(fig.variants) if i == 0 or v.name in variants)
        )
    world = load_world(fig.world) if fig.world is not None else None
    seed = fig.seed if seed is None else int(seed)
    duration = fig.duration if duration is None else float(duration)
    if camera is not None and world is None:
        raise FigureError(f"{name}: a real data set has no simulated world to render (--camera)")
    out = Path(out) if out else RUNS_DIR / (fig.name if camera is None else f"{fig.name}_{camera}")
    workers = default_workers(len(fig.variants)) if workers is None else max(1, int(workers))
    with staged_directory(out, _inputs(config)) as stage:
        parallel = workers > 1 and len(fig.variants) > 1
        shared = dict(
            world=world,
            duration=duration,
            seed=seed,
            show_progress=show_progress,
            recorder_factory=recorder_factory,
            config=config,
            ratslam=ratslam,
            camera=camera,
            redraw=False if parallel else None,  # several bars in parallel workers would clash
        )
        jobs = []
        for i, variant in enumerate(fig.variants):
            vdir = stage if i == 0 else stage / "variants" / variant.name
            vdir.mkdir(parents=True, exist_ok=True)
            jobs.append((fig.name, vdir, variant, shared))
        if parallel:
            warm_kernels()  # compiled once here, inherited by the forked workers
            runs = map_in_processes(_variant_job, jobs, min(workers, len(jobs)), fork_context())
        else:
            runs = [_variant_job(job) for job in jobs]
        primary = runs[0]
        run = RunResult(
            figure=FigureInfo(
                name=fig.name,
                title=fig.title if camera is None else f"{fig.title}, from the {camera} camera",
                notes=fig.notes,
            ),
            world=None if world is None else WorldSource(world.name, str(world.path), primary.lap_length_m),
            real_log=fig.real_log if world is None else None,
            duration_s=primary.duration_s if duration is None else duration,
            seed=seed,
            fp_rate=fig.fp_rate,
            variant_labels={v.name: v.label for v in fig.variants},
            variants={v.name: r.result for v, r in zip(fig.variants, runs)},
            extras=primary.result.extras,
        )
        published = None
        if ratslam == "both":
            published = dataclasses.replace(
                run,
                variants={v.name: r.alternatives[PUBLISHED] for v, r in zip(fig.variants, runs)},
                extras=primary.alternatives[PUBLISHED].extras,
            )
            published = dataclasses.replace(published, claims=evaluate_claims(fig, published))
        run = dataclasses.replace(
            run,
            claims=evaluate_claims(fig, run),
            provenance=provenance(figure=fig.name, seed=seed, duration_s=duration, ratslam=ratslam)
            if camera is None
            else provenance(figure=fig.name, seed=seed, duration_s=duration, ratslam=ratslam, camera=camera),
            published=published,
        )
        write_run(stage, run)
    return out


@contextlib.contextmanager
def _named(log_path):
    """A tick the systems refuse, reported with the log's file name and line."""
    try:
        yield
    except TickError as e:
        raise InputError(f"{log_path}: line {e.tick + 2}: {e.problem}") from None


def _inputs(config: ConfigOverrides | None) -> tuple[Path, ...]:
    """The configuration file a run reads, if any (its output must not replace it)."""
    return (Path(config.source),) if config is not None and config.source else ()


def _camera_log_view(log, log_path, ratslam_config, gtsam_config, config, fov_deg):
    """The matcher's settings for a camera log: the caller's or the configuration file's view,
    with what neither gives derived from the log (a caller's ``ratslam_config`` gives every field)."""
    from .camera_stream import log_camera_view

    rs = ratslam_config or RatSLAMConfig()
    given: set[str] = set()
    if ratslam_config is not None:
        given = {f.name for f in dataclasses.fields(rs.view)}
    if config is not None:
        rs, _ = config.apply(rs, gtsam_config or PoseGraphConfig())
        given |= set(config.ratslam.get("view", {}))
    return log_camera_view(log, log_path, rs.view, given, fov_deg)


def replay(
    log_path,
    out,
    show_progress: bool = True,
    recorder_factory: RecorderFactory | None = None,
    ratslam_config: RatSLAMConfig | None = None,
    gtsam_config: PoseGraphConfig | None = None,
    config: ConfigOverrides | None = None,
    ratslam: RatSLAMChoice = "defaults",
    yes: bool = False,
    fov_deg: float | None = None,
) -> Path:
    """Replay a user's observation log through both systems into run directory ``out``
    (``config``, from a configuration file, on top of the given configurations or, where none is
    given, of those :func:`harness.scale.derive_configs` derives from the log's speed, tick rate
    and labels; the simulator's own streams get exactly the defaults). A camera log's images are
    matched first (the effective ``view`` settings, those not given derived from the images and
    the field of view from ``fov_deg``, the configuration or the log's camera description:
    :func:`harness.camera_stream.log_camera_view`), its template numbers and rotations then
    replayed (:mod:`harness.camera_stream`). ``ratslam``: the project's defaults (the default),
    the published algorithm, or both on the same stream. A grid or log beyond the size budget
    (:mod:`harness.budget`) is refused before anything runs unless ``yes``."""
    log = ObservationLog.read_csv(log_path)
    camera_view, camera_derivation, views = None, "", None
    if fov_deg is not None and log.image is None:
        raise InputError(f"{log_path}: --fov: the log has no image column (a field of view is for camera logs)")
    if log.image is not None:
        camera_view, camera_derivation = _camera_log_view(log, log_path, ratslam_config, gtsam_config, config, fov_deg)
        from .camera_stream import match_camera_views

        log, views = match_camera_views(log, log_path, camera_view)
    name = Path(log_path).name
    if ratslam_config is not None and gtsam_config is not None:
        rs_cfg, pg_cfg = ratslam_config, gtsam_config
        derivation = "Configurations given by the caller (nothing derived from the log)."
    else:
        derived_rs, derived_pg, derivation = derive_configs(log)
        if camera_view is not None:  # a camera log: the settings sized for scene numbers re-derived
            from .camera_stream import camera_configs

            derived_rs, derived_pg, camera_text = camera_configs(
                log, camera_view, derived_rs, derived_pg, scale_position=False
            )
            derivation += "\n" + camera_text
        rs_cfg, pg_cfg = ratslam_config or derived_rs, gtsam_config or derived_pg
    if camera_view is not None:
        rs_cfg = dataclasses.replace(rs_cfg, view=camera_view)
        derivation = f"{derivation}\n{camera_derivation}" if camera_derivation else derivation
    if config is not None:
        rs_cfg, pg_cfg = config.apply(rs_cfg, pg_cfg)
    check_grid(str(config.source if config is not None and config.source else log_path), rs_cfg.shape, yes)
    check_ticks(str(log_path), len(log), yes)
    rs_cfg, alternatives, derivations = ratslam_settings(rs_cfg, ratslam, derivation)
    derivation = derivations[""]
    out = Path(out)
    with staged_directory(out, (Path(log_path), *_inputs(config))) as stage, _named(log_path):
        result, alt_results = run_single_stream(
            stage,
            log,
            rs_cfg,
            pg_cfg,
            config_header=f"Effective configuration of the replay of {name}.\n"
            f"{derivation}\n"
            f"Reproduce: ratslam-harness replay {name} --config config.toml",
            progress=_progress(log, f"replay {name}", show_progress),
            recorder_factory=recorder_factory,
            alternatives=alternatives,
            camera=views,
        )

        def recorded(r: VariantResult, cfg: RatSLAMConfig, name: str = "") -> VariantResult:
            return dataclasses.replace(
                r,
                config=VariantConfig(ratslam=dataclasses.asdict(cfg), gtsam=dataclasses.asdict(pg_cfg)),
                derived_scale=derivations[name],
            )

        run = RunResult(
            figure=None,
            title=f"replay of {name}",
            log=str(log_path),
            duration_s=log.duration,
            variants={"replay": recorded(result, rs_cfg)},
            provenance=provenance(log=str(log_path), ratslam=ratslam),
        )
        if PUBLISHED in alt_results:
            run = dataclasses.replace(
                run,
                published=dataclasses.replace(
                    run, variants={"replay": recorded(alt_results[PUBLISHED], alternatives[PUBLISHED], PUBLISHED)}
                ),
            )
        write_run(stage, run)
    return out
