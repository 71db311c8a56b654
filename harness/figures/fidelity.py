"""The fidelity study: what each of the defaults' departures from the paper buys, and why.

For every departure of the project's defaults from RatSLAM as published
(:func:`ratslam.published.departures`; fields that only act together form one switch) and for the
two local-view readings the paper does not describe (habituation, the minimum association age),
two configurations are run on the same stream as the published preset and the defaults:

* ``published+SWITCH``: the published preset with that departure alone switched on;
* ``defaults-SWITCH``: the defaults with that departure alone removed (its fields at the
  published value). For a local-view reading (on in both) ``published-SWITCH`` and
  ``defaults-SWITCH`` switch it off instead (:data:`LOCAL_VIEW_OFF`).

Every configuration steps through one stream per (figure, seed) in one pass
(:func:`harness.run.stream.step_stream`) inside a :class:`Probe`, a :class:`ratslam.RatSLAM` that
records each experience switch from outside the package (which experience, on what scene run,
how long after a snap, the zone-of-influence terms of eq 9), so that the mechanism behind an
effect is measured on the run itself (:func:`mechanisms`).

Usage::

    python -m harness.figures.fidelity run --out reports/fidelity/runs.csv [--workers 2]
    python -m harness.figures.fidelity scenes --out reports/fidelity/scenes.csv
    python -m harness.figures.fidelity table reports/fidelity/runs.csv [--column online_ate_m]
    python -m harness.figures.fidelity mechanisms reports/fidelity/runs.csv --figure fig7 [--configs ...]
    python -m harness.figures.fidelity closures --figure fig7 --seed 0 --scenes clean+no_fp --config published
    python -m harness.figures.fidelity scene-table reports/fidelity/runs.csv reports/fidelity/scenes.csv
    python -m harness.figures.fidelity plot reports/fidelity/runs.csv --out reports/fidelity/ablation.png
    python -m harness.figures.fidelity report reports/fidelity
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import math
import sys
from collections.abc import Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ratslam import RatSLAM, RatSLAMConfig
from ratslam.published import departures, field_paths
from worlds import ObservationLog, load_world, simulate
from worlds.files import atomic_open

from ..report.metrics import ate_rmse, wrap_angle
from ..run.runner import dead_reckon
from ..run.stream import step_stream
from .registry import figure_configs, get_figure
from .streams import variant_log, variant_world


@dataclass(frozen=True)
class Switch:
    """One departure (or local-view reading) as a switch: ``on`` / ``off`` values per field path."""

    name: str
    label: str
    on: dict[str, Any]
    off: dict[str, Any]
    local_view: bool = False  # on in both the published preset and the defaults


# Fields that act only together (one switch), by the name of the switch.
GROUPS = {"reentry_fusion": ("reentry.position_sigma_m", "reentry.heading_sigma_deg")}
LABELS = {
    "trans_gain": "trans_gain 1.05",
    "view_confirm_ticks": "view_confirm_ticks 2",
    "snap_settle_ticks": "snap_settle_ticks 50",
    "offset_transitions": "offset_transitions",
    "energy": 'energy "product"',
    "relocalise_path_bound": "relocalise_path_bound",
    "loop_closure_sequence": "loop_closure_sequence",
    "odometry_gate_chi2": "odometry_gate_chi2 100 (acts only with the fusion)",
    "reentry_fusion": "re-entry fusion (sigmas 0.25 m, 5 deg)",
    "yaw_bias_search": "yaw_bias.search",
}
# The local-view readings the paper does not describe, switched off: habituation through a
# negligible rate (fatigue_rate must be > 0; 1e-9 a tick never reaches 1e-4 in a run), and the
# minimum association age through 1 (a view injects from the tick after it was learnt).
LOCAL_VIEW_OFF: dict[str, tuple[str, dict[str, Any]]] = {
    "fatigue": ("habituation (local_view.fatigue_*)", {"local_view.fatigue_rate": 1e-9}),
    "min_age": ("local_view.min_age_ticks 70", {"local_view.min_age_ticks": 1}),
}


def _get(cfg: RatSLAMConfig, path: str) -> Any:
    section, name = path.split(".")
    return getattr(getattr(cfg, section), name)


def _set(cfg: RatSLAMConfig, values: dict[str, Any]) -> RatSLAMConfig:
    changes: dict[str, dict[str, Any]] = {}
    for path, value in values.items():
        section, name = path.split(".")
        changes.setdefault(section, {})[name] = value
    return cfg.replace(**changes)


def _short(path: str) -> str:
    """A switch's name for one field: the field's name (``yaw_bias_search`` for ``yaw_bias.search``)."""
    section, name = path.split(".")
    return f"{section}_{name}" if name == "search" else name


def switches() -> list[Switch]:
    """The departures of the defaults from the published preset as switches (grouped by
    :data:`GROUPS`), then the local-view readings. Fails if a departure has no label (a new
    departure must be named here before the study runs)."""
    defaults, published = RatSLAMConfig(), RatSLAMConfig.published()
    paths = [d.split(" = ")[0] for d in departures(defaults)]
    grouped = {p: g for g, ps in GROUPS.items() for p in ps}
    out: list[Switch] = []
    for path in paths:
        name = grouped.get(path) or _short(path)
        if any(s.name == name for s in out):
            continue
        fields = GROUPS.get(name, (path,))
        if name not in LABELS or any(f not in paths for f in fields):
            raise ValueError(f"{name}: a departure the study does not name (add it to LABELS / GROUPS)")
        out.append(
            Switch(name, LABELS[name], {f: _get(defaults, f) for f in fields}, {f: _get(published, f) for f in fields})
        )
    for name, (label, off) in LOCAL_VIEW_OFF.items():
        on = {f: _get(defaults, f) for f in off}
        out.append(Switch(name, label, on, off, local_view=True))
    return out


def configurations(base: RatSLAMConfig) -> dict[str, RatSLAMConfig]:
    """Every configuration of the study on a figure's ``base`` (its grid and path-integration
    bias on the defaults): ``published``, ``defaults``, and per switch ``published+NAME`` /
    ``defaults-NAME`` (``published-NAME`` for a local-view reading), plus
    ``published+reentry_fusion+gate`` (the gate acts only with the fusion)."""
    published = RatSLAMConfig.published(base)
    out = {"published": published, "defaults": base}
    for s in switches():
        if s.local_view:
            out[f"published-{s.name}"] = _set(published, s.off)
        else:
            out[f"published+{s.name}"] = _set(published, s.on)
        out[f"defaults-{s.name}"] = _set(base, s.off)
    gate = "experience_map.odometry_gate_chi2"
    both = (*GROUPS["reentry_fusion"], gate)
    out["published+reentry_fusion+gate"] = _set(published, {f: _get(base, f) for f in both})
    return out


def differing_fields(a: RatSLAMConfig, b: RatSLAMConfig) -> set[str]:
    """The field paths where two configurations differ."""
    return {p for p in field_paths(RatSLAMConfig) if _get(a, p) != _get(b, p)}


# ------------------------------------------------------------------------------- instrumentation
class Probe(RatSLAM):
    """RatSLAM unchanged, with every experience switch and creation recorded from outside.

    ``events``: one row per tick the current experience changed, ``(tick, kind, from, to, scene
    run in ticks, ticks since the latest snap, E_xy, E_theta, new link index or -1)`` with kind 1 a
    switch to a known experience (a re-entry), 0 a new experience (eqs 10-11)."""

    def __init__(self, config: RatSLAMConfig):
        super().__init__(config)
        self.events: list[tuple[int, int, int, int, int, int, float, float, int]] = []
        self._scene, self._run, self._snap_tick, self._k = -1, 0, -(10**9), 0

    def step(self, dt: float, v_trans: float, v_rot: float, scene_id: int, view_rotation: float = 0.0) -> None:
        em = self.experience_map
        size, current, links = em.size, em.current, len(em.link_column("d"))
        super().step(dt, v_trans, v_rot, scene_id, view_rotation)
        k = self._k
        self._k += 1
        self._run = self._run + 1 if scene_id == self._scene else 1
        self._scene = scene_id
        if self.snapped:
            self._snap_tick = k
        if em.current == current:
            return
        link = links if len(em.link_column("d")) > links else -1
        j = em.current
        e_xy = e_th = float("nan")
        kind = 0 if em.size > size else 1
        if kind == 1:
            e_xy, e_th = self.zone_terms(j)
        self.events.append((k, kind, current, j, self._run, k - self._snap_tick, e_xy, e_th, link))

    def zone_terms(self, j: int) -> tuple[float, float]:
        """Eqs 2-5 of experience ``j`` against the current peak: (E_xy, E_theta)."""
        cfg = self.config.experience_map
        grid = np.array(self.config.shape, dtype=float)
        d = np.abs(self.experience_map.cells[j] - self.peak)
        d = np.minimum(d, grid - d)
        r = math.hypot(d[0], d[1])
        return max(1.0 - r / cfg.r_inf_cells, 0.0), max(1.0 - d[2] / cfg.theta_inf_cells, 0.0)


def _between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Positions ``b`` (N, 2) in the frames of poses ``a`` (N, 3)."""
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    return np.stack((c * dx + s * dy, -s * dx + c * dy), axis=1)


FALSE_REENTRY_M = 1.5  # a re-entry this far (in truth) from the place its experience stands for is false
WINDOW_TICKS = 7  # 1 s windows for the pose cells' gain


def mechanisms(probe: Probe, peak_metres: np.ndarray, snapped: np.ndarray, log: ObservationLog) -> dict[str, Any]:
    """What a run's switches did, measured against ground truth (after the run; the system never
    sees it): re-entries, false re-entries (the robot further than :data:`FALSE_REENTRY_M` in
    truth from the experience's place), those on heading alone (E_xy = 0, only eq 9's sum admits
    them) and how far away they were, those on a one-tick scene, on a false-positive scene, within
    50 ticks of a snap; the position error of the links made at re-entries and at new
    experiences; the pose cells' displacement over the odometry's in 1 s windows without a snap."""
    gt = log.ground_truth()
    first = probe.experience_first_tick
    ev = np.array(probe.events, dtype=float).reshape(-1, 9)
    sw = ev[ev[:, 1] == 1]
    tick, to = sw[:, 0].astype(int), sw[:, 3].astype(int)
    dist = np.hypot(*(gt[tick, :2] - gt[first[to], :2]).T)
    false = dist > FALSE_REENTRY_M
    heading_only = sw[:, 6] == 0.0
    fp = log.false_positive[tick] if log.false_positive is not None else np.zeros(len(tick), dtype=bool)
    one_tick, mid_snap = scene_run_lengths(log.scene_id)[tick] == 1, sw[:, 5] < 50

    links = probe.links
    lk_d, lk_th = probe.experience_map.link_column("d"), probe.experience_map.link_column("theta")
    true_rel = _between(gt[first[links[:, 0]]], gt[first[links[:, 1]], :2])
    meas = np.stack((lk_d * np.cos(lk_th), lk_d * np.sin(lk_th)), axis=1)
    link_err = np.hypot(*(meas - true_rel).T)
    true_phi = gt[first[links[:, 1]], 2] - gt[first[links[:, 0]], 2]
    phi = probe.experience_map.link_column("phi")
    link_phi_err = np.degrees(np.abs(wrap_angle(phi - true_phi)))
    linking = (sw[:, 8] >= 0) & ~false  # true re-entries that made a link (a loop closed)
    robot_vs_place = np.degrees(np.abs(wrap_angle(gt[tick, 2] - gt[first[to], 2])))
    made_at = {int(e[8]): int(e[1]) for e in ev if e[8] >= 0}
    at_reentry = np.array([i for i, kind in made_at.items() if kind == 1], dtype=int)
    at_true_reentry = np.array(
        [int(e[8]) for e, f in zip(sw, false) if e[8] >= 0 and not f],
        dtype=int,
    )
    at_create = np.array([i for i, kind in made_at.items() if kind == 0], dtype=int)

    def med(a: np.ndarray) -> float:
        return float(np.median(a)) if len(a) else float("nan")

    def p90(a: np.ndarray) -> float:
        return float(np.percentile(a, 90)) if len(a) else float("nan")

    return {
        "reentries": len(sw),
        "false_reentries": int(false.sum()),
        "heading_only": int(heading_only.sum()),
        "heading_only_false": int((heading_only & false).sum()),
        "heading_only_dist_m": med(dist[heading_only]),
        "one_tick": int(one_tick.sum()),
        "one_tick_false": int((one_tick & false).sum()),
        "fp_scene": int(fp.sum()),
        "fp_scene_false": int((fp & false).sum()),
        "mid_snap": int(mid_snap.sum()),
        "mid_snap_false": int((mid_snap & false).sum()),
        "link_err_reentry_m": med(link_err[at_true_reentry]),
        "link_err_reentry_all_m": med(link_err[at_reentry]),
        "link_err_create_m": med(link_err[at_create]),
        "place_only": int((sw[:, 7] == 0.0).sum()),
        "reentry_offset_p90_m": p90(dist[linking]),
        "reentry_heading_diff_p90_deg": p90(robot_vs_place[linking]),
        "link_err_reentry_p90_m": p90(link_err[at_true_reentry]),
        "link_phi_err_reentry_deg": med(link_phi_err[at_true_reentry]),
        "link_phi_err_reentry_p90_deg": p90(link_phi_err[at_true_reentry]),
        "link_phi_err_create_deg": med(link_phi_err[at_create]),
        "pc_gain": pose_cell_gain(peak_metres, snapped, log, probe.config),
    }


def scene_run_lengths(scene_id: np.ndarray) -> np.ndarray:
    """Per tick, how many consecutive ticks the scene number of that tick was reported for."""
    s = np.asarray(scene_id)
    starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
    lengths = np.diff(np.r_[starts, len(s)])
    return np.repeat(lengths, lengths)


def pose_cell_gain(peak_metres: np.ndarray, snapped: np.ndarray, log: ObservationLog, cfg: RatSLAMConfig) -> float:
    """The pose-cell peak's displacement over the odometry's, summed over 1 s windows in which the
    peak did not snap (1.0: the packet keeps up with the odometry; below: it lags)."""
    pc = cfg.pose_cells
    extent = np.array([pc.nx, pc.ny]) * pc.cell_size_m
    step = np.diff(peak_metres[:, :2], axis=0)
    step -= extent * np.round(step / extent)
    path = np.vstack((np.zeros((1, 2)), np.cumsum(step, axis=0)))
    odo = dead_reckon(log)[:, :2]
    w = WINDOW_TICKS
    n = (len(path) - 1) // w
    starts = np.arange(n) * w
    clean = np.array([not snapped[s + 1 : s + w + 1].any() for s in starts], dtype=bool)
    dp = np.hypot(*(path[starts + w] - path[starts]).T)[clean]
    do = np.hypot(*(odo[starts + w] - odo[starts]).T)[clean]
    return float(dp.sum() / do.sum()) if do.sum() > 0 else float("nan")


# ------------------------------------------------------------------------------------- the runs
STREAMS = {  # figure -> seeds
    "fig7": (0, 1, 2, 3, 4),
    "fig13": (0, 1, 2, 3, 4),
    "fig8": (0,),
    "fig9": (0,),
    "fig10": (0,),
    "fig11": (0,),
    "fig4": (0,),
}


def figure_base(figure: str) -> RatSLAMConfig:
    """The defaults on a figure's grid with its primary variant's path-integration bias."""
    fig = get_figure(figure)
    v = fig.primary
    if v.odometric_bias or v.wheel_errors or not v.lookalikes or v.ratslam_preset or v.gtsam or v.derived:
        raise ValueError(f"{figure}: the study runs primary variants on the plain world only")
    return figure_configs(fig)[0]


def figure_stream(figure: str, seed: int, duration: float | None = None, world: Any = None) -> ObservationLog:
    """The figure's primary stream, as a figure run simulates it (``world``, a loaded world,
    overrides its world, e.g. finer scene cells)."""
    fig = get_figure(figure)
    base = world if world is not None else load_world(fig.world)
    return variant_log(fig, variant_world(fig, base, fig.primary), fig.duration if duration is None else duration, seed)


COLUMNS = [
    "figure", "seed", "scenes", "config", "map_ate_m", "online_ate_m", "odometry_ate_m", "experiences", "links",
    "snaps", "reentries", "false_reentries", "heading_only", "heading_only_false", "heading_only_dist_m",
    "one_tick", "one_tick_false", "fp_scene", "fp_scene_false", "mid_snap", "mid_snap_false",
    "link_err_reentry_m", "link_err_reentry_all_m", "link_err_create_m", "pc_gain", "wall_s",
    "place_only", "reentry_offset_p90_m", "reentry_heading_diff_p90_deg", "link_err_reentry_p90_m",
    "link_phi_err_reentry_deg", "link_phi_err_reentry_p90_deg", "link_phi_err_create_deg",
]  # fmt: skip


def run_configs(log: ObservationLog, configs: dict[str, RatSLAMConfig], labels: dict[str, Any]) -> list[dict[str, Any]]:
    """Every configuration through ``log`` in one pass; one CSV row per configuration."""
    probes = {name: Probe(cfg) for name, cfg in configs.items()}
    traces, _ = step_stream(log, probes)
    gt = log.ground_truth()
    odometry_ate = ate_rmse(dead_reckon(log), gt)
    rows = []
    for name, trace in traces.items():
        p = probes[name]
        first = p.experience_first_tick
        row = {
            **labels,
            "config": name,
            "map_ate_m": ate_rmse(p.experience_poses, gt[first]) if len(first) > 1 else float("nan"),
            "online_ate_m": ate_rmse(trace.pose, gt),
            "odometry_ate_m": odometry_ate,
            "experiences": len(first),
            "links": len(p.links),
            "snaps": int(np.asarray(trace.snapped).sum()),
            "wall_s": round(trace.wall_s, 2),
        }
        assert trace.peak_metres is not None and trace.snapped is not None
        row |= mechanisms(p, trace.peak_metres, trace.snapped, log)
        rows.append(row)
    return rows


def _job(args: tuple[str, int, tuple[str, ...] | None, float | None]) -> list[dict[str, Any]]:
    figure, seed, names, duration = args
    configs = configurations(figure_base(figure))
    if names is not None:
        configs = {n: configs[n] for n in names}
    log = figure_stream(figure, seed, duration)
    rows = run_configs(log, configs, {"figure": figure, "seed": seed, "scenes": "world"})
    print(f"done {figure} seed {seed} ({len(configs)} configurations)", file=sys.stderr, flush=True)
    return rows


SPLIT = {"fig11": 3, "fig4": 4}
"""The long streams' configurations split over this many jobs (each simulates its stream)."""


def jobs(duration: float | None = None) -> list[tuple[str, int, tuple[str, ...] | None, float | None]]:
    """The study's jobs: the 15-minute streams first, then the long ones split (:data:`SPLIT`)."""
    out: list[tuple[str, int, tuple[str, ...] | None, float | None]] = []
    for fig in ("fig7", "fig13", "fig8", "fig9", "fig10"):
        out += [(fig, s, None, duration) for s in STREAMS[fig]]
    names = tuple(configurations(RatSLAMConfig()))
    for fig in ("fig11", "fig4"):
        out += [(fig, STREAMS[fig][0], names[k :: SPLIT[fig]], duration) for k in range(SPLIT[fig])]
    return out


def write_rows(path: Path, rows: Iterable[dict[str, Any]]) -> None:
    """The rows as CSV (atomically), columns :data:`COLUMNS`."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_open(path, "w") as f:
        w = csv.DictWriter(f, COLUMNS, lineterminator="\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


# ------------------------------------------------------------------------------- the scene model
def scene_variants(world_name: str) -> dict[str, Any]:
    """The small loop's scene model as shipped and two changes to it: finer scene cells (0.3 m and
    8 heading sectors: a view places the robot to 0.3 m) and a clean scene model (no aliasing, no
    blanks, no flicker: each place shows its own number; false positives set by the stream)."""
    world = load_world(world_name)
    s = world.scenes
    return {
        "world": world,
        "cells_0.3m": dataclasses.replace(world, scenes=dataclasses.replace(s, cell_size=0.3, heading_sectors=8)),
        "clean": dataclasses.replace(
            world, scenes=dataclasses.replace(s, alias_rate=0.0, blank_rate=0.0, flicker_prob=0.0)
        ),
    }


def _scene_job(args: tuple[str, int, str, float | None, bool]) -> list[dict[str, Any]]:
    figure, seed, variant, duration, no_fp = args
    fig = get_figure(figure)
    all_cfgs = configurations(figure_base(figure))
    names = ["published", "defaults", "published+offset_transitions", "published+view_confirm_ticks"]
    if variant == "no_views":  # pure path integration: the pose cells' gain without any view's pull
        log = figure_stream(figure, seed, duration)
        log = dataclasses.replace(log, scene_id=np.full(len(log), -1, dtype=log.scene_id.dtype))
        names = ["published", "published+trans_gain"]
    else:
        world = scene_variants(fig.world or "")[variant]
        log = simulate(world, duration=fig.duration if duration is None else duration, seed=seed,
                       bias_deg_s=0.0, fp_rate=0.0 if no_fp else fig.fp_rate)  # fmt: skip
    label = variant + ("+no_fp" if no_fp else "")
    rows = run_configs(log, {n: all_cfgs[n] for n in names}, {"figure": figure, "seed": seed, "scenes": label})
    print(f"done scenes {label} {figure} seed {seed}", file=sys.stderr, flush=True)
    return rows


SCENE_JOBS = [("cells_0.3m", False), ("clean", False), ("clean", True)]
"""The scene-model variants run on every seed of the small loop (and ``no_views`` on seed 0)."""


def closures(figure: str, seed: int, scenes: str, config: str, duration: float | None = None) -> str:
    """Markdown: each re-entry of one run that made a link (a loop closed), against ground truth:
    the tick, the experience and when it was made, eq 9's terms, the robot's and the
    experience's true headings and their distance. ``scenes``: "world" or a scene-model variant
    (:func:`scene_variants`, ``+no_fp`` for no false positives)."""
    fig = get_figure(figure)
    if scenes == "world":
        log = figure_stream(figure, seed, duration)
    else:
        variant, no_fp = scenes.removesuffix("+no_fp"), scenes.endswith("+no_fp")
        world = scene_variants(fig.world or "")[variant]
        log = simulate(world, duration=fig.duration if duration is None else duration, seed=seed,
                       bias_deg_s=0.0, fp_rate=0.0 if no_fp else fig.fp_rate)  # fmt: skip
    probe = Probe(configurations(figure_base(figure))[config])
    step_stream(log, {config: probe})
    gt, first = log.ground_truth(), probe.experience_first_tick
    out = [
        "| tick | experience (made at tick) | E_xy | E_theta | robot heading (deg) "
        "| experience heading (deg) | distance (m) |",
        "|---|---|---|---|---|---|---|",
    ]
    for k, kind, _, j, _, _, e_xy, e_th, link in probe.events:
        if kind == 1 and link >= 0:
            h_robot, h_exp = np.degrees(gt[k, 2]), np.degrees(gt[first[j], 2])
            d = math.hypot(*(gt[k, :2] - gt[first[j], :2]))
            out.append(f"| {k} | {j} ({first[j]}) | {e_xy:.2f} | {e_th:.2f} | {h_robot:.0f} | {h_exp:.0f} | {d:.2f} |")
    return "\n".join(out)


# ------------------------------------------------------------------------------------- tables
def _read(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _summary(values: list[float]) -> str:
    if not values:
        return "-"
    if len(values) == 1:
        return f"{values[0]:.2f}"
    return f"{np.median(values):.2f} [{min(values):.2f}-{max(values):.2f}]"


def tables(rows: list[dict[str, str]], column: str = "map_ate_m") -> str:
    """Markdown: per figure, published and defaults, then per switch its two configurations'
    ``column`` as median [range] over the seeds."""
    out = []
    for fig in STREAMS:
        mine = [r for r in rows if r["figure"] == fig and r["scenes"] == "world"]
        if not mine:
            continue

        def val(config: str, mine: list[dict[str, str]] = mine) -> str:
            return _summary([float(r[column]) for r in mine if r["config"] == config])

        seeds = sorted({r["seed"] for r in mine})
        out.append(f"\n**{fig}** (seeds {', '.join(seeds)}; {column}): published {val('published')}, "
                   f"defaults {val('defaults')}\n")  # fmt: skip
        out.append("| departure | on top of published | removed from defaults |")
        out.append("|---|---|---|")
        for s in switches():
            a = f"published-{s.name}" if s.local_view else f"published+{s.name}"
            label = f"{s.label} (switched off)" if s.local_view else s.label
            out.append(f"| {label} | {val(a)} | {val('defaults-' + s.name)} |")
        out.append(f"| re-entry fusion + odometry gate | {val('published+reentry_fusion+gate')} | - |")
    return "\n".join(out)


MECHANISM_COLUMNS = [
    ("reentries", "re-entries"),
    ("false_reentries", "false (> 1.5 m)"),
    ("heading_only", "E_xy = 0"),
    ("heading_only_false", "E_xy = 0, false"),
    ("place_only", "E_theta = 0"),
    ("one_tick", "on a 1-tick scene"),
    ("one_tick_false", "1-tick, false"),
    ("fp_scene", "on a false positive"),
    ("mid_snap", "< 50 ticks after a snap"),
    ("mid_snap_false", "after a snap, false"),
]
MECHANISM_LENGTHS = [
    ("heading_only_dist_m", "E_xy = 0: true distance (m)"),
    ("link_err_reentry_m", "re-entry link error (m)"),
    ("link_err_create_m", "new-experience link error (m)"),
    ("link_err_reentry_p90_m", "re-entry link error p90 (m)"),
    ("link_phi_err_reentry_deg", "re-entry link heading error (deg)"),
    ("link_phi_err_reentry_p90_deg", "re-entry link heading error p90 (deg)"),
    ("link_phi_err_create_deg", "new-experience link heading error (deg)"),
    ("reentry_offset_p90_m", "robot vs place at a linking re-entry p90 (m)"),
    ("reentry_heading_diff_p90_deg", "robot vs place heading at a linking re-entry p90 (deg)"),
    ("pc_gain", "pose cells / odometry"),
]


def mechanism_table(rows: list[dict[str, str]], figure: str, configs: list[str], scenes: str = "world") -> str:
    """Markdown: per configuration, the switch counts of :func:`mechanisms` summed over the seeds
    and its lengths as the median over the seeds."""
    mine = [r for r in rows if r["figure"] == figure and r["scenes"] == scenes]
    head = ["configuration", "map ATE (m)"] + [h for _, h in MECHANISM_COLUMNS] + [h for _, h in MECHANISM_LENGTHS]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for c in configs:
        rs = [r for r in mine if r["config"] == c]
        if not rs:
            continue
        cells = [c, _summary([float(r["map_ate_m"]) for r in rs])]
        cells += [str(sum(int(r[k]) for r in rs)) for k, _ in MECHANISM_COLUMNS]
        for k, _ in MECHANISM_LENGTHS:
            v = [float(r[k]) for r in rs if r[k] not in ("", "nan")]
            cells.append(f"{np.median(v):.3f}" if v else "-")
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


SCENE_CONFIGS = ["published", "defaults", "published+offset_transitions", "published+view_confirm_ticks"]


def scene_table(runs: list[dict[str, str]], scenes: list[dict[str, str]]) -> str:
    """Markdown: the small loop's map ATE (median [range] over the seeds) per scene model, for the
    configurations the scene-model runs step, with the published preset's switches on one-tick
    scenes, its false re-entries and the heading offset of its linking re-entries."""
    rows = [r for r in runs if r["figure"] == "fig7" and r["scenes"] == "world"] + [
        r for r in scenes if r["figure"] == "fig7" and r["scenes"] != "no_views"
    ]
    head = [*SCENE_CONFIGS, "published: re-entries on 1-tick scenes", "false", "heading offset p90 (deg)"]
    out = ["| scene model | " + " | ".join(head) + " |", "|" + "---|" * (len(head) + 1)]
    for model in dict.fromkeys(r["scenes"] for r in rows):
        mine = [r for r in rows if r["scenes"] == model]
        pub = [r for r in mine if r["config"] == "published"]
        cells = [_summary([float(r["map_ate_m"]) for r in mine if r["config"] == c]) for c in SCENE_CONFIGS]
        cells += [str(sum(int(r["one_tick"]) for r in pub)), str(sum(int(r["false_reentries"]) for r in pub))]
        cells.append(f"{np.median([float(r['reentry_heading_diff_p90_deg']) for r in pub]):.1f}")
        out.append(f"| {model} | " + " | ".join(cells) + " |")
    return "\n".join(out)


REPORT_HEAD = """\
# Fidelity study: each departure of the defaults from the published RatSLAM, alone

What this is and what the numbers mean: [docs/fidelity.md](../../docs/fidelity.md) (the study, the
measured causes, the scene-model question). This report holds every table, generated from the
committed CSVs:

- `runs.csv`: one row per (figure, seed, configuration) of the ablation: map and online ATE, the
  odometry's ATE, sizes, and the mechanism columns measured by the probe (below).
- `scenes.csv`: the small loop's published preset, defaults and two single departures on changed
  scene models (finer cells, a clean scene model with and without false positives) and with no
  views at all (pure path integration: the pose cells' own gain).
- `ablation.png`: the small loop and the open plan, each departure on top of the published
  preset and removed from the defaults (median and range over seeds 0-4).

Reproduce (2 worker processes; the run is resumable, one CSV per job beside `runs.csv`):

```bash
python -m harness.figures.fidelity run --out reports/fidelity/runs.csv --workers 2
python -m harness.figures.fidelity scenes --out reports/fidelity/scenes.csv --workers 2
python -m harness.figures.fidelity table reports/fidelity/runs.csv [--column online_ate_m]
python -m harness.figures.fidelity mechanisms reports/fidelity/runs.csv --figure FIG
python -m harness.figures.fidelity scene-table reports/fidelity/runs.csv reports/fidelity/scenes.csv
python -m harness.figures.fidelity closures --figure fig7 --seed 0 --scenes world --config published
python -m harness.figures.fidelity plot reports/fidelity/runs.csv --out reports/fidelity/ablation.png
python -m harness.figures.fidelity report reports/fidelity       # this report, from the two CSVs
```

Configurations: `published` = `RatSLAMConfig.published(base)`, `defaults` = `base` (the figure's
grid and path-integration bias on the defaults); `published+X` = the preset with departure X
alone on, `defaults-X` = the defaults with X alone at the preset's value; for the local-view
readings (on in both) `published-X` / `defaults-X` switch them off (`fatigue`:
`local_view.fatigue_rate = 1e-9`; `min_age`: `local_view.min_age_ticks = 1`);
`published+reentry_fusion+gate` = the fusion and the odometry gate together (the gate acts only
with the fusion).

![ablation](ablation.png)

## Experience-map ATE (m), median [range] over the seeds

`python -m harness.figures.fidelity table reports/fidelity/runs.csv`
"""

REPORT_MECHANISMS = """\

## Mechanisms, per configuration

`python -m harness.figures.fidelity mechanisms reports/fidelity/runs.csv --figure FIG`. Counts are summed
over the seeds, lengths are the median over the seeds of each run's statistic. A re-entry is a
switch to a known experience; false: the experience stands for a place more than 1.5 m from
where the robot truly was; E_xy = 0 / E_theta = 0: eq 9's place / heading term of the re-entered
experience was zero (only the sum form admits these); 1-tick scene: the scene number was reported
for one tick only; after a snap: within 50 ticks of one; link errors: a transition's position
(m) and heading (deg) against the true relative pose of its two experiences' places, for links
made at true re-entries and at new experiences; robot vs place: how far the robot truly was from
the re-entered experience's place (position, heading) at re-entries that made a link; pose cells
/ odometry: the peak's displacement over the odometry's in 1 s windows without a snap.

"""

REPORT_SCENES = """\
## The scene model

`python -m harness.figures.fidelity scene-table reports/fidelity/runs.csv reports/fidelity/scenes.csv`
(small loop, seeds 0-4; "world": as shipped, 1 m cells and 4 heading sectors, 10% aliased, 10%
blank, flicker at borders, 0.2% false positives per tick; `cells_0.3m`: 0.3 m cells and 8 sectors;
`clean`: no aliasing, blanks or flicker; `clean+no_fp`: and no false positives)

"""


def write_report(directory: Path) -> None:
    """``report.md`` of ``directory`` from its ``runs.csv`` and ``scenes.csv`` (the plot is
    :func:`plot`; the loop-closure tables rerun two 15-minute streams)."""
    runs, scenes = _read(directory / "runs.csv"), _read(directory / "scenes.csv")
    figures = [f for f in STREAMS if any(r["figure"] == f for r in runs)]
    parts = [REPORT_HEAD, tables(runs), "\n\n## Online ATE (m), median [range] over the seeds\n",
             "`python -m harness.figures.fidelity table reports/fidelity/runs.csv --column online_ate_m`",
             tables(runs, "online_ate_m"), "\n", REPORT_MECHANISMS]  # fmt: skip
    for fig in figures:
        parts += [
            f"### {fig}\n",
            mechanism_table(runs, fig, list(dict.fromkeys(r["config"] for r in runs if r["figure"] == fig))),
            "",
        ]
    parts += [REPORT_SCENES, scene_table(runs, scenes), ""]
    for model in ("cells_0.3m", "clean", "clean+no_fp"):
        parts += [f"### {model}\n", mechanism_table(scenes, "fig7", SCENE_CONFIGS, model), ""]
    parts += [
        "### The published preset's loop closures, fig7 seed 0\n",
        "`python -m harness.figures.fidelity closures --seed 0 --scenes clean+no_fp` (a clean scene model without "
        "false positives), then `--scenes world` (as shipped): each re-entry that made a link, against ground truth "
        "(headings and distance from the truth at the tick and where the experience was made).\n",
        closures("fig7", 0, "clean+no_fp", "published"),
        "",
        closures("fig7", 0, "world", "published"),
        "",
        "### No views (pure path integration, fig7 seed 0)\n",
        "| configuration | pose cells / odometry |",
        "|---|---|",
    ]
    parts += [f"| {r['config']} | {float(r['pc_gain']):.3f} |" for r in scenes if r["scenes"] == "no_views"]
    with atomic_open(directory / "report.md", "w") as out:
        out.write("\n".join(parts) + "\n")


def plot(rows: list[dict[str, str]], out: Path) -> None:
    """PNG: per switch, the map ATE of the small loop and the open plan (median, range over the
    seeds) with the departure on top of the published preset and removed from the defaults, beside
    the preset and the defaults themselves (log scale)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sw = switches()
    fig, axes = plt.subplots(1, 2, figsize=(13, 6), sharey=True)
    for ax, mode in zip(axes, ("on top of published", "removed from defaults")):
        for k, (figure, colour) in enumerate((("fig7", "tab:blue"), ("fig13", "tab:orange"))):
            mine = [r for r in rows if r["figure"] == figure and r["scenes"] == "world"]
            for i, s in enumerate(sw):
                if mode.startswith("on"):
                    config = f"published{'-' if s.local_view else '+'}{s.name}"
                else:
                    config = f"defaults-{s.name}"
                v = [float(r["map_ate_m"]) for r in mine if r["config"] == config]
                if not v:
                    continue
                y = i + (k - 0.5) * 0.3
                ax.plot([min(v), max(v)], [y, y], color=colour, lw=2)
                ax.plot(np.median(v), y, "o", color=colour, label=figure if i == 0 else None)
            for ref, style in (("published", "--"), ("defaults", ":")):
                v = [float(r["map_ate_m"]) for r in mine if r["config"] == ref]
                if v:
                    ax.axvline(np.median(v), color=colour, ls=style, lw=1)
        ax.set_xscale("log")
        ax.set_title(mode)
        ax.set_xlabel("experience-map ATE (m), median and range over seeds 0-4")
        ax.legend(loc="lower left" if mode.startswith("on") else "lower right")
    axes[0].set_yticks(range(len(sw)))
    axes[0].set_yticklabels([s.label + (" off" if s.local_view else "") for s in sw])
    axes[0].invert_yaxis()
    fig.suptitle("Experience-map ATE per departure (vertical lines: the published preset dashed, the defaults dotted)")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m harness.figures.fidelity", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    for name in ("run", "scenes"):
        p = sub.add_parser(name)
        p.add_argument("--out", type=Path, required=True)
        p.add_argument("--workers", type=int, default=2)
        p.add_argument("--duration", type=float, default=None, help="seconds per stream (default: the figure's)")
        p.add_argument("--figures", nargs="*", default=None, help="only these figures")
    t = sub.add_parser("table")
    t.add_argument("csv", type=Path)
    t.add_argument("--column", default="map_ate_m")
    cl = sub.add_parser("closures")
    cl.add_argument("--figure", default="fig7")
    cl.add_argument("--seed", type=int, default=0)
    cl.add_argument("--scenes", default="world")
    cl.add_argument("--config", default="published")
    st = sub.add_parser("scene-table")
    st.add_argument("runs", type=Path)
    st.add_argument("scenes", type=Path)
    m = sub.add_parser("mechanisms")
    m.add_argument("csv", type=Path)
    m.add_argument("--figure", default="fig7")
    m.add_argument("--scenes", default="world")
    m.add_argument("--configs", nargs="*", default=None, help="default: every configuration of the figure")
    rp = sub.add_parser("report")
    rp.add_argument("dir", type=Path)
    pl = sub.add_parser("plot")
    pl.add_argument("csv", type=Path)
    pl.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    if args.cmd == "table":
        print(tables(_read(args.csv), args.column))
        return 0
    if args.cmd == "closures":
        print(closures(args.figure, args.seed, args.scenes, args.config))
        return 0
    if args.cmd == "scene-table":
        print(scene_table(_read(args.runs), _read(args.scenes)))
        return 0
    if args.cmd == "mechanisms":
        data = _read(args.csv)
        configs = args.configs or list(dict.fromkeys(r["config"] for r in data if r["figure"] == args.figure))
        print(mechanism_table(data, args.figure, configs, args.scenes))
        return 0
    if args.cmd == "report":
        write_report(args.dir)
        return 0
    if args.cmd == "plot":
        plot(_read(args.csv), args.out)
        return 0
    if args.cmd == "run":
        todo: list[Any] = jobs(args.duration)
        fn: Any = _job
    else:
        todo = [("fig7", s, v, args.duration, fp) for v, fp in SCENE_JOBS for s in STREAMS["fig7"]]
        todo.append(("fig7", 0, "no_views", args.duration, False))
        fn = _scene_job
    parts = args.out.with_suffix(".parts")  # one CSV per job: a killed study resumes where it stopped
    parts.mkdir(parents=True, exist_ok=True)
    names = {f"{i:02d}_{j[0]}_{j[1]}": j for i, j in enumerate(todo) if args.figures is None or j[0] in args.figures}
    with ProcessPoolExecutor(max_workers=max(1, min(args.workers, 2))) as pool:
        futures = {pool.submit(fn, j): parts / f"{n}.csv" for n, j in names.items()
                   if not (parts / f"{n}.csv").exists()}  # fmt: skip
        for future in as_completed(futures):
            write_rows(futures[future], future.result())
    rows: list[dict[str, Any]] = [r for n in names for r in _read(parts / f"{n}.csv")]
    write_rows(args.out, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
