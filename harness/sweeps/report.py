"""A sweep's results: the tidy ``runs.csv`` and ``report.md`` with robustness curves.

``runs.csv`` has one row per run and system: the run id, world, duration, which axis the run
varies (``varied``: an axis name, or ``grid``), every axis's value, the seed, the system's name
and kind, ATE online and of its map (experience map / pose-graph keyframes), the odometry's ATE,
loop-closure precision and recall (pose graph), map nodes, snaps (RatSLAM), wall times and the
error of a failed run. The report is built from ``runs.csv`` alone, so ``ratslam-harness report
DIR`` can rebuild it: per axis, the median map ATE across seeds with the interquartile band, one
line per system, the odometry as reference; and the breakdown table: per system, the largest
value of each axis up to which the median map ATE stays at or below ``BREAKDOWN_ATE_M``.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from worlds.errors import InputError
from worlds.files import atomic_write_text, read_json

from .spec import AXES, CAMERA_AXES, LOG_AXES, WORLD_AXES

BREAKDOWN_ATE_M = 0.5
_AXIS_SETS = (WORLD_AXES, LOG_AXES, CAMERA_AXES)


def columns(axes: tuple[str, ...] = WORLD_AXES) -> tuple[str, ...]:
    """runs.csv's columns for a sweep over ``axes`` (its base's: a world's, a log's, a camera's)."""
    return ("run_id", "world", "duration_s", "varied", *axes, *_RESULT_COLUMNS)


_RESULT_COLUMNS = (
    "seed",
    "system",
    "kind",
    "ate_online",
    "ate_map",
    "ate_odometry",
    "closure_precision",
    "closure_recall",
    "nodes",
    "snaps",
    "wall_s",
    "run_wall_s",
    "error",
)
COLUMNS = columns(WORLD_AXES)
"""runs.csv's columns for a simulated world's sweep."""
WALL_COLUMNS = ("wall_s", "run_wall_s")


class SweepReportError(InputError):
    """A sweep directory that cannot be reported on (one line: path and problem)."""


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def result_rows(tasks: list[dict], runs_dir: Path) -> list[dict]:
    """One row per run and system, in the spec's run order (completion order does not matter)."""
    rows = []
    for task in tasks:
        path = runs_dir / task["run_id"] / "result.json"
        if not path.is_file():
            continue
        result = read_json(path)["result"]
        cond = task["condition"]
        common = {
            "run_id": task["run_id"],
            "world": Path(str(task["world"] if "world" in task else task["log"])).stem,
            "duration_s": task["duration"],
            "varied": task["varied"],
            **cond,
            "seed": task["seed"],
            "ate_odometry": result.get("ate_odometry"),
            "run_wall_s": result["wall_s"],
            "error": result["error"],
        }
        for system in task["systems"]:
            r = result["systems"].get(system["name"], {})
            rows.append(
                {
                    **common,
                    "system": system["name"],
                    "kind": system["kind"],
                    **{
                        k: r.get(k)
                        for k in (
                            "ate_online",
                            "ate_map",
                            "closure_precision",
                            "closure_recall",
                            "nodes",
                            "snaps",
                            "wall_s",
                        )
                    },
                }
            )
    return rows


def csv_text(rows: list[dict], axes: tuple[str, ...] = WORLD_AXES) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    names = columns(axes)
    writer.writerow(names)
    for row in rows:
        writer.writerow([_cell(row.get(c)) for c in names])
    return buf.getvalue()


def row_axes(rows: list[dict]) -> tuple[str, ...]:
    """The axes runs.csv's rows have values for (a world's, a log's or a camera's)."""
    keys = set(rows[0]) if rows else set(WORLD_AXES)
    return next((axes for axes in _AXIS_SETS if set(axes) <= keys), WORLD_AXES)


def read_runs_csv(path) -> list[dict]:
    """``runs.csv`` back as rows (numbers as floats, empty cells as None)."""
    path = Path(path)
    if not path.is_file():
        raise SweepReportError(f"{path}: missing (not a sweep directory)")
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        header = set(reader.fieldnames or ())
        axes = next((a for a in _AXIS_SETS if set(a) <= header), WORLD_AXES)
        missing = set(columns(axes)) - header
        if missing:
            raise SweepReportError(f"{path}: missing column(s) {', '.join(sorted(missing))}")
        rows = []
        for line, raw in enumerate(reader, start=2):
            if None in raw or None in raw.values():  # a row cut short or run on (a truncated file)
                raise SweepReportError(f"{path}: line {line}: expected {len(reader.fieldnames or ())} fields")
            row = {}
            for k, v in raw.items():
                if k in ("run_id", "world", "varied", "system", "kind", "error"):
                    row[k] = v or None
                else:
                    try:
                        row[k] = float(v) if v != "" else None
                    except ValueError:
                        raise SweepReportError(f"{path}: line {line}: {k}: not a number ({v!r})") from None
            rows.append(row)
    return rows


def _finite(values) -> np.ndarray:
    a = np.array([v for v in values if v is not None], dtype=float)
    return a[np.isfinite(a)]


def curves(rows: list[dict], axis: str, key: str = "ate_map") -> dict:
    """Per system: (axis values, median, 25th and 75th percentile of ``key`` across seeds);
    ``"odometry"``: the same for the odometry's ATE."""
    mine = [r for r in rows if r["varied"] == axis and not r["error"]]
    values = sorted({r[axis] for r in mine})
    out = {}
    for system in dict.fromkeys(r["system"] for r in mine):
        stats = []
        for v in values:
            a = _finite(r[key] for r in mine if r["system"] == system and r[axis] == v)
            stats.append(np.percentile(a, [50, 25, 75]) if len(a) else [math.nan] * 3)
        out[system] = (np.array(values), *np.array(stats).T)
    first = next(iter(out), None)
    if first is not None:
        stats = []
        for v in values:
            a = _finite(r["ate_odometry"] for r in mine if r["system"] == first and r[axis] == v)
            stats.append(np.percentile(a, [50, 25, 75]) if len(a) else [math.nan] * 3)
        out["odometry"] = (np.array(values), *np.array(stats).T)
    return out


def breakdown(rows: list[dict], bound: float = BREAKDOWN_ATE_M) -> dict:
    """Per system and axis: the largest axis value up to which (from the smallest) the median
    map ATE stays <= ``bound``; None if it fails at the smallest value already."""
    out: dict = {}
    for axis in dict.fromkeys(r["varied"] for r in rows if r["varied"] in AXES):
        for system, (values, median, _, _) in curves(rows, axis).items():
            if system == "odometry":
                continue
            held = None
            for v, m in zip(values, median):
                if not (m <= bound):
                    break
                held = float(v)
            out.setdefault(system, {})[axis] = held
    return out


def against_odometry(rows: list[dict]) -> list[str]:
    """Per axis, the median map ATE of each system at each value beside the odometry's median
    (markdown lines); a median above the odometry's is marked with an asterisk."""
    lines: list[str] = []
    for axis in dict.fromkeys(r["varied"] for r in rows if r["varied"] in AXES):
        per = curves(rows, axis)
        odo = per.pop("odometry", None)
        if odo is None:
            continue
        systems = list(per)
        lines += [
            f"| {axis} | odometry | " + " | ".join(systems) + " |",
            "|---|---|" + "---|" * len(systems),
        ]
        for i, v in enumerate(odo[0]):
            cells = []
            for s in systems:
                m = per[s][1][i]
                cells.append(f"{m:.3f}" + ("*" if m > odo[1][i] else "") if math.isfinite(m) else "n/a")
            lines.append(f"| {v:g} | {odo[1][i]:.3f} | " + " | ".join(cells) + " |")
        lines.append("")
    return lines


def plot_axis(rows: list[dict], axis: str, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from worlds.plot import save_figure

    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.0), sharey=True)
    for ax, key, title in (
        (axes[0], "ate_map", "map (experience map / keyframes)"),
        (axes[1], "ate_online", "online estimate"),
    ):
        for system, (x, med, lo, hi) in curves(rows, axis, key).items():
            if system == "odometry":
                ax.plot(x, med, "k--", lw=1.0, label="odometry")
                continue
            (line,) = ax.plot(x, med, "o-", lw=1.2, ms=3, label=system)
            ax.fill_between(x, lo, hi, color=line.get_color(), alpha=0.15)
        ax.axhline(BREAKDOWN_ATE_M, color="0.6", lw=0.6, ls=":")
        ax.set_yscale("log")
        ax.set_xlabel(f"{axis} ({AXES[axis].meaning})", fontsize=8)
        ax.set_title(f"ATE of the {title}: median, IQR across seeds", fontsize=9)
        ax.grid(True, which="both", lw=0.3, color="0.85")
    axes[0].set_ylabel("ATE (m)")
    axes[1].legend(fontsize=7, loc="best")
    return save_figure(fig, path)


def _fmt(v) -> str:
    return "—" if v is None else f"{v:g}"


def _stream_sentence(rows: list[dict]) -> str:
    """How one run makes its stream: simulated, or a real log's odometry with labels synthesised."""
    if row_axes(rows) == LOG_AXES:
        return (
            "One run labels the real log once under its condition (the log's odometry, the labels "
            "synthesised from its ground truth) and runs every system on that stream."
        )
    return "One run simulates its condition once and runs every system on that stream."


def render(rows: list[dict], title: str, panels: list[str]) -> str:
    runs = {r["run_id"]: r for r in rows}
    failed = [r for r in runs.values() if r["error"]]
    systems = list(dict.fromkeys(r["system"] for r in rows))
    seeds = sorted({int(r["seed"]) for r in rows})
    worlds = sorted({r["world"] for r in rows})
    lines = [
        f"# Sweep: {title}",
        "",
        f"{len(runs)} runs ({len(failed)} failed) on {', '.join(worlds)}, "
        f"{len(seeds)} seeds, systems: {', '.join(systems)}. {_stream_sentence(rows)} Map ATE: the "
        "experience map (RatSLAM) or the pose graph's keyframes, SE(2)-aligned to ground truth.",
        "",
    ]
    bd = breakdown(rows)
    if bd:
        axes = list(dict.fromkeys(a for per in bd.values() for a in per))
        lines += [
            f"## Breakdown: largest value with median map ATE <= {BREAKDOWN_ATE_M} m",
            "",
            "| system | " + " | ".join(axes) + " |",
            "|---|" + "---|" * len(axes),
        ]
        lines += [f"| {s} | " + " | ".join(_fmt(bd[s].get(a)) for a in axes) + " |" for s in bd]
        lines.append("")
    odometry = against_odometry(rows)
    if odometry:
        lines += [
            "## Median map ATE against the odometry's (m; * = worse than the odometry)",
            "",
            *odometry,
        ]
    if panels:
        lines += ["## Robustness curves", ""] + [f"![{p}]({p})" for p in panels] + [""]
    grid = [r for r in rows if r["varied"] == "grid" and not r["error"]]
    if grid:
        lines += ["## Median map ATE per condition (m)", ""]
        axes = [a for a in row_axes(grid) if len({r[a] for r in grid}) > 1]
        lines += [
            "| " + " | ".join(axes) + " | " + " | ".join(systems) + " |",
            "|" + "---|" * (len(axes) + len(systems)),
        ]
        for cond in dict.fromkeys(tuple(r[a] for a in axes) for r in grid):
            mine = [r for r in grid if tuple(r[a] for a in axes) == cond]
            cells = []
            for s in systems:
                a = _finite(r["ate_map"] for r in mine if r["system"] == s)
                cells.append(f"{np.median(a):.3f}" if len(a) else "n/a")
            lines.append("| " + " | ".join(f"{v:g}" for v in cond) + " | " + " | ".join(cells) + " |")
        lines.append("")
    if failed:
        lines += (
            ["## Failed runs", ""]
            + [f"- `{r['run_id']}` seed {int(r['seed'])}: {r['error']}" for r in failed[:20]]
            + [""]
        )
    return "\n".join(lines)


def write_report_from_rows(out: Path, rows: list[dict], title: str) -> Path:
    panels = [
        plot_axis(rows, axis, out / f"curve_{axis}.png").name
        for axis in dict.fromkeys(r["varied"] for r in rows if r["varied"] in AXES)
    ]
    return atomic_write_text(out / "report.md", render(rows, title, panels))


def write_sweep_report(out: Path, tasks: list[dict]) -> Path:
    """``runs.csv`` from the run results, then the report."""
    rows = result_rows(tasks, out / "runs")
    axes = tuple(tasks[0]["condition"]) if tasks else WORLD_AXES
    atomic_write_text(out / "runs.csv", csv_text(rows, axes))
    return write_report_from_rows(out, read_runs_csv(out / "runs.csv"), out.name)


def rebuild_sweep_report(out) -> Path:
    """Rebuild ``report.md`` and the curves of sweep directory ``out`` from its ``runs.csv``."""
    out = Path(out)
    return write_report_from_rows(out, read_runs_csv(out / "runs.csv"), out.name)
