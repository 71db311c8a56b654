"""report.md and PNG panels of a run directory, from its metrics.json and maps.npz alone.

``ratslam-harness report DIR`` calls :func:`write_report` to rebuild them without re-running.
The report is rendered from the run's typed result (:class:`harness.results.RunResult`).
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from worlds import load_world
from worlds.errors import InputError
from worlds.files import atomic_write_text, read_tum

from . import plots
from .results import RunResult, VariantResult
from .run_dir import add_to_manifest

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
    if run.primary.has_ground_truth and not (run_dir / "trajectories" / "ground_truth.tum").exists():
        raise ReportError(f"{run_dir / 'trajectories' / 'ground_truth.tum'}: missing (not a complete run directory)")
    try:
        maps = dict(np.load(maps_path))
    except (OSError, ValueError, zipfile.BadZipFile) as e:
        raise ReportError(f"{maps_path}: cannot be read ({e})") from None
    return run, maps


def _poses(path: Path) -> np.ndarray:
    """The (x, y, θ) poses of a run's TUM file; one line naming it if it cannot be read."""
    try:
        return read_tum(path)[1]
    except OSError as e:
        raise ReportError(f"{path}: cannot be read ({e.strerror})") from None
    except ValueError as e:  # a malformed file: the message names it
        raise ReportError(str(e)) from None


def write_panels(run_dir: Path, run: RunResult, maps: dict[str, np.ndarray]) -> list[Path]:
    """The four PNG panels of the primary variant (none without ground truth)."""
    world = load_world(run.world.file) if run.world is not None and run.world.file else None
    traj = run_dir / "trajectories"
    if not (traj / "ground_truth.tum").exists():
        return []
    gt = _poses(traj / "ground_truth.tum")
    if len(gt) < 2:
        return []
    odo = _poses(traj / "odometry.tum")
    fp_xy = gt[maps["false_positive"].astype(bool), :2] if "false_positive" in maps else np.zeros((0, 2))
    exp_ticks = maps["experience_first_tick"].astype(int)
    out = [
        plots.panel_world(world, gt, odo, fp_xy, run_dir / PANELS[0]),
        plots.panel_pose_cells(
            maps["peak_cells"], maps["snapped"].astype(bool), tuple(maps["grid_shape"]), run_dir / PANELS[1]
        ),
        plots.panel_experience_map(
            world, maps["experience_poses"][:, :2], gt[exp_ticks, :2], maps["links"].astype(int), run_dir / PANELS[2]
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
                run_dir / PANELS[3],
            )
        )
    return out


def _fmt(v, unit=""):
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return "n/a"
    if isinstance(v, float):
        return f"{v:.3f}{unit}"
    return f"{v}{unit}"


def _variant_section(name: str, label: str, v: VariantResult) -> list[str]:
    """One variant's accuracy table and counts."""
    lines = [f"### Variant `{name}`: {label}", ""]
    if v.derived_scale:
        lines += [v.derived_scale.replace("\n", " "), ""]
    if v.ate is not None:
        yaw = v.alignment_yaw_deg
        lines += ["| trajectory | ATE (m) | alignment yaw (deg) |", "|---|---|---|"]
        for system, ate in v.ate.items():
            lines.append(f"| {system} | {_fmt(ate)} | {_fmt(None if yaw is None else yaw.get(system))} |")
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
    return lines


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
        held = sum(c.held for c in claims)
        lines += [
            f"## The paper's claims ({held}/{len(claims)} held)",
            "",
            "| claim | measured | held |",
            "|---|---|---|",
        ]
        lines += [f"| {c.statement} | {c.measured} | {'yes' if c.held else '**no**'} |" for c in claims]
        lines.append("")
    lines += [
        "## Accuracy",
        "",
        "ATE: RMSE of position after least-squares SE(2) alignment to ground truth. "
        "`experience_map` compares each experience's final map pose with the ground truth where "
        "it was created (the place it stands for: later entries are related to that place "
        "through the pose-cell offset, see `offset_transitions`); `*_online` is the estimate "
        "at every tick; `pose_cell_path` is the pose-cell peak in metres (unwrapped).",
        "",
    ]
    for name, v in run.variants.items():
        lines += _variant_section(name, run.label(name), v)
    if panels:
        lines += ["## Panels", ""] + [f"![{p}]({p})" for p in panels] + [""]
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


def write_report(run_dir, run: RunResult | None = None) -> Path:
    """(Re)build ``report.md`` and the PNG panels of ``run_dir`` from ``run`` (default: its
    metrics.json)."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise ReportError(f"{run_dir}: not a directory")
    run, maps = _load(run_dir, run)
    written = write_panels(run_dir, run, maps)
    report = atomic_write_text(run_dir / "report.md", render_markdown(run, [p.name for p in written]))
    add_to_manifest(run_dir, [*written, report])  # a rebuilt report's files are the run's own
    return report
