"""Closed-loop goal navigation on RatSLAM's experience map and on the GTSAM pose graph.

Exploration: the world's usual route stream (:func:`worlds.simulate`) for ``exploration_s``
seconds is fed tick by tick to RatSLAM and to the pose graph. Then ``n_goals`` goals, drawn with
the seed among places the robot visited while exploring (successive goals at least 3 m apart),
are driven to one after the other, once navigating on each system's map, both starting from the
same exploration stream and the robot's final pose.

How a goal reaches a SLAM system. A user would click on the map where they want the robot to go.
The click is simulated without ground truth entering the SLAM: for a goal drawn at exploration
tick ``k`` (true place ``gt[k]``), the goal point is where the system itself put the robot at tick
``k``, as its map places it now. At tick ``k`` the system's pose is recorded relative to the node it
was at (RatSLAM: the current experience, created or last re-entered nearest before ``k``; the
pose graph: the latest keyframe); when the goal is issued, that relative pose is composed with the
node's current map pose (loop closures and the map correction have moved it since). For a place
seen for the first time at ``k`` this is the map pose of the experience/keyframe created nearest
in time; for a revisit it is the node the system recognised the place as.

Driving. The controller (:mod:`harness.navigation.controller`) is given only the system's navigator (its
pose, its plans, its nodes' map positions); it drives the pymunk robot (:class:`worlds.drive.Drive`,
walls still block) and the system keeps stepping on the new observations. Replanning rule: see the
controller. A goal ends when the controller declares arrival (its pose within ``arrive_m`` of the
goal point) or at the timeout, ``timeout_factor`` x the shortest route's time + ``timeout_extra_s``.

RatSLAM's configuration. Unless one is given, RatSLAM runs with its re-entry fusion on, weighted
by the same noise model the pose graph gives its loop closures and odometry
(:func:`navigation_ratslam_config`): a scene match as a 1 m cell and a 90 deg sector deserve
(sigma 0.41 m, 37 deg), the odometry trusted throughout (the pose graph's is), the fixes chained
(``reentry.chain_fixes``) and no loop-closure sequence. Why, with the measurements: docs/navigation.md
("RatSLAM's configuration for navigating").

Judging (ground truth, metrics only). Reached = the controller declared arrival and the robot's
true position is within ``success_radius`` m of the goal's true place; an arrival farther away is
"wrong place". Time ratio = time to arrival over the shortest route's time: the shortest path on
the world's route network from the robot's true position to the goal's at the robot's cruise speed.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from baselines import PoseGraphConfig, PoseGraphSLAM
from baselines.navigation import PoseGraphNavigator
from ratslam import RatSLAM, RatSLAMConfig
from ratslam.localisation import LocaliserConfig
from ratslam.navigation import ExperienceMapNavigator, LocalisingNavigator
from worlds import ObservationLog, World, load_world, simulate
from worlds.drive import Drive

from ..run.conditions import condition_world
from ..run.stream import step_stream
from .controller import ControllerParams, RouteController
from .goals import draw_goal_ticks, route_network_distance

SYSTEMS = ("ratslam", "gtsam")
GOAL_SEPARATION_M = 3.0
FIRST_GOAL_S = 30.0  # goals are drawn from exploration ticks after this (the maps exist by then)


class NavigationHooks:
    """Observers of :func:`run_navigation`, called at fixed points (the default does nothing).

    They see the systems' navigators and the simulator's stream and may record or save them, but
    must not step or change them: the experiment's outcome does not depend on the hooks."""

    def exploration_started(self, world: World, log: ObservationLog) -> None:
        """Before the first exploration tick: the whole exploration stream (with ground truth)."""

    def exploration_tick(self, k: int, navs: dict) -> None:
        """After exploration tick ``k`` was fed to every system (``navs``: system -> navigator)."""

    def explored(self, navs: dict) -> None:
        """After the exploration, before the first goal: the post-exploration maps."""

    def goal_started(self, system: str, goal: int, true_goal: tuple[float, float], map_goal) -> None:
        """Goal ``goal`` handed to ``system`` (``map_goal`` in the system's map frame)."""

    def planned(self, system: str, goal: int, nav, nodes: np.ndarray) -> None:
        """A route was planned (first plan or replan) on ``system``'s map: its ``nodes``."""

    def navigation_tick(self, system: str, goal: int, true_pose, nav) -> None:
        """One tick driven on ``system``'s map (``true_pose``: ground truth, for the record only)."""

    def goal_ended(self, system: str, outcome: GoalOutcome) -> None:
        """The goal's outcome on ``system``'s map."""


@dataclass(frozen=True)
class GoalOutcome:
    """One goal driven on one system's map."""

    index: int
    tick: int  # exploration tick whose place is the goal
    true_goal: tuple[float, float]
    true_start: tuple[float, float]
    map_goal: tuple[float, float]  # the goal point handed to the system (its map frame)
    status: str  # reached, wrong place, timeout, or the plan's failure
    time_s: float  # until arrival or the end (timeout / no plan)
    shortest_time_s: float  # route-network shortest path at cruise speed
    replans: int
    final_error_m: float  # true distance to the goal's place at the end

    @property
    def reached(self) -> bool:
        return self.status == "reached"

    @property
    def time_ratio(self) -> float:
        return self.time_s / self.shortest_time_s if self.reached else math.nan


@dataclass
class SystemNavigation:
    """All goals on one system's map, with the summary metrics."""

    system: str
    outcomes: list[GoalOutcome]
    trace: dict = field(default_factory=dict, repr=False)  # per-tick arrays, not written to JSON
    localiser: dict = field(default_factory=dict)  # RatSLAM on a fixed map: MapLocaliser.stats()

    @property
    def success_rate(self) -> float:
        return sum(o.reached for o in self.outcomes) / max(len(self.outcomes), 1)

    @property
    def time_ratios(self) -> np.ndarray:
        return np.array([o.time_ratio for o in self.outcomes if o.reached])

    @property
    def median_time_ratio(self) -> float:
        r = self.time_ratios
        return float(np.median(r)) if len(r) else math.nan

    def summary(self) -> dict:
        r = self.time_ratios
        statuses: dict[str, int] = {}
        for o in self.outcomes:
            statuses[o.status] = statuses.get(o.status, 0) + 1
        err = np.array([o.final_error_m for o in self.outcomes if o.status in ("reached", "wrong place")])
        return {
            "goals": len(self.outcomes),
            "reached": sum(o.reached for o in self.outcomes),
            "success_rate": self.success_rate,
            "median_time_ratio": self.median_time_ratio,
            "mean_time_ratio": float(np.mean(r)) if len(r) else math.nan,
            "p90_time_ratio": float(np.percentile(r, 90)) if len(r) else math.nan,
            "replans_total": sum(o.replans for o in self.outcomes),
            "goals_with_replans": sum(o.replans > 0 for o in self.outcomes),
            "statuses": statuses,
            "arrival_error_median_m": float(np.median(err)) if len(err) else math.nan,
            "arrival_error_max_m": float(err.max()) if len(err) else math.nan,
        } | ({"localiser": self.localiser} if self.localiser else {})


@dataclass
class NavigationResult:
    """A navigation experiment: its set-up and, per system, every goal's outcome."""

    world: str
    exploration_s: float
    n_goals: int
    seed: int
    settings: dict
    systems: dict[str, SystemNavigation]

    def to_dict(self) -> dict:
        return {
            "world": self.world,
            "exploration_s": self.exploration_s,
            "n_goals": self.n_goals,
            "seed": self.seed,
            "settings": self.settings,
            "systems": {
                name: {
                    "summary": s.summary(),
                    "goals": [dataclasses.asdict(o) | {"time_ratio": o.time_ratio} for o in s.outcomes],
                }
                for name, s in self.systems.items()
            },
        }

    def write_json(self, path) -> None:
        """Write :meth:`to_dict` as JSON (NaN/inf written as null)."""
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(json.dumps(_finite(self.to_dict()), indent=2) + "\n")


def _finite(x):
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    return x


def _relative(node, pose) -> tuple[float, float, float]:
    """``pose`` expressed in the frame of ``node`` (both (x, y, θ))."""
    c, s = math.cos(node[2]), math.sin(node[2])
    dx, dy = pose[0] - node[0], pose[1] - node[1]
    return c * dx + s * dy, -s * dx + c * dy, pose[2] - node[2]


def _compose(node, rel) -> tuple[float, float]:
    c, s = math.cos(node[2]), math.sin(node[2])
    return node[0] + c * rel[0] - s * rel[1], node[1] + s * rel[0] + c * rel[1]


def navigation_ratslam_config(pose_graph: PoseGraphConfig | None = None, **reentry) -> RatSLAMConfig:
    """RatSLAM's defaults with re-entry fusion weighted like the pose graph's loop closures and
    odometry (``closures.sigma_xy_m``, ``closures.sigma_theta_rad``, ``odometry.sigma_v_m_s``,
    ``odometry.sigma_w_rad_s``): both systems then trust a scene match and the wheels alike; the
    odometry trusted throughout, the fixes chained, no loop-closure sequence (module docstring).
    ``reentry`` overrides fields of :class:`ratslam.ReentryFusionConfig`."""
    pg = pose_graph or PoseGraphConfig()
    fields = {
        "position_sigma_m": pg.closures.sigma_xy_m,
        "heading_sigma_deg": math.degrees(pg.closures.sigma_theta_rad),
        "odom_speed_noise_m_s": pg.odometry.sigma_v_m_s,
        "odom_heading_noise_rad_s": pg.odometry.sigma_w_rad_s,
        "odometry_trust_limit": math.inf,  # the pose graph trusts its odometry model throughout
        "chain_fixes": True,  # on a known map, a pose is as good as its latest fix (module doc)
    }
    # a re-entry held for the next scene's agreement leaves the robot on a new experience off the
    # map's routes (module doc)
    return RatSLAMConfig().replace(reentry=fields | reentry, experience_map={"loop_closure_sequence": False})


def localiser_config(rs_config: RatSLAMConfig) -> LocaliserConfig:
    """The map localiser weighted as RatSLAM's re-entry fusion is: a scene places the robot
    within ``reentry.position_sigma_m``, the odometry's noise is the fusion's."""
    r = rs_config.reentry
    return LocaliserConfig(
        position_sigma_m=r.position_sigma_m if r.enabled else LocaliserConfig().position_sigma_m,
        odom_speed_noise_m_s=r.odom_speed_noise_m_s,
        odom_heading_noise_rad_s=r.odom_heading_noise_rad_s,
    )


def _navigator(system: str, slam):
    return ExperienceMapNavigator(slam) if system == "ratslam" else PoseGraphNavigator(slam)


def run_navigation(
    world_name: str | World,
    exploration_s: float,
    n_goals: int = 50,
    seed: int = 0,
    *,
    systems: tuple[str, ...] = SYSTEMS,
    success_radius: float = 1.0,
    goal_radius: float = 1.0,
    lookalikes: bool = True,
    ratslam_config: RatSLAMConfig | None = None,
    ratslam_localise: bool = True,
    gtsam_config: PoseGraphConfig | None = None,
    controller: ControllerParams | None = None,
    timeout_factor: float = 3.0,
    timeout_extra_s: float = 60.0,
    out: str | Path | None = None,
    trace: bool = False,
    progress: Callable[[str, int, int], None] | None = None,
    hooks: NavigationHooks | None = None,
) -> NavigationResult:
    """Explore ``world_name`` for ``exploration_s`` s, then drive to ``n_goals`` goals on each
    system's map (see the module docstring). ``goal_radius``: a node within this of the goal
    point is the goal node; ``success_radius``: judged on ground truth; ``lookalikes=False``: the
    world's look-alike regions show their own scenes. Writes JSON to ``out`` if given;
    ``ratslam_config`` None: :func:`navigation_ratslam_config`; ``ratslam_localise`` (default):
    navigate RatSLAM's explored map, fixed, by :mod:`ratslam.localisation` (False: with RatSLAM
    stepping on); ``trace`` keeps per-tick true and estimated poses; ``progress(system, done,
    total)``: system "exploration" counts ticks, the others goals; ``hooks``: observers
    (recording, saving the map; see :class:`NavigationHooks`)."""
    for s in systems:
        if s not in SYSTEMS:
            raise ValueError(f"unknown system {s!r} (known: {', '.join(SYSTEMS)})")
    hooks = hooks if hooks is not None else NavigationHooks()
    world = condition_world(load_world(world_name), {"lookalikes": lookalikes})
    log = simulate(world, duration=exploration_s, seed=seed)
    gt = log.ground_truth()
    first = min(int(FIRST_GOAL_S / world.dt), len(log) - 1)
    goal_ticks = draw_goal_ticks(
        gt[:, :2], n_goals, np.random.default_rng([seed, 11]), gt[-1, :2], GOAL_SEPARATION_M, first
    )

    # Exploration: both systems on the same stream; at each goal tick, remember where each
    # system put the robot relative to the node it was at.
    pg_config = gtsam_config or PoseGraphConfig()
    rs_config = ratslam_config or navigation_ratslam_config(pg_config)
    navs = {s: _navigator(s, RatSLAM(rs_config) if s == "ratslam" else PoseGraphSLAM(pg_config)) for s in systems}
    anchors: dict[str, dict[int, tuple[int, tuple[float, float, float]]]] = {s: {} for s in systems}
    wanted = set(goal_ticks.tolist())
    hooks.exploration_started(world, log)

    def at_tick(k: int, stepped) -> None:
        if k in wanted:
            for s in systems:
                node = navs[s].current_node
                rel = _relative(navs[s].node_pose(node), navs[s].pose) if node >= 0 else (0.0, 0.0, 0.0)
                anchors[s][k] = (node, rel)
        hooks.exploration_tick(k, navs)

    report = None if progress is None else (lambda done, total: progress("exploration", done, total))
    step_stream(log, navs, on_tick=at_tick, progress=report, finalize=False)
    if progress is not None:
        progress("exploration", len(log), len(log))
    hooks.explored(navs)
    seen = log.scene_id[np.sort(np.unique(log.scene_id, return_index=True)[1])]

    params = controller or ControllerParams(speed=world.robot.speed, max_turn_rate_deg=world.robot.max_turn_rate_deg)
    results = {}
    for s in systems:
        navs[s].goal_radius = goal_radius
        if s == "ratslam" and ratslam_localise:
            navs[s] = LocalisingNavigator(navs[s].slam, localiser_config(rs_config), goal_radius)
        drive = Drive(world, gt[-1], seed=seed, seen_scenes=seen)
        results[s] = _navigate(
            s, navs[s], drive, world, gt, goal_ticks, anchors[s], params, success_radius,
            timeout_factor, timeout_extra_s, trace, progress, hooks,
        )  # fmt: skip
    result = NavigationResult(
        world=world.name,
        exploration_s=float(exploration_s),
        n_goals=n_goals,
        seed=seed,
        settings={
            "success_radius_m": success_radius,
            "goal_radius_m": goal_radius,
            "lookalikes": lookalikes,
            "goal_separation_m": GOAL_SEPARATION_M,
            "timeout": f"{timeout_factor} x shortest route time + {timeout_extra_s} s",
            "controller": dataclasses.asdict(params),
            "ratslam_config": dataclasses.asdict(rs_config),
            "ratslam_navigation": (
                "localisation on the explored map (ratslam.localisation)"
                if ratslam_localise
                else "RatSLAM stepping (pose cells, view cells, experience map)"
            ),
            "gtsam_config": dataclasses.asdict(pg_config),
        },
        systems=results,
    )
    if out is not None:
        result.write_json(out)
    return result


def _navigate(
    system, nav, drive, world, gt, goal_ticks, anchors, params, success_radius, timeout_factor, timeout_extra_s, trace,
    progress, hooks,
) -> SystemNavigation:  # fmt: skip
    """Drive to every goal in turn on one system's map."""
    dt = world.dt
    ctrl = RouteController(nav, params)
    outcomes = []
    tr: dict[str, list] = {"true": [], "estimate": [], "goal": []}
    for g, k in enumerate(goal_ticks.tolist()):
        true_goal = (float(gt[k, 0]), float(gt[k, 1]))
        start = drive.true_pose
        shortest = route_network_distance(world, start[:2], true_goal) / params.speed
        node, rel = anchors[k]
        map_goal = _compose(nav.node_pose(node), rel) if node >= 0 else (math.nan, math.nan)
        hooks.goal_started(system, g, true_goal, map_goal)
        status = ctrl.set_goal(map_goal) if node >= 0 else "no current experience"
        route = ctrl.route_nodes
        if node >= 0:
            hooks.planned(system, g, nav, route)
        limit = timeout_factor * shortest + timeout_extra_s
        t = 0.0
        while status == "ok" and not ctrl.arrived and t < limit:
            v, w = ctrl.command(dt)
            if ctrl.route_nodes is not route:  # replanned
                route = ctrl.route_nodes
                hooks.planned(system, g, nav, route)
            if ctrl.arrived or ctrl.status != "ok":
                break
            obs = drive.step(v, w)
            nav.step(*obs)
            t += dt
            hooks.navigation_tick(system, g, drive.true_pose, nav)
            if trace:
                tr["true"].append(drive.true_pose)
                tr["estimate"].append(nav.pose)
                tr["goal"].append(g)
        end = drive.true_pose
        error = math.hypot(end[0] - true_goal[0], end[1] - true_goal[1])
        if status != "ok":
            final = status
        elif ctrl.status != "ok":
            final = ctrl.status
        elif ctrl.arrived:
            final = "reached" if error <= success_radius else "wrong place"
        else:
            final = "timeout"
        outcome = GoalOutcome(
            index=g,
            tick=k,
            true_goal=true_goal,
            true_start=(start[0], start[1]),
            map_goal=(float(map_goal[0]), float(map_goal[1])),
            status=final,
            time_s=t,
            shortest_time_s=shortest,
            replans=ctrl.replans,
            final_error_m=error,
        )
        outcomes.append(outcome)
        hooks.goal_ended(system, outcome)
        if progress is not None:
            progress(system, g + 1, len(goal_ticks))
    arrays = {key: np.asarray(v) for key, v in tr.items()} if trace else {}
    localiser = getattr(nav, "localiser", None)
    return SystemNavigation(system, outcomes, arrays, localiser.stats() if localiser is not None else {})
