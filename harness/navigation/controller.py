"""A route-following controller that sees only a SLAM system's map: its pose, its plans, its nodes.

The controller is built from a navigator (``ratslam.navigation.ExperienceMapNavigator`` or
``baselines.navigation.PoseGraphNavigator``) and nothing else: no world, no simulator, no ground
truth. Each tick it reads the SLAM's pose and the current map positions of its route's nodes
(the map correction keeps moving them) and returns a velocity command.

Following. The route is the planned nodes followed by the goal point itself, each inner point
averaged with its neighbours within ``smooth_m`` of route (one misplaced node then does not kink
the path into a door frame). Pure pursuit: the robot's progress along the route is its
projection onto the route ahead (within ``window_m``; of projections about as near as the
nearest, the one furthest along, so a route that starts behind the robot, at a stale current
experience or at keyframes just driven, is skipped rather than driven back); it steers for the
route point ``lookahead_m`` beyond, turning on the spot beyond 60 degrees of heading error, like
the exploring robot; a target behind (beyond ``TURN_HOLD_RAD``) is turned to the way the robot
already turns (a command acts a tick late, so at 180 deg, where the nearer way round flips with
each tick, choosing it afresh each tick leaves the robot rocking on the spot). Progress is
placed anew (within ``window_m``) after each plan only; then it advances no faster than the pose
moves, so a later part of the route lying near (across a wall, past a door) never pulls the robot
off the part it is on. Arrival: the pose within ``arrive_m`` of the goal point.

Lost. A navigator may say it is lost (``nav.lost``: the map localiser, after metres without a
scene it knows, having left the routes the map was built on) and offer its way back
(``nav.way_back()``: its own path back to where it last matched the map). The controller then
drives that way back instead of the route; found again, it plans the goal afresh (a replan); at
the way back's end and still lost, it tells the navigator (``nav.give_up_way_back()``) and
follows the route again. Navigators without ``lost`` are never lost.

Blocked. The map shows no walls, so a robot whose pose is off may drive into one. When forward
commands have not moved the pose (the robot's own odometry) for ``blocked_s``, it reverses at half
speed for ``back_off_s`` and plans afresh (a replan).

Replanning (counted). The route is planned again when the pose is more than ``replan_m`` from the
route ahead (the robot, or the map's idea of where it is, left the route), or when the distance
still to go has not shrunk by ``stall_progress_m`` in ``stall_s`` seconds (stuck, e.g. against a
wall). At most one replan per ``replan_interval_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, cast

import numpy as np

from slamkit.poses import range_bearing

TURN_HOLD_RAD = math.radians(150.0)


class RouteLike(Protocol):
    status: str
    nodes: np.ndarray

    @property
    def found(self) -> bool: ...


class NavigableMap(Protocol):
    """What the controller may read of a SLAM system (both navigators provide it)."""

    name: str

    @property
    def pose(self) -> tuple[float, float, float]: ...

    def plan(self, goal_xy) -> RouteLike: ...

    def node_xy(self, nodes: np.ndarray) -> np.ndarray: ...

    @property
    def rebuilds(self) -> int:
        """How often the map was built anew (its nodes renumbered): a route is planned again."""
        ...


class LosableMap(NavigableMap, Protocol):
    """A navigator that can tell it is lost and offer its way back (the map localiser's)."""

    @property
    def lost(self) -> bool: ...

    def way_back(self) -> np.ndarray: ...

    def give_up_way_back(self) -> None: ...


@dataclass(frozen=True)
class ControllerParams:
    """Driving and route-following parameters (the robot's own, not the world's ground truth)."""

    speed: float = 0.3  # m/s cruise
    max_turn_rate_deg: float = 60.0  # deg/s
    turn_gain: float = 2.5  # rad/s per rad of heading error
    lookahead_m: float = 0.5  # pure pursuit: steer for the route point this far ahead
    arrive_m: float = 0.2  # at the goal point: arrived
    window_m: float = 5.0  # progress may skip ahead this far along the route
    skip_tolerance_m: float = 0.25  # ... to a point no more than this farther than the nearest
    smooth_m: float = 0.75  # route points averaged over this much route either side (0: off)
    replan_m: float = 1.0  # off the route ahead by more than this: replan
    stall_s: float = 20.0  # no progress for this long: replan
    stall_progress_m: float = 0.3
    replan_interval_s: float = 5.0
    blocked_s: float = 2.0  # driving forward while the pose stays put this long: blocked
    back_off_s: float = 2.0  # ... then reverse at half speed this long and plan afresh


class RouteController:
    """Drives to a goal point in the SLAM's map frame, given only the SLAM's navigator."""

    def __init__(self, nav: NavigableMap, params: ControllerParams | None = None):
        self.nav = nav
        self.params = params if params is not None else ControllerParams()
        self.goal = (0.0, 0.0)
        self.status = "idle"
        self.replans = 0
        self.arrived = False
        self._nodes = np.zeros(0, dtype=np.int64)
        self._s = -1.0  # progress along the route (m; -1: not placed on the route yet)
        self._last_xy: tuple[float, float] | None = None  # the pose at the previous command
        self._v_last = 0.0  # the previous command's speed
        self._w_last = 0.0  # ... and turn rate
        self._retracing = False  # driving back to where the map last matched
        self._t_blocked = 0.0  # how long forward commands have not moved the pose
        self._backing = 0.0  # time left reversing off an obstacle
        self._t = 0.0
        self._best, self._t_best, self._t_plan = math.inf, 0.0, -math.inf
        self._planned_on = 0  # the map's rebuild count when the route was planned

    def set_goal(self, goal_xy) -> str:
        """Plan to ``goal_xy`` (map frame); returns the plan's status ("ok" or why not)."""
        self.goal = (float(goal_xy[0]), float(goal_xy[1]))
        self.arrived = False
        self.replans = 0
        self._t = 0.0
        self._t_blocked, self._backing = 0.0, 0.0
        return self._plan()

    def _plan(self) -> str:
        route = self.nav.plan(self.goal)
        self.status = route.status
        self._nodes = np.asarray(route.nodes, dtype=np.int64) if route.found else np.zeros(0, dtype=np.int64)
        self._planned_on = self.nav.rebuilds
        self._s = -1.0
        self._best, self._t_best, self._t_plan = math.inf, self._t, self._t
        return self.status

    def _moved(self, xy: tuple[float, float]) -> float:
        """How far the pose moved since the previous command (m)."""
        last, self._last_xy = self._last_xy, xy
        return 0.0 if last is None else math.hypot(xy[0] - last[0], xy[1] - last[1])

    def _replan(self) -> None:
        self.replans += 1
        self._plan()

    @property
    def route_nodes(self) -> np.ndarray:
        """The nodes of the route being followed."""
        return self._nodes

    def command(self, dt: float) -> tuple[float, float]:
        """Velocity command (m/s, rad/s) for the next tick of ``dt`` seconds; (0, 0) once arrived
        or without a route."""
        self._t += dt
        if self.arrived or self.status != "ok":
            return 0.0, 0.0
        p = self.params
        x, y, th = self.nav.pose
        moved = self._moved((x, y))
        if self._recovering(dt, moved):
            return self._out(-0.5 * p.speed, 0.0)
        if self.status != "ok":  # the replan after backing off found no route
            return self._out(0.0, 0.0)
        back = self._way_back(x, y, th)
        if back is not None:
            return back
        if self.nav.rebuilds != self._planned_on:  # the route's nodes are another map's
            self._replan()
            if self.status != "ok":
                return self._out(0.0, 0.0)
        # the route as it lies in the map now: its nodes, then the goal point
        pts = np.vstack((self.nav.node_xy(self._nodes), [self.goal]))
        along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))))
        if p.smooth_m > 0 and len(pts) > 2:
            pts = _smooth(pts, along, p.smooth_m)
            along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))))
        total = float(along[-1])
        # placed anew (a new plan) the route may start behind the robot and is skipped along up
        # to window_m; once placed, progress keeps up with the robot's own motion, so it never
        # jumps to a later part of the route that merely lies near (across a wall, past a door)
        window = p.window_m if self._s < 0 else moved + p.skip_tolerance_m
        s_proj, off = _project_on_route((x, y), pts, along, max(self._s, 0.0), window, p.skip_tolerance_m)
        self._s = max(self._s, s_proj)
        d_goal = math.hypot(self.goal[0] - x, self.goal[1] - y)
        if d_goal < p.arrive_m:
            self.arrived = True
            return self._out(0.0, 0.0)
        to_go = total - self._s + off
        if to_go < self._best - p.stall_progress_m:
            self._best, self._t_best = to_go, self._t
        if self._t - self._t_plan >= p.replan_interval_s and (off > p.replan_m or self._t - self._t_best > p.stall_s):
            self._replan()
            if self.status != "ok":
                return self._out(0.0, 0.0)
            return self.command(0.0)
        s_target = self._s + p.lookahead_m
        target = self.goal if s_target >= total or d_goal < p.lookahead_m else _point_at(pts, along, s_target)
        return self._steer(target, x, y, th)

    def _way_back(self, x: float, y: float, th: float) -> tuple[float, float] | None:
        """A navigator that says it is lost (``nav.lost``; the map localiser's) is driven back along
        its own path to where it last matched the map (``nav.way_back()``); found again, the goal
        is planned afresh. None: not lost, follow the route."""
        if not getattr(self.nav, "lost", False):
            if self._retracing:
                self._retracing = False
                self._replan()
            return None
        self._retracing = True
        nav = cast(LosableMap, self.nav)
        pts = nav.way_back()
        if len(pts) < 2 or math.hypot(pts[-1][0] - x, pts[-1][1] - y) < self.params.arrive_m:
            nav.give_up_way_back()  # back there and nothing matched: go on from here
            return None
        along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))))
        s, _ = _project_on_route((x, y), pts, along, 0.0, float(along[-1]), self.params.skip_tolerance_m)
        return self._steer(_point_at(pts, along, s + self.params.lookahead_m), x, y, th)

    def _steer(self, target, x: float, y: float, th: float) -> tuple[float, float]:
        """Pure pursuit towards ``target``: turn on the spot beyond 60 deg of heading error."""
        p = self.params
        _, err = range_bearing((x, y, th), target)
        max_turn = math.radians(p.max_turn_rate_deg)
        if abs(err) > TURN_HOLD_RAD and self._w_last != 0.0:
            # a target behind: keep turning the way the robot already turns (the command acts a
            # tick late, and at +/-180 deg the nearer way round flips with every tick)
            err = math.copysign(abs(err), self._w_last)
        v_rot = max(-max_turn, min(max_turn, p.turn_gain * err))
        v_trans = p.speed * max(0.0, 1.0 - abs(err) / (math.pi / 3))
        return self._out(v_trans, v_rot)

    def _out(self, v_trans: float, v_rot: float) -> tuple[float, float]:
        self._v_last, self._w_last = v_trans, v_rot
        return v_trans, v_rot

    def _recovering(self, dt: float, moved: float) -> bool:
        """Whether to reverse this tick. Blocked (a wall the map does not show; the robot's own
        odometry says that forward commands have not moved it for ``blocked_s``), the robot
        backs off for ``back_off_s`` at half speed and then plans afresh (a replan)."""
        p = self.params
        if self._backing > 0.0:
            self._backing -= dt
            if self._backing > 0.0:
                return True
            self._replan()
            return False
        blocked = self._v_last > 0.5 * p.speed and moved < 0.2 * self._v_last * dt
        self._t_blocked = self._t_blocked + dt if blocked else 0.0
        if self._t_blocked >= p.blocked_s:
            self._t_blocked, self._backing = 0.0, p.back_off_s
            return True
        return False


def _project_on_route(xy, pts: np.ndarray, along: np.ndarray, s0: float, window: float, tolerance: float):
    """Where the robot is along the route: projections of ``xy`` on the segments from progress
    ``s0`` up to ``window`` metres further; of those no more than ``tolerance`` farther than the
    nearest, the one furthest along. Returns (progress m, distance to the route m)."""
    q = np.asarray(xy, dtype=float)
    if len(pts) == 1:
        return 0.0, float(np.hypot(*(pts[0] - q)))
    s0 = min(s0, float(along[-1]))  # the map correction can shorten the route under the robot
    a, b = pts[:-1], pts[1:]
    ab = b - a
    length = along[1:] - along[:-1]
    u = np.clip(np.einsum("ij,ij->i", q - a, ab) / np.maximum(length**2, 1e-12), 0.0, 1.0)
    s = along[:-1] + u * length
    c = a + u[:, None] * ab
    dist = np.hypot(c[:, 0] - q[0], c[:, 1] - q[1])
    ok = (along[1:] >= s0) & (along[:-1] <= s0 + window)
    s, dist = np.maximum(s[ok], s0), dist[ok]
    best = dist <= dist.min() + tolerance
    return float(s[best].max()), float(dist.min())


def _point_at(pts: np.ndarray, along: np.ndarray, s: float) -> np.ndarray:
    """The route point ``s`` metres along the polyline through ``pts``."""
    i = int(np.clip(np.searchsorted(along, s, side="right") - 1, 0, len(pts) - 2))
    seg = max(along[i + 1] - along[i], 1e-12)
    return pts[i] + (pts[i + 1] - pts[i]) * min(max((s - along[i]) / seg, 0.0), 1.0)


def _smooth(pts: np.ndarray, along: np.ndarray, half: float, step: float = 0.25) -> np.ndarray:
    """The route resampled every ``step`` m, each inner point replaced by the mean of the samples
    within ``half`` m of route either side (the ends stay): one misplaced node no longer kinks
    the path the robot drives, whatever the nodes' spacing."""
    n = max(int(np.ceil(along[-1] / step)), 1)
    s = np.linspace(0.0, along[-1], n + 1)
    res = np.stack([np.interp(s, along, pts[:, 0]), np.interp(s, along, pts[:, 1])], axis=1)
    near = np.abs(s[:, None] - s[None, :]) <= half
    out = (near @ res) / near.sum(axis=1)[:, None]
    out[0], out[-1] = res[0], res[-1]
    return out
