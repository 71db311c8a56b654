"""The quickest route over a graph of places joined by driving times (both navigators plan with it).

A place is a node with a map position (an experience of RatSLAM's map, a keyframe of the pose
graph); a join is an edge weighted by the seconds it takes to drive, drivable both ways (of
parallel joins the quickest counts; a zero-time join, such as a loop closure, still counts). The
goal node is the node nearest the goal point within a radius; the route is Dijkstra's shortest
path from the start node. Planning reads only the graph and always terminates: a goal with no node
near it, or not joined to the start, gives a result saying so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

OK = "ok"
NO_NODE_NEAR_GOAL = "no experience near goal"
UNREACHABLE = "unreachable"
NOT_LOCALISED = "no current experience"

_MIN_WEIGHT = 1e-6  # s; a zero-time join still counts as an edge


@dataclass(frozen=True)
class Route:
    """A planned route: ``status`` is :data:`OK` or says why there is none.

    ``nodes`` are the places from the start to the goal node, ``waypoints`` their map positions
    (x, y) when planned (a map correction moves them afterwards: re-read them by node),
    ``time_s`` the sum of the joins' driving times (inf without a route), ``goal_node`` the node
    nearest the goal (-1 when there is none).
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
    ``weights`` (M,) (seconds; of parallel edges the quickest counts); ``start`` the node the
    robot is at (-1: none, :data:`NOT_LOCALISED`). The goal node is the node nearest ``goal_xy``
    within ``goal_radius`` m (else :data:`NO_NODE_NEAR_GOAL`). Dijkstra from ``start``; a goal
    not joined to it gives :data:`UNREACHABLE`.
    """
    node_xy = np.asarray(node_xy, dtype=float).reshape(-1, 2)
    n = len(node_xy)
    if start < 0 or start >= n:
        return _no_route(NOT_LOCALISED)
    gap = np.hypot(node_xy[:, 0] - goal_xy[0], node_xy[:, 1] - goal_xy[1])
    goal = int(np.argmin(gap))
    if gap[goal] > goal_radius:
        return _no_route(NO_NODE_NEAR_GOAL)
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
