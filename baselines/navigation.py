"""Goal-directed navigation on the pose graph, judged the same way as on RatSLAM's experience map.

The graph's places are its keyframes; two keyframes are joined by their odometry factor (weighted
by the time driven between them) and by every accepted loop closure (the same place seen twice:
no time to drive). The quickest route is a shortest path over these joins, driven either way, from
the latest keyframe to the keyframe nearest the goal within ``goal_radius`` m. This mirrors
``ratslam.navigation`` (same result type, same rules) without importing it: baselines never import
ratslam. Planning reads only the graph, never ground truth, and always terminates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from .pose_graph import PoseGraphSLAM

OK = "ok"
NO_KEYFRAME_NEAR_GOAL = "no experience near goal"  # same wording as ratslam: one status vocabulary
UNREACHABLE = "unreachable"
NOT_LOCALISED = "no current experience"

_MIN_WEIGHT = 1e-6  # s; a loop closure (zero time) still counts as an edge


@dataclass(frozen=True)
class Route:
    """A planned route (mirrors ``ratslam.navigation.Route``): ``status`` is :data:`OK` or says why
    there is none; ``nodes`` the keyframes from the latest to the goal keyframe, ``waypoints`` their
    positions when planned, ``time_s`` the route's driving time (inf without a route)."""

    status: str
    nodes: np.ndarray
    waypoints: np.ndarray
    time_s: float
    goal_node: int = -1

    @property
    def found(self) -> bool:
        """Whether a route exists."""
        return self.status == OK


def _no_route(status: str, goal_node: int = -1) -> Route:
    return Route(status, np.zeros(0, dtype=np.int64), np.zeros((0, 2)), math.inf, goal_node)


def quickest_route(
    node_xy: np.ndarray, edges: np.ndarray, weights: np.ndarray, start: int, goal_xy, goal_radius: float
) -> Route:
    """Quickest route over an undirected weighted graph (see ``ratslam.navigation.quickest_route``)."""
    node_xy = np.asarray(node_xy, dtype=float).reshape(-1, 2)
    n = len(node_xy)
    if start < 0 or start >= n:
        return _no_route(NOT_LOCALISED)
    gap = np.hypot(node_xy[:, 0] - goal_xy[0], node_xy[:, 1] - goal_xy[1])
    goal = int(np.argmin(gap))
    if gap[goal] > goal_radius:
        return _no_route(NO_KEYFRAME_NEAR_GOAL)
    if goal == start:
        return Route(OK, np.array([start]), node_xy[[start]].copy(), 0.0, goal)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    weights = np.asarray(weights, dtype=float)
    keep = edges[:, 0] != edges[:, 1]
    edges, weights = edges[keep], np.maximum(weights[keep], _MIN_WEIGHT)
    lo, hi = edges.min(axis=1), edges.max(axis=1)
    order = np.lexsort((weights, hi, lo))  # per node pair, the quickest join first
    lo, hi, weights = lo[order], hi[order], weights[order]
    first = np.ones(len(lo), dtype=bool)
    first[1:] = (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])
    graph = coo_matrix((weights[first], (lo[first], hi[first])), shape=(n, n)).tocsr()
    dist, pred = dijkstra(graph, directed=False, indices=start, return_predecessors=True)
    if not math.isfinite(dist[goal]):
        return _no_route(UNREACHABLE, goal)
    path = [goal]
    while path[-1] != start:
        path.append(int(pred[path[-1]]))
    nodes = np.array(path[::-1], dtype=np.int64)
    return Route(OK, nodes, node_xy[nodes].copy(), float(dist[goal]), goal)


def graph_edges(slam: PoseGraphSLAM) -> tuple[np.ndarray, np.ndarray]:
    """The pose graph's joins as (edges (M, 2), seconds (M,)): consecutive keyframes by the time
    driven between them, accepted loop closures by zero time."""
    k = slam.num_keyframes
    times = slam.keyframe_times
    odo = np.stack((np.arange(k - 1), np.arange(1, k)), axis=1).reshape(-1, 2)
    odo_t = np.diff(times) if k > 1 else np.zeros(0)
    closures = slam.loop_closures
    if len(closures):
        closures = closures[slam.closure_accepted]
    return np.concatenate((odo, closures)).astype(np.int64), np.concatenate((odo_t, np.zeros(len(closures))))


def plan_route(slam: PoseGraphSLAM, goal_xy, goal_radius: float = 1.0, node_xy: np.ndarray | None = None) -> Route:
    """Quickest route on ``slam``'s graph from its latest keyframe to the keyframe nearest
    ``goal_xy`` (map frame) within ``goal_radius`` m. ``node_xy``: the keyframes' current
    positions, if already at hand."""
    if node_xy is None:
        node_xy = slam.keyframe_poses[:, :2]
    edges, seconds = graph_edges(slam)
    return quickest_route(node_xy, edges, seconds, slam.num_keyframes - 1, goal_xy, goal_radius)


def range_bearing(pose, xy) -> tuple[float, float]:
    """Range (m) and bearing (rad, relative to the heading, in [-π, π)) of ``xy`` from ``pose``."""
    dx, dy = xy[0] - pose[0], xy[1] - pose[1]
    bearing = (math.atan2(dy, dx) - pose[2] + math.pi) % (2.0 * math.pi) - math.pi
    return math.hypot(dx, dy), bearing


class PoseGraphNavigator:
    """What a controller sees of the pose graph: its pose, its plans and its keyframes' positions
    (mirrors ``ratslam.navigation.ExperienceMapNavigator``). It also steps the SLAM."""

    name = "gtsam"

    def __init__(self, slam: PoseGraphSLAM, goal_radius: float = 1.0):
        self.slam = slam
        self.goal_radius = goal_radius
        self._cache_key: tuple[int, int] = (-1, -1)
        self._poses = np.zeros((0, 3))

    def _keyframe_poses(self) -> np.ndarray:
        # The estimate changes only when a keyframe joins the graph or the graph is rebuilt with a
        # searched yaw-rate bias: extract it once per keyframe and rebuild.
        key = (self.slam.num_keyframes, self.slam.yaw_bias_rebuilds)
        if self._cache_key != key:
            self._poses = self.slam.keyframe_poses
            self._cache_key = key
        return self._poses

    @property
    def pose(self) -> tuple[float, float, float]:
        """Current (x, y, θ) in the graph's map frame."""
        return self.slam.pose

    def plan(self, goal_xy) -> Route:
        """Quickest route to ``goal_xy`` (map frame) from the latest keyframe."""
        return plan_route(self.slam, goal_xy, self.goal_radius, self._keyframe_poses()[:, :2])

    def node_xy(self, nodes: np.ndarray) -> np.ndarray:
        """Current positions (K, 2) of keyframes ``nodes``."""
        return self._keyframe_poses()[np.asarray(nodes, dtype=np.int64), :2]

    def node_pose(self, node: int) -> tuple[float, float, float]:
        """Current pose (x, y, θ) of keyframe ``node``."""
        x, y, th = self._keyframe_poses()[int(node)]
        return float(x), float(y), float(th)

    @property
    def current_node(self) -> int:
        """The latest keyframe (-1 before the first)."""
        return self.slam.num_keyframes - 1

    def step(self, dt: float, v_trans: float, v_rot: float, scene_id: int) -> None:
        """Advance the SLAM one tick on an observation."""
        self.slam.step(dt, v_trans, v_rot, scene_id)
