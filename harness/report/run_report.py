"""report.md and PNG panels of a run directory, from its metrics.json and maps.npz alone.

``ratslam-harness report DIR`` calls :func:`write_report` to rebuild them without re-running.
The report is rendered from the run's typed result (:class:`harness.report.results.RunResult`).
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from worlds import World, load_world
from worlds.errors import InputError
from worlds.files import atomic_write_text, read_tum

from ..run.directory import add_to_manifest
from ..run.workers import fork_context, free_cores, map_in_processes
from .results import ClaimResult, RunResult, VariantResult

PUBLISHED = "published"  # the alternative RatSLAM run beside the defaults (harness.figures.run)

PANELS = ("a_world.png", "b_pose_cells.png", "c_experience_map.png", "d_gtsam.png")


class ReportError(InputError):
    """A run directory that cannot be reported on (one line: path and problem)."""


def _load(run_dir: Path, run: RunResult | None) -> tuple[RunResult, dict[str, np.ndarray]]:
    metrics_path, maps_path = run_dir / "metrics.json", run_dir / "maps.npz"
    for p in (metrics_path, maps_path):
        if not p.exists():
            raise ReportError(f"{p}: missing (not a complete run directory)")
    if run is None:
        run = RunResult.from_json(metrics_path)
    return run, _maps(maps_path)


def _poses(path: Path) -> np.ndarray:
    """The (x, y, θ) poses of a run's TUM file; one line naming it if it cannot be read."""
    try:
        return read_tum(path)[1]
    except OSError as e:
        raise ReportError(f"{path}: cannot be read ({e.strerror})") from None
    except ValueError as e:  # a malformed file: the message names it
        raise ReportError(str(e)) from None


def _variant_dirs(run_dir: Path, run: RunResult) -> list[Path]:
    """The directory of every variant whose run is in ``run_dir`` (the primary's is ``run_dir``)."""
    dirs = [run_dir if i == 0 else run_dir / "variants" / name for i, name in enumerate(run.variants)]
    return [d for d in dirs if (d / "maps.npz").exists()]


def _maps(path: Path) -> dict[str, np.ndarray]:
    try:
        return dict(np.load(path))
    except (OSError, ValueError, zipfile.BadZipFile) as e:
        raise ReportError(f"{path}: cannot be read ({e})") from None


def write_panels(run_dir: Path, run: RunResult, maps: dict[str, np.ndarray]) -> list[Path]:
    """The PNG panels of every variant (none without ground truth): the world, and for RatSLAM's
    defaults and, where it ran, the published preset, the paper's figure pair, (a) the pose-cell
    peak path with snaps and (b) the experience map with ground truth; and the pose graph. The
    primary variant's are in ``run_dir``, the others' in their variant directories. Several
    variants' panels are drawn in parallel processes, one per free core (the same files)."""
    world = load_world(run.world.file) if run.world is not None and run.world.file else None
    dirs = _variant_dirs(run_dir, run)
    workers = min(len(dirs), free_cores())
    if workers < 2:
        return [p for vdir in dirs for p in variant_panels(vdir, world, maps if vdir == run_dir else None)]
    jobs = [(vdir, world) for vdir in dirs]
    return [p for panels in map_in_processes(_panels_job, jobs, workers, fork_context()) for p in panels]


def _panels_job(job: tuple[Path, World | None]) -> list[Path]:
    return variant_panels(*job)


def _references(vdir: Path, maps: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray] | None:
    """Ground truth and odometry of a variant's run: from maps.npz, or from the TUM files of a
    run directory written before maps.npz held them (None without ground truth)."""
    if "ground_truth" in maps:
        return maps["ground_truth"], maps["odometry"]
    traj = vdir / "trajectories"
    if not (traj / "ground_truth.tum").exists():
        return None
    return _poses(traj / "ground_truth.tum"), _poses(traj / "odometry.tum")


def variant_panels(vdir: Path, world: World | None, maps: dict[str, np.ndarray] | None = None) -> list[Path]:
    """One variant's panels, from ``maps`` (default: its maps.npz)."""
    from . import plots  # matplotlib: loaded where a panel is drawn, not by every command

    if maps is None:
        maps = _maps(vdir / "maps.npz")
    references = _references(vdir, maps)
    if references is None or len(references[0]) < 2:
        return []
    gt, odo = references
    fp_xy = gt[maps["false_positive"].astype(bool), :2] if "false_positive" in maps else np.zeros((0, 2))
    out = [plots.panel_world(world, gt, odo, fp_xy, vdir / PANELS[0])]
    grid = tuple(maps["grid_shape"])
    for prefix, label in (("", "RatSLAM"), (f"{PUBLISHED}_", "RatSLAM as published")):
        if f"{prefix}peak_cells" not in maps:
            continue
        suffix = f"_{PUBLISHED}" if prefix else ""
        exp_ticks = maps[f"{prefix}experience_first_tick"].astype(int)
        out += [
            plots.panel_pose_cells(
                maps[f"{prefix}peak_cells"],
                maps[f"{prefix}snapped"].astype(bool),
                grid,
                vdir / f"b_pose_cells{suffix}.png",
                label,
            ),
            plots.panel_experience_map(
                world,
                maps[f"{prefix}experience_poses"][:, :2],
                gt[exp_ticks, :2],
                maps[f"{prefix}links"].astype(int),
                vdir / f"c_experience_map{suffix}.png",
                label,
                gt[:, :2],
            ),
        ]
    if "keyframe_poses" in maps and len(maps["keyframe_poses"]):
        kf_ticks = maps["keyframe_ticks"].astype(int)
        out.append(
            plots.panel_gtsam(
                world,
                maps["keyframe_poses"][:, :2],
                gt[kf_ticks, :2],
                maps["loop_closures"],
                maps["closure_accepted"],
                vdir / PANELS[3],
            )
        )
    return out


def _fmt(v, unit=""):
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return "n/a"
    if isinstance(v, float):
        return f"{v:.3f}{unit}"
    return f"{v}{unit}"


_RATSLAM_TRAJECTORIES = ("ratslam_online", "pose_cell_path", "experience_map", "ratslam_final")


def _variant_section(name: str, label: str, v: VariantResult, published: VariantResult | None = None) -> list[str]:
    """One variant's accuracy table and counts (and the published RatSLAM's, if it ran)."""
    lines = [f"### Variant `{name}`: {label}", ""]
    if v.derived_scale:
        lines += [v.derived_scale.replace("\n", " "), ""]
    if v.ate is not None:
        yaw = v.alignment_yaw_deg
        lines += ["| trajectory | ATE (m) | alignment yaw (deg) |", "|---|---|---|"]
        for system, ate in v.ate.items():
            lines.append(f"| {system} | {_fmt(ate)} | {_fmt(None if yaw is None else yaw.get(system))} |")
        if published is not None and published.ate is not None:
            p_yaw = published.alignment_yaw_deg
            for system in _RATSLAM_TRAJECTORIES:
                p_ate = published.ate.get(system)
                y = None if p_yaw is None else p_yaw.get(system)
                lines.append(f"| {system}, RatSLAM as published | {_fmt(p_ate)} | {_fmt(y)} |")
    else:
        lines.append("No ground truth: no accuracy measured.")
    lc, t = v.loop_closure, v.timing
    proposed = lc.proposed if lc is not None else v.loop_closures_proposed
    accepted, precision, recall = (None, None, None) if lc is None else (lc.accepted, lc.precision, lc.recall)
    lines += [
        "",
        f"Experiences {v.experiences}, transitions {v.links}, snaps {v.snaps}, "
        f"multiple representations {_fmt(v.multiple_representations)}, hash collisions "
        f"{_fmt(v.hash_collisions)}.",
        f"GTSAM: {_fmt(v.keyframes)} keyframes, loop closures proposed {_fmt(proposed)}, "
        f"accepted {_fmt(accepted)}, precision {_fmt(precision)}, recall {_fmt(recall)}.",
        f"Wall time: RatSLAM {t.ratslam_s:.1f} s (x{_fmt(t.ratslam_realtime_factor)} real time), "
        f"GTSAM {t.gtsam_s:.1f} s (x{_fmt(t.gtsam_realtime_factor)} real time).",
        "",
    ]
    if published is not None:
        pt = published.timing
        lines[-1:] = [
            f"RatSLAM as published: experiences {published.experiences}, transitions {published.links}, snaps "
            f"{published.snaps}, multiple representations {_fmt(published.multiple_representations)}, hash "
            f"collisions {_fmt(published.hash_collisions)}; {pt.ratslam_s:.1f} s "
            f"(x{_fmt(pt.ratslam_realtime_factor)} real time).",
            "",
        ]
    return lines


def _claims_table(claims: list[ClaimResult], published: list[ClaimResult] | None) -> list[str]:
    """The paper's claims, judged for the project's defaults and, if it ran, RatSLAM as published."""
    held = sum(c.held for c in claims)
    if published is None:
        lines = [f"## The paper's claims ({held}/{len(claims)} held)", ""]
        lines += ["| claim | measured | held |", "|---|---|---|"]
        lines += [f"| {c.statement} | {c.measured} | {'yes' if c.held else '**no**'} |" for c in claims]
        return lines + [""]
    by_key = {c.key: c for c in published}
    p_held = sum(c.held for c in published)
    lines = [
        f"## The paper's claims (project defaults {held}/{len(claims)} held; RatSLAM as published "
        f"{p_held}/{len(published)})",
        "",
        "Each claim judged on the same streams for RatSLAM with the project's defaults and with the "
        "paper's algorithm as published (`RatSLAMConfig.published()`; docs/fidelity.md says why they differ). "
        "The pose graph's numbers are the same run's in both columns.",
        "",
        "| claim | project defaults | held | as published | held |",
        "|---|---|---|---|---|",
    ]
    for c in claims:
        p = by_key.get(c.key)
        p_cells = f"{p.measured} | {'yes' if p.held else '**no**'}" if p is not None else "n/a | n/a"
        lines.append(f"| {c.statement} | {c.measured} | {'yes' if c.held else '**no**'} | {p_cells} |")
    return lines + [""]


def render_markdown(run: RunResult, panels: list[str]) -> str:
    """The report text: claims table, accuracy per variant and system, timing, panels, provenance."""
    fig = run.figure
    if fig is not None:
        lines = [f"# {fig.name}: {fig.title}", ""]
    else:
        lines = [f"# replay: {run.title or 'run'}", ""]
    if run.world is not None:
        lines += [
            f"World `{run.world.name}`, {run.duration_s:.0f} s simulated, seed {run.seed}, "
            f"false-positive rate {_or_na(run.fp_rate)} per tick.",
            "",
        ]
    elif run.real_log:
        lines += [
            f"Real data set `{run.real_log}`, {run.duration_s:.0f} s, scene numbers "
            f"synthesised with seed {run.seed}, false-positive rate {_or_na(run.fp_rate)} "
            "per tick.",
            "",
        ]
    if fig is not None and fig.notes:
        lines += [fig.notes, ""]
    claims = run.claims or []
    if claims:
        lines += _claims_table(claims, None if run.published is None else run.published.claims)
    lines += [
        "## Accuracy",
        "",
        "ATE: RMSE of position after least-squares SE(2) alignment to ground truth. "
        "`experience_map` compares each experience's final map pose with the ground truth where "
        "it was created (the place it stands for: later entries are related to that place "
        "through the pose-cell offset, see `offset_transitions`); `*_online` is the estimate "
        "at every tick; `*_final` every tick as the final map places it (the node its pose hung "
        "from, at its final pose); `pose_cell_path` is the pose-cell peak in metres (unwrapped).",
        "",
    ]
    for name, v in run.variants.items():
        published = None if run.published is None else run.published.variants.get(name)
        lines += _variant_section(name, run.label(name), v, published)
    if panels:
        lines += ["## Panels", ""]
        for i, name in enumerate(run.variants):
            where = "" if i == 0 else f"variants/{name}/"
            mine = [p for p in panels if p.rpartition("/")[0] + ("/" if "/" in p else "") == where]
            if mine:
                lines += [f"### `{name}`", ""] + [f"![{p}]({p})" for p in mine] + [""]
    lines += [
        "## Recording",
        "",
        "Open the Rerun recording of the primary variant with `rerun recording.rrd` (rerun-sdk 0.41).",
        "",
        "## Provenance",
        "",
        "```",
        *(f"{k}: {v}" for k, v in run.provenance.items() if k != "config"),
        "```",
        "",
    ]
    return "\n".join(lines)


def _or_na(v) -> str:
    return "n/a" if v is None else f"{v}"


def write_report(run_dir, run: RunResult | None = None, panels: list[Path] | None = None) -> Path:
    """(Re)build ``report.md`` and the PNG panels of ``run_dir`` from ``run`` (default: its
    metrics.json); ``panels``: the panels, already drawn with each variant's run
    (:func:`variant_panels`), instead of drawing them all here."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise ReportError(f"{run_dir}: not a directory")
    run, maps = _load(run_dir, run)
    written = write_panels(run_dir, run, maps) if panels is None else panels
    report = atomic_write_text(
        run_dir / "report.md", render_markdown(run, [p.relative_to(run_dir).as_posix() for p in written])
    )
    add_to_manifest(run_dir, [*written, report])  # a rebuilt report's files are the run's own
    return report
