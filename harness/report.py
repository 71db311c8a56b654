"""report.md and PNG panels of a run directory, from its metrics.json and maps.npz alone.

``ratslam-harness report DIR`` calls :func:`write_report` to rebuild them without re-running.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from worlds import load_world
from worlds.files import atomic_write_text, read_json, read_tum

from . import plots

PANELS = ("a_world.png", "b_pose_cells.png", "c_experience_map.png", "d_gtsam.png")


class ReportError(Exception):
    """A run directory that cannot be reported on (one line: path and problem)."""


def _load(run_dir: Path):
    metrics_path, maps_path = run_dir / "metrics.json", run_dir / "maps.npz"
    for p in (metrics_path, maps_path, run_dir / "trajectories" / "ground_truth.tum"):
        if not p.exists():
            raise ReportError(f"{p}: missing (not a complete run directory)")
    return read_json(metrics_path), dict(np.load(maps_path))


def write_panels(run_dir: Path, metrics: dict, maps: dict) -> list[Path]:
    """The four PNG panels of the primary variant."""
    world = load_world(metrics["world"]["file"]) if (metrics.get("world") or {}).get("file") else None
    traj = run_dir / "trajectories"
    gt = read_tum(traj / "ground_truth.tum")[1]
    if gt is None or len(gt) < 2:
        return []
    odo = read_tum(traj / "odometry.tum")[1]
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


def render_markdown(metrics: dict, panels: list[str]) -> str:
    """The report text: claims table, accuracy per variant and system, timing, panels, provenance."""
    fig = metrics.get("figure") or {}
    lines = [f"# {fig.get('name', 'replay')}: {fig.get('title', metrics.get('title', 'run'))}", ""]
    if metrics.get("world"):
        w = metrics["world"]
        lines += [
            f"World `{w['name']}`, {metrics['duration_s']:.0f} s simulated, seed {metrics['seed']}, "
            f"false-positive rate {metrics.get('fp_rate', 'n/a')} per tick.",
            "",
        ]
    elif metrics.get("real_log"):
        lines += [
            f"Real data set `{metrics['real_log']}`, {metrics['duration_s']:.0f} s, scene numbers "
            f"synthesised with seed {metrics['seed']}, false-positive rate {metrics.get('fp_rate', 'n/a')} "
            "per tick.",
            "",
        ]
    if fig.get("notes"):
        lines += [fig["notes"], ""]
    claims = metrics.get("claims", [])
    if claims:
        held = sum(c["held"] for c in claims)
        lines += [
            f"## The paper's claims ({held}/{len(claims)} held)",
            "",
            "| claim | measured | held |",
            "|---|---|---|",
        ]
        lines += [f"| {c['statement']} | {c['measured']} | {'yes' if c['held'] else '**no**'} |" for c in claims]
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
    for name, v in metrics["variants"].items():
        label = metrics.get("variant_labels", {}).get(name, name)
        lines += [f"### Variant `{name}`: {label}", ""]
        if v.get("derived_scale"):
            lines += [v["derived_scale"].replace("\n", " "), ""]
        lines += ["| trajectory | ATE (m) | alignment yaw (deg) |", "|---|---|---|"]
        for system, ate in v["ate"].items():
            lines.append(f"| {system} | {_fmt(ate)} | {_fmt(v['alignment_yaw_deg'].get(system))} |")
        lc = v.get("loop_closure", {})
        t = v["timing"]
        lines += [
            "",
            f"Experiences {v['experiences']}, transitions {v['links']}, snaps {v['snaps']}, "
            f"multiple representations {v['multiple_representations']}, hash collisions "
            f"{v['hash_collisions']}.",
            f"GTSAM: {v.get('keyframes', 'n/a')} keyframes, loop closures proposed {lc.get('proposed', 'n/a')}, "
            f"accepted {lc.get('accepted', 'n/a')}, precision {_fmt(lc.get('precision'))}, "
            f"recall {_fmt(lc.get('recall'))}.",
            f"Wall time: RatSLAM {t['ratslam_s']:.1f} s (x{_fmt(t['ratslam_realtime_factor'])} real time), "
            f"GTSAM {t['gtsam_s']:.1f} s (x{_fmt(t['gtsam_realtime_factor'])} real time).",
            "",
        ]
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
        *(f"{k}: {v}" for k, v in metrics["provenance"].items() if k != "config"),
        "```",
        "",
    ]
    return "\n".join(lines)


def write_report(run_dir) -> Path:
    """(Re)build ``report.md`` and the PNG panels of ``run_dir``."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise ReportError(f"{run_dir}: not a directory")
    metrics, maps = _load(run_dir)
    panels = [p.name for p in write_panels(run_dir, metrics, maps)]
    return atomic_write_text(run_dir / "report.md", render_markdown(metrics, panels))
