"""Goal-directed navigation on the experience map (the paper's future work).

The paper notes that the experience map, unlike the pose cells, suits goal-directed navigation:
"by incorporating time durations into the inter-experience link transitions, the quickest route
to any location in the map can be found". Every transition stores the time it took to drive, so
the quickest route is a shortest path over transitions weighted by elapsed time. A transition
``i -> j`` can be driven back from ``j`` to ``i`` (it joins two places), so both directions count.

A goal is a point in the experience map's own frame (a "click on the map"). The experience
nearest to it, within ``goal_radius`` metres, is the goal experience; the route starts at the
current experience. Planning reads only the map (no ground truth) and always terminates: a goal
with no experience near it, or one not joined to the current experience, gives a result saying so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from .localisation import LocaliserConfig, MapLocaliser
from .pipeline import RatSLAM

OK = "ok"
NO_EXPERIENCE_NEAR_GOAL = "no experience near goal"
UNREACHABLE = "unreachable"
NOT_LOCALISED = "no current experience"

_MIN_WEIGHT = 1e-6  # s; a zero-time transition still counts as an edge


@dataclass(frozen=True)
class Route:
    """A planned route: ``status`` is :data:`OK` or says why there is none.

    ``nodes`` are the experiences from the current one to the goal experience, ``waypoints`` their
    map positions (x, y) when planned (the map correction moves them afterwards: re-read them from
    the map by node), ``time_s`` the sum of the transitions' elapsed times (inf without a route).
    """

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
    node_xy: np.ndarray,
    edges: np.ndarray,
    weights: np.ndarray,
    start: int,
    goal_xy,
    goal_radius: float,
) -> Route:
    """Quickest route over an undirected weighted graph of map places.

    ``node_xy`` (N, 2) map positions; ``edges`` (M, 2) node pairs, each drivable both ways, with
    ``weights`` (M,) (elapsed seconds; of parallel edges the quickest counts); ``start`` the node
    the robot is at (-1: none). The goal node is the node nearest ``goal_xy`` within
    ``goal_radius`` m. Dijkstra from ``start``; unreachable goals give status :data:`UNREACHABLE`.
    """
    node_xy = np.asarray(node_xy, dtype=float).reshape(-1, 2)
    n = len(node_xy)
    if start < 0 or start >= n:
        return _no_route(NOT_LOCALISED)
    gap = np.hypot(node_xy[:, 0] - goal_xy[0], node_xy[:, 1] - goal_xy[1])
    goal = int(np.argmin(gap))
    if gap[goal] > goal_radius:
        return _no_route(NO_EXPERIENCE_NEAR_GOAL)
    if goal == start:
        return Route(OK, np.array([start]), node_xy[[start]].copy(), 0.0, goal)
    graph = _undirected_graph(n, np.asarray(edges, dtype=np.int64).reshape(-1, 2), np.asarray(weights, dtype=float))
    dist, pred = dijkstra(graph, directed=False, indices=start, return_predecessors=True)
    if not math.isfinite(dist[goal]):
        return _no_route(UNREACHABLE, goal)
    path = [goal]
    while path[-1] != start:
        path.append(int(pred[path[-1]]))
    nodes = np.array(path[::-1], dtype=np.int64)
    return Route(OK, nodes, node_xy[nodes].copy(), float(dist[goal]), goal)


def _undirected_graph(n: int, edges: np.ndarray, weights: np.ndarray):
    """Sparse upper-triangular adjacency with the smallest weight of each node pair."""
    keep = edges[:, 0] != edges[:, 1]
    edges, weights = edges[keep], np.maximum(weights[keep], _MIN_WEIGHT)
    lo, hi = edges.min(axis=1), edges.max(axis=1)
    order = np.lexsort((weights, hi, lo))  # per pair, the quickest first
    lo, hi, weights = lo[order], hi[order], weights[order]
    first = np.ones(len(lo), dtype=bool)
    first[1:] = (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])
    return coo_matrix((weights[first], (lo[first], hi[first])), shape=(n, n)).tocsr()


def range_bearing(pose, xy) -> tuple[float, float]:
    """Range (m) and bearing (rad, relative to the heading, in [-π, π)) of point ``xy`` from
    ``pose`` = (x, y, θ): what a controller follows."""
    dx, dy = xy[0] - pose[0], xy[1] - pose[1]
    bearing = (math.atan2(dy, dx) - pose[2] + math.pi) % (2.0 * math.pi) - math.pi
    return math.hypot(dx, dy), bearing


def plan_route(slam: RatSLAM, goal_xy, goal_radius: float = 1.0) -> Route:
    """Quickest route on ``slam``'s experience map from its current experience to the experience
    nearest ``goal_xy`` (experience-map frame) within ``goal_radius`` m; transitions weighted by
    their elapsed time, driven either way."""
    return quickest_route(
        slam.experience_poses[:, :2], slam.links, slam.link_dt, slam.current_experience, goal_xy, goal_radius
    )


class ExperienceMapNavigator:
    """What a controller sees of RatSLAM: its pose, its plans and its experiences' map positions.

    It steps the system on the robot's observations too (``dt, v_trans, v_rot, scene_id``), so a
    controller driving a robot needs nothing else, and never anything from the world.
    """

    name = "ratslam"

    def __init__(self, slam: RatSLAM, goal_radius: float = 1.0):
        self.slam = slam
        self.goal_radius = goal_radius

    @property
    def pose(self) -> tuple[float, float, float]:
        """Current (x, y, θ) in the experience-map frame."""
        return self.slam.pose

    def plan(self, goal_xy) -> Route:
        """Quickest route to ``goal_xy`` (map frame) from the current experience."""
        return plan_route(self.slam, goal_xy, self.goal_radius)

    def node_xy(self, nodes: np.ndarray) -> np.ndarray:
        """Current map positions (K, 2) of experiences ``nodes`` (the correction moves them)."""
        return self.slam.experience_map.poses[np.asarray(nodes, dtype=np.int64), :2]

    def node_pose(self, node: int) -> tuple[float, float, float]:
        """Current map pose (x, y, θ) of experience ``node``."""
        x, y, th = self.slam.experience_map.poses[int(node)]
        return float(x), float(y), float(th)

    @property
    def current_node(self) -> int:
        """The current experience (-1 before the first)."""
        return self.slam.current_experience

    def step(self, dt: float, v_trans: float, v_rot: float, scene_id: int) -> None:
        """Advance the SLAM one tick on an observation."""
        self.slam.step(dt, v_trans, v_rot, scene_id)


class LocalisingNavigator:
    """What a controller sees of a fixed RatSLAM map localised on by :class:`MapLocaliser`: the
    localiser's pose, routes over the map's transitions from the experience nearest the pose, the
    experiences' (fixed) map positions. Stepping it steps the localiser only."""

    name = "ratslam"

    def __init__(self, slam: RatSLAM, config: LocaliserConfig | None = None, goal_radius: float = 1.0):
        self.slam = slam  # whose map is navigated: never stepped here (its cells are displayed)
        self.localiser = MapLocaliser(slam, config)
        self.goal_radius = goal_radius

    @property
    def pose(self) -> tuple[float, float, float]:
        """Current (x, y, θ) in the map's frame."""
        return self.localiser.pose

    @property
    def current_node(self) -> int:
        """The experience nearest the pose."""
        return self.localiser.nearest_experience

    def plan(self, goal_xy) -> Route:
        """Quickest route to ``goal_xy`` (map frame) from the experience nearest the pose."""
        loc = self.localiser
        return quickest_route(
            loc.experience_poses[:, :2], loc.links, loc.link_dt, self.current_node, goal_xy, self.goal_radius
        )

    def node_xy(self, nodes: np.ndarray) -> np.ndarray:
        """Map positions (K, 2) of experiences ``nodes``."""
        return self.localiser.experience_poses[np.asarray(nodes, dtype=np.int64), :2]

    def node_pose(self, node: int) -> tuple[float, float, float]:
        """Map pose (x, y, θ) of experience ``node``."""
        x, y, th = self.localiser.experience_poses[int(node)]
        return float(x), float(y), float(th)

    @property
    def lost(self) -> bool:
        """Whether the localiser has gone too far without matching the map (see MapLocaliser)."""
        return self.localiser.lost

    def way_back(self) -> np.ndarray:
        """Map points back along the path to the latest match, newest first."""
        return self.localiser.way_back()

    def give_up_way_back(self) -> None:
        """Back at the latest match without a new one: start the way back anew from here."""
        self.localiser.give_up_way_back()

    def step(self, dt: float, v_trans: float, v_rot: float, scene_id: int) -> None:
        """Advance the localiser one tick on an observation."""
        self.localiser.step(dt, v_trans, v_rot, scene_id)
