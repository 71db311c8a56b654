"""The goal-navigation experiment (``ratslam-harness nav WORLD``) into a run directory.

One exploration stream of the world (its default duration unless given) is fed to RatSLAM and to
the GTSAM pose graph; then ``n_goals`` goals drawn with the seed among the places visited are
driven in sequence, once on RatSLAM's experience map and once on the pose graph, in the pymunk
world (:func:`harness.navigation.closed_loop.run_navigation`, whose docstring says how a goal reaches a map,
how the robot is driven and how a goal is judged). RatSLAM runs with re-entry fusion weighted like
the pose graph, its fixes chained (:func:`harness.navigation.closed_loop.navigation_ratslam_config`).

The run directory (staged: it appears only when complete, see :mod:`harness.run.directory`):

- ``metrics.json``: per system the success rate, median and mean time ratio (time to arrival over
  the ground-truth shortest route's time at cruise speed, over the goals reached), replans and
  statuses; the per-goal table; the claims (RatSLAM reaches >= 95 % of goals, its median time
  ratio <= 1.3), GTSAM's value beside each; the settings (both configurations, the controller),
  timing and provenance (seed, package versions, git commit);
- ``report.md`` and ``routes.png`` (the world, the routes first planned to each goal drawn in the
  world frame, the true paths driven, the goals reached or not);
- ``ratslam_map.npz``: RatSLAM's state after the exploration (:meth:`ratslam.RatSLAM.save`); a
  loaded map plans the same routes as the live one did;
- ``recording.rrd`` (unless ``recording=False``): the exploration as every run records it
  (:mod:`harness.record.recorder`), then the navigation on the same ``tick`` timeline, RatSLAM's goals
  first, GTSAM's after: ``world/nav/<system>/goal`` (the goal's true place, green),
  ``world/nav/<system>/map_goal`` and ``world/nav/<system>/route`` (the goal point and the planned
  route, logged at each (re)plan, drawn in the world frame through the SE(2) alignment of the
  post-exploration map onto ground truth), ``world/nav/<system>/driven`` (the true path, one
  segment per tick), ``pose_cells/nav/route`` (RatSLAM's route through its experiences' pose
  cells: where consecutive experiences are more than ``pose_cells.snap_threshold_cells`` apart,
  the pose-cell representation jumps, drawn thin red) and ``metrics/nav/<system>/reached``,
  ``success_rate``, ``time_ratio`` (per goal).
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
import rerun as rr

from baselines import PoseGraphConfig
from worlds import InputError, ObservationLog, World, load_world
from worlds.files import atomic_write_text, read_json, write_json

from ..record.recorder import C_EXP, C_GTSAM, C_PEAK, C_SNAP, Recorder, _SegmentBuffer, _segments
from ..report import metrics as hm
from ..run.directory import provenance, staged_directory
from ..run.progress import Progress
from ..run.runner import dead_reckon
from .closed_loop import (
    SYSTEMS,
    GoalOutcome,
    NavigationHooks,
    NavigationResult,
    _finite,
    navigation_ratslam_config,
    run_navigation,
)

RUNS_DIR = Path("runs")  # default output: a fresh, git-ignored folder
SUCCESS_CLAIM = 0.95  # RatSLAM reaches at least this share of the goals
TIME_RATIO_CLAIM = 1.3  # RatSLAM's median time ratio is at most this


class NavigationInputError(InputError):
    """A bad navigation-experiment input (one line: option and problem)."""


def _check(n_goals: int, exploration_s: float | None, seed: int) -> None:
    if isinstance(n_goals, bool) or not isinstance(n_goals, (int, np.integer)) or n_goals < 1:
        raise NavigationInputError(f"--goals: must be a whole number of goals >= 1, got {n_goals!r}")
    if exploration_s is not None and not (math.isfinite(exploration_s) and exploration_s > 0):
        raise NavigationInputError(f"--exploration: must be a positive number of seconds, got {exploration_s!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise NavigationInputError(f"--seed: must be an integer, got {seed!r}")


# ---------------------------------------------------------------------------------- hooks
class _Alignment:
    """A map's frame -> the world's, from the post-exploration map against ground truth."""

    def __init__(self, poses: np.ndarray, ticks: np.ndarray, gt: np.ndarray):
        self.fit = None
        ticks = np.asarray(ticks, dtype=np.int64)
        ok = (ticks >= 0) & (ticks < len(gt))
        if ok.sum() >= 2:
            self.fit = hm.ate(np.asarray(poses, dtype=float)[ok], gt[ticks[ok]])

    def __call__(self, xy) -> np.ndarray:
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        return self.fit.apply(xy) if self.fit is not None else xy


class ExperimentHooks(NavigationHooks):
    """Saves the post-exploration RatSLAM map, keeps the routes first planned to each goal (world
    frame, for ``routes.png``) and, with ``recording``, writes ``recording.rrd`` (see the module
    docstring)."""

    def __init__(self, run_dir: Path, grid_shape, snap_threshold_cells: float, recording: bool = True):
        self.run_dir = Path(run_dir)
        self.grid_shape = tuple(int(g) for g in grid_shape)
        self.snap_threshold = float(snap_threshold_cells)
        self.recording = recording
        self.recorder: Recorder | None = None
        self.align: dict[str, _Alignment] = {}
        self.routes: dict[str, dict[int, np.ndarray]] = {s: {} for s in SYSTEMS}
        self.map_path = self.run_dir / "ratslam_map.npz"
        self._tick = 0
        self._dt = 1.0
        self._goal: dict[str, tuple[float, float]] = {}
        self._reached: dict[str, list[bool]] = {s: [] for s in SYSTEMS}
        self._buffers: dict = {}
        self._prev: dict[str, tuple[float, float]] = {}

    # ---------------------------------------------------------------- exploration
    def exploration_started(self, world: World, log: ObservationLog) -> None:
        self._log, self._gt, self._dt = log, log.ground_truth(), float(world.dt)
        if self.recording:
            self._odom = dead_reckon(log)
            self._fp = log.false_positive if log.false_positive is not None else np.zeros(len(log), bool)
            self.recorder = Recorder(self.run_dir / "recording.rrd", world.walls, self.grid_shape, navigation=True)
            self._buffers = {s: _SegmentBuffer(f"world/nav/{s}/driven", 70) for s in SYSTEMS}

    def exploration_tick(self, k: int, navs: dict) -> None:
        if self.recorder is not None:
            rs, pg = navs.get("ratslam"), navs.get("gtsam")
            self.recorder.log_tick(
                k,
                float(self._log.t[k]),
                self._gt[k],
                self._odom[k],
                None if rs is None else rs.slam,
                None if pg is None else pg.slam,
                bool(self._fp[k]),
            )

    def explored(self, navs: dict) -> None:
        if "ratslam" in navs:
            slam = navs["ratslam"].slam
            slam.save(self.map_path)
            self.align["ratslam"] = _Alignment(slam.experience_poses, slam.experience_first_tick, self._gt)
        if "gtsam" in navs:
            slam = navs["gtsam"].slam
            self.align["gtsam"] = _Alignment(slam.keyframe_poses, slam.keyframe_ticks, self._gt)
        if self.recorder is not None:
            self.recorder.finish_maps()
        self._tick = len(self._log)

    # ---------------------------------------------------------------- navigation
    def _time(self) -> None:
        assert self.recorder is not None
        self.recorder.rec.set_time("tick", sequence=self._tick)
        self.recorder.rec.set_time("sim_time", duration=self._tick * self._dt)

    def goal_started(self, system: str, goal: int, true_goal, map_goal) -> None:
        self._goal[system] = (float(map_goal[0]), float(map_goal[1]))
        if self.recorder is not None:
            self._time()
            rec = self.recorder.rec
            rec.log(f"world/nav/{system}/goal", rr.Points2D([true_goal], colors=[(60, 220, 60, 255)], radii=[0.25]))
            if math.isfinite(map_goal[0]):
                where = self.align[system](map_goal)
                rec.log(f"world/nav/{system}/map_goal", rr.Points2D(where, colors=[_colour(system)], radii=[0.12]))

    def planned(self, system: str, goal: int, nav, nodes: np.ndarray) -> None:
        nodes = np.asarray(nodes, dtype=np.int64)
        pts = np.vstack((nav.node_xy(nodes), [self._goal[system]])) if len(nodes) else np.zeros((0, 2))
        xy = self.align[system](pts)
        self.routes[system].setdefault(goal, xy)
        if self.recorder is None:
            return
        self._time()
        rec = self.recorder.rec
        rec.log(
            f"world/nav/{system}/route",
            rr.LineStrips2D([xy] if len(xy) else [], colors=[_colour(system)], radii=[0.06]),
        )
        if system == "ratslam":
            cells = nav.slam.experience_map.cells[nodes, :2] + 0.5  # cell i covers [i, i + 1) in the image
            if len(cells) >= 2:
                segs = np.stack((cells[:-1], cells[1:]), axis=1)
                n = np.array(self.grid_shape[:2], dtype=float)
                d = np.abs(cells[1:] - cells[:-1])
                jump = np.hypot(*np.minimum(d, n - d).T) > self.snap_threshold
                jump |= np.any(d > n / 2, axis=1)  # wrapped around the grid
                colours = np.where(jump[:, None], np.array(C_SNAP), np.array(C_PEAK)).astype(np.uint8)
                radii = np.where(jump, 0.08, 0.3).astype(np.float32)
                rec.log("pose_cells/nav/route", rr.LineStrips2D(_segments(segs), colors=colours, radii=radii))
            else:
                rec.log("pose_cells/nav/route", rr.LineStrips2D([]))

    def navigation_tick(self, system: str, goal: int, true_pose, nav) -> None:
        self._tick += 1
        if self.recorder is None:
            return
        buf = self._buffers[system]
        here = (float(true_pose[0]), float(true_pose[1]))
        prev = self._prev.get(system)
        self._prev[system] = here
        if prev is not None and buf.add(self._tick, self._tick * self._dt, prev, here, _colour(system), 0.03):
            buf.send(self.recorder.rec)

    def goal_ended(self, system: str, outcome: GoalOutcome) -> None:
        self._reached[system].append(outcome.reached)
        if self.recorder is None:
            return
        self._time()
        rec = self.recorder.rec
        reached = self._reached[system]
        rec.log(f"metrics/nav/{system}/reached", rr.Scalars([float(outcome.reached)]))
        rec.log(f"metrics/nav/{system}/success_rate", rr.Scalars([sum(reached) / len(reached)]))
        if outcome.reached:
            rec.log(f"metrics/nav/{system}/time_ratio", rr.Scalars([outcome.time_ratio]))

    def map_ate(self) -> dict[str, float]:
        """Each post-exploration map's ATE (m): RatSLAM's experiences against the true poses when
        they were created, GTSAM's keyframes against the true poses when they were taken."""
        return {s: a.fit.rmse for s, a in self.align.items() if a.fit is not None}

    # ---------------------------------------------------------------- closing
    def close(self) -> None:
        if self.recorder is not None:
            for buf in self._buffers.values():
                buf.send(self.recorder.rec)
            self.recorder.close()

    def abort(self) -> None:
        if self.recorder is not None:
            self.recorder.abort()


def _colour(system: str) -> tuple[int, int, int, int]:
    return C_EXP if system == "ratslam" else C_GTSAM


# ---------------------------------------------------------------------------------- metrics
def claims(result: NavigationResult) -> list[dict]:
    """The experiment's claims, measured on RatSLAM, with GTSAM's value beside each."""
    out = []
    for key, statement, threshold, holds in (
        ("success_rate", f"RatSLAM reaches at least {SUCCESS_CLAIM:.0%} of the goals", SUCCESS_CLAIM, _at_least),
        (
            "median_time_ratio",
            f"RatSLAM's median time ratio (time to the goal over the shortest route's at cruise speed, goals "
            f"reached) is at most {TIME_RATIO_CLAIM}",
            TIME_RATIO_CLAIM,
            _at_most,
        ),
    ):
        row: dict = {"id": key, "statement": statement, "threshold": threshold}
        for system, nav in result.systems.items():
            value = nav.summary()[key]
            row[system] = value
            row[f"{system}_meets"] = holds(value, threshold)
        row["held"] = row.get("ratslam_meets", False)
        out.append(row)
    return out


def _at_least(v: float, t: float) -> bool:
    return bool(math.isfinite(v) and v >= t)


def _at_most(v: float, t: float) -> bool:
    return bool(math.isfinite(v) and v <= t)


def experiment_metrics(result: NavigationResult, wall_s: float, map_ate: dict | None = None) -> dict:
    """metrics.json's content: the result, its claims, the post-exploration maps' ATE (``map_ate``:
    system -> m), timing and provenance."""
    d = result.to_dict()
    return {
        "experiment": "nav",
        "world": d["world"],
        "seed": d["seed"],
        "exploration_s": d["exploration_s"],
        "n_goals": d["n_goals"],
        "claims": claims(result),
        "summary": {s: v["summary"] for s, v in d["systems"].items()},
        "exploration_map_ate_m": map_ate or {},
        "goals": {s: v["goals"] for s, v in d["systems"].items()},
        "settings": d["settings"],
        "timing": {"wall_s": wall_s},
        "provenance": provenance(
            experiment="nav", world=d["world"], seed=d["seed"], exploration_s=d["exploration_s"], n_goals=d["n_goals"]
        ),
    }


# ---------------------------------------------------------------------------------- outputs
def plot_routes(world: World, result: NavigationResult, routes: dict, path) -> Path:
    """``routes.png``: one panel per system: the world, the true paths driven, the routes first
    planned to each goal (world frame), the goals (green: reached, red: not)."""
    import matplotlib.pyplot as plt

    from worlds.plot import draw_world, save_figure

    systems = list(result.systems)
    w, h = world.size
    fig, axes = plt.subplots(len(systems), 1, figsize=(min(14.0, 2.0 + w * 0.35), len(systems) * (1.8 + h * 0.35)))
    axes = np.atleast_1d(axes)
    for ax, system in zip(axes, systems):
        nav = result.systems[system]
        draw_world(ax, world, route=False)
        true = nav.trace.get("true")
        if true is not None and len(true):
            ax.plot(true[:, 0], true[:, 1], color="0.55", lw=0.5, alpha=0.8, label="driven (true)", zorder=4)
        first = True
        for _, xy in sorted(routes.get(system, {}).items()):
            if len(xy) >= 2:
                ax.plot(
                    xy[:, 0], xy[:, 1], color="tab:blue" if system == "ratslam" else "tab:purple", lw=0.8,
                    alpha=0.6, ls="--", label="planned (map, aligned)" if first else None, zorder=5,
                )  # fmt: skip
                first = False
        ok = np.array([o.reached for o in nav.outcomes], dtype=bool)
        goals = np.array([o.true_goal for o in nav.outcomes], dtype=float).reshape(-1, 2)
        if ok.any():
            ax.plot(goals[ok, 0], goals[ok, 1], "o", color="tab:green", ms=6, label="goal reached", zorder=6)
        if (~ok).any():
            ax.plot(goals[~ok, 0], goals[~ok, 1], "X", color="tab:red", ms=8, label="goal not reached", zorder=6)
        s = nav.summary()
        ax.set_title(
            f"{system}: {s['reached']}/{s['goals']} goals reached, median time ratio {s['median_time_ratio']:.2f}"
        )
        ax.legend(loc="upper right", fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path)


def _fmt(v, spec: str = ".2f") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "n/a"
    return format(v, spec)


def is_nav_run(run_dir) -> bool:
    """Whether ``run_dir`` holds a navigation experiment's metrics (``"experiment": "nav"``)."""
    try:
        m = read_json(Path(run_dir) / "metrics.json")
    except (OSError, ValueError):
        return False  # not readable: the run directory's own report says why
    return isinstance(m, dict) and m.get("experiment") == "nav"


def rebuild_nav_report(run_dir) -> Path:
    """``report.md`` of a navigation run directory rebuilt from its ``metrics.json``."""
    run_dir = Path(run_dir)
    try:
        return write_report(run_dir, read_json(run_dir / "metrics.json"), (run_dir / "recording.rrd").is_file())
    except (KeyError, TypeError) as e:
        raise NavigationInputError(f"{run_dir / 'metrics.json'}: not a complete navigation run ({e!r})") from None


def write_report(run_dir: Path, m: dict, recording: bool) -> Path:
    """``report.md`` from the experiment's metrics."""
    systems = list(m["summary"])
    lines = [
        f"# Goal navigation on {m['world']}: RatSLAM's experience map beside the GTSAM pose graph",
        "",
        f"Exploration: {m['exploration_s']:g} s of the world's route stream (seed {m['seed']}); then "
        f"{m['n_goals']} goals, drawn among the places visited (successive goals at least "
        f"{m['settings']['goal_separation_m']:g} m apart), driven in sequence in the pymunk world, once on each "
        "map, from the same exploration. The controller sees only the system's navigator (pose, plan, node "
        "positions); the plan is the quickest route over the map's transition times (RatSLAM) or the "
        "keyframes joined by odometry and accepted closures (GTSAM).",
        "",
        f"Reached: the controller declared arrival and the robot is truly within "
        f"{m['settings']['success_radius_m']:g} m of the goal's place. Time ratio: time to arrival over "
        "the ground-truth shortest route along the world's route network at the robot's cruise speed "
        f"(goals reached only). Timeout: {m['settings']['timeout']}. RatSLAM runs with re-entry fusion "
        "weighted like the pose graph's closures and odometry, its fixes chained, its odometry trusted "
        "throughout and no loop-closure sequence (`navigation_ratslam_config`, whose module says why). "
        + (
            "Navigating, RatSLAM's explored map is fixed and the robot localised on it "
            "(`ratslam.localisation`: a Kalman filter on the odometry and scene sightings, relocalisation "
            "from their sequence, the way back when lost). "
            if m["settings"].get("ratslam_navigation", "").startswith("localisation")
            else "Navigating, RatSLAM goes on stepping (`--stepping`). "
        )
        + "The world's "
        + (
            "look-alike regions show the same scenes (the world as shipped)."
            if m["settings"]["lookalikes"]
            else "look-alike regions show their own scenes (`--no-lookalikes`)."
        ),
        "",
        "## Claims",
        "",
        "| claim | threshold | RatSLAM | held | GTSAM (beside it) | GTSAM meets |",
        "|---|---|---|---|---|---|",
    ]
    for c in m["claims"]:
        spec = ".0%" if c["id"] == "success_rate" else ".2f"
        lines.append(
            f"| {c['statement']} | {_fmt(c['threshold'], spec)} | {_fmt(c.get('ratslam'), spec)} | "
            f"{'yes' if c['held'] else '**no**'} | {_fmt(c.get('gtsam'), spec)} | "
            f"{'yes' if c.get('gtsam_meets') else 'no'} |"
        )
    lines += ["", "## Summary", "", "| | " + " | ".join(systems) + " |", "|---" * (len(systems) + 1) + "|"]
    rows = (
        ("goals reached", lambda s: f"{s['reached']}/{s['goals']}"),
        ("success rate", lambda s: _fmt(s["success_rate"], ".0%")),
        ("median time ratio", lambda s: _fmt(s["median_time_ratio"])),
        ("mean time ratio", lambda s: _fmt(s["mean_time_ratio"])),
        ("90th percentile time ratio", lambda s: _fmt(s["p90_time_ratio"])),
        ("replans (total / goals with any)", lambda s: f"{s['replans_total']} / {s['goals_with_replans']}"),
        ("arrival error median / max (m)",
         lambda s: f"{_fmt(s['arrival_error_median_m'])} / {_fmt(s['arrival_error_max_m'])}"),
        ("outcomes", lambda s: ", ".join(f"{k} {v}" for k, v in sorted(s["statuses"].items()))),
        ("localiser: sightings matched / relocalisations / times lost (ways back given up)",
         lambda s: "{sightings_matched} / {relocalisations} / {times_lost} ({ways_back_given_up})".format(
             **s["localiser"]) if "localiser" in s else "–"),
    )  # fmt: skip
    for label, f in rows:
        lines.append(f"| {label} | " + " | ".join(f(m["summary"][s]) for s in systems) + " |")
    ate = m.get("exploration_map_ate_m", {})
    lines.append("| map ATE after the exploration (m) | " + " | ".join(_fmt(ate.get(s)) for s in systems) + " |")
    lines += ["", "![routes](routes.png)", "", "## Goals", ""]
    lines.append(
        "| goal | true place (m) | shortest (s) | "
        + " | ".join(f"{s} outcome, time ratio, replans" for s in systems)
        + " |"
    )
    lines.append("|---" * (3 + len(systems)) + "|")
    for i in range(m["n_goals"]):
        cells = []
        first = m["goals"][systems[0]][i]
        for s in systems:
            g = m["goals"][s][i]
            cells.append(f"{g['status']}, {_fmt(g['time_ratio'])}, {g['replans']}")
        x, y = first["true_goal"]
        lines.append(f"| {i} | ({x:.1f}, {y:.1f}) | {first['shortest_time_s']:.0f} | " + " | ".join(cells) + " |")
    lines += ["", "## Files", "", "- `metrics.json`: everything above, the settings and provenance"]
    lines.append("- `ratslam_map.npz`: RatSLAM after the exploration (`RatSLAM.load` it and plan on it)")
    if recording:
        lines.append("- `recording.rrd`: exploration then navigation (open it with `rerun recording.rrd`)")
    p = m["provenance"]
    lines += ["", f"Commit {p['git_commit']}, {p['created_utc']}, wall time {m['timing']['wall_s']:.0f} s.", ""]
    return atomic_write_text(Path(run_dir) / "report.md", "\n".join(lines))


# ---------------------------------------------------------------------------------- the run
def run_nav_experiment(
    world: str | Path,
    out=None,
    seed: int = 0,
    n_goals: int = 50,
    exploration_s: float | None = None,
    recording: bool = True,
    show_progress: bool = True,
    lookalikes: bool = True,
    ratslam_localise: bool = True,
) -> Path:
    """Run the navigation experiment on ``world`` into ``out`` (default ``runs/nav_WORLD``);
    ``exploration_s`` None: the world's duration; ``lookalikes=False``: the world's look-alike
    regions show their own scenes (as Fig 4's distinct_rooms variant); ``ratslam_localise``
    (default): navigate RatSLAM's explored map, fixed, by :mod:`ratslam.localisation`; False: with
    RatSLAM stepping on.
    Returns the run directory."""
    _check(n_goals, exploration_s, seed)
    w = load_world(world)
    exploration = float(w.duration if exploration_s is None else exploration_s)
    out = Path(out) if out else RUNS_DIR / f"nav_{w.name}"
    pg_config = PoseGraphConfig()
    rs_config = navigation_ratslam_config(pg_config)
    progress = _Progress(show_progress, w.dt)
    world_file = (Path(world),) if Path(world).suffix == ".toml" else ()
    with staged_directory(out, world_file) as stage:
        hooks = ExperimentHooks(stage, rs_config.shape, rs_config.pose_cells.snap_threshold_cells, recording)
        t0 = time.perf_counter()
        try:
            result = run_navigation(
                w, exploration, n_goals, int(seed), ratslam_config=rs_config, gtsam_config=pg_config, trace=True,
                lookalikes=lookalikes, progress=progress, hooks=hooks, ratslam_localise=ratslam_localise,
            )  # fmt: skip
        except BaseException:
            hooks.abort()
            raise
        hooks.close()
        m = experiment_metrics(result, time.perf_counter() - t0, hooks.map_ate())
        write_json(stage / "metrics.json", _finite(m))
        plot_routes(w, result, hooks.routes, stage / "routes.png")
        write_report(stage, m, recording)
    return out


class _Progress:
    """Exploration ticks, then goals per system, on stderr."""

    def __init__(self, enabled: bool, dt: float):
        self.enabled = enabled
        self._bar = Progress(1, "exploration", dt, enabled=enabled)  # the clock starts now

    def __call__(self, system: str, done: int, total: int) -> None:
        if not self.enabled:
            return
        if system == "exploration":
            self._bar(done, total)
        elif done == total or done % 10 == 0:
            print(f"navigation on {system}: {done}/{total} goals", file=sys.stderr, flush=True)
