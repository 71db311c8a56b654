"""Navigation goals and their ground truth: where the goals are, and how long the best route takes.

Goals are places the robot visited while exploring (ground truth, used only to choose and judge
goals). The yardstick for a navigation's duration is the shortest path on the world's route
network (the corridors and doorways the exploring robot drove) at the robot's cruise speed.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import dijkstra

from worlds import InputError, World


class GoalDrawError(InputError):
    """The exploration is too short (or too confined) for the goals asked for."""


def draw_goal_ticks(
    gt_xy: np.ndarray,
    n_goals: int,
    rng: np.random.Generator,
    start_xy,
    min_separation_m: float = 3.0,
    first_tick: int = 0,
    max_attempts: int = 10_000,
) -> np.ndarray:
    """``n_goals`` exploration ticks, uniformly among ticks from ``first_tick`` on, each goal's true
    place at least ``min_separation_m`` (straight line) from the previous one (the first from
    ``start_xy``, where navigation starts), so that no goal is reached by standing still."""
    gt_xy = np.asarray(gt_xy, dtype=float)
    ticks: list[int] = []
    prev = np.asarray(start_xy, dtype=float)
    for _ in range(max_attempts):
        if len(ticks) == n_goals:
            break
        k = int(rng.integers(first_tick, len(gt_xy)))
        if np.hypot(*(gt_xy[k] - prev)) >= min_separation_m:
            ticks.append(k)
            prev = gt_xy[k]
    if len(ticks) < n_goals:
        raise GoalDrawError(
            f"could not draw {n_goals} goals {min_separation_m:g} m apart from the places visited after "
            f"{first_tick} ticks of exploration: explore for longer or ask for fewer goals"
        )
    return np.array(ticks, dtype=np.int64)


def _project(p: np.ndarray, seg: np.ndarray) -> tuple[int, float, float]:
    """Nearest route edge to ``p``: (edge index, position along it in [0, 1], distance to it)."""
    a, b = seg[:, 0], seg[:, 1]
    ab = b - a
    u = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12), 0.0, 1.0)
    c = a + u[:, None] * ab
    d = np.hypot(c[:, 0] - p[0], c[:, 1] - p[1])
    e = int(np.argmin(d))
    return e, float(u[e]), float(d[e])


def route_network_distance(world: World, a_xy, b_xy) -> float:
    """Shortest path (m) from ``a_xy`` to ``b_xy`` along the world's route network: each point
    joins the network at its nearest edge (straight across), then the path follows the edges."""
    names = list(world.nodes)
    index = {n: i for i, n in enumerate(names)}
    xy = np.array([world.nodes[n] for n in names], dtype=float)
    seg = world.edge_segments()
    n = len(names)
    graph = np.zeros((n + 2, n + 2))  # dense: route networks have tens of nodes; 0 = no edge
    for a, b in world.edges:
        i, j = index[a], index[b]
        graph[i, j] = graph[j, i] = max(float(np.hypot(*(xy[i] - xy[j]))), 1e-9)
    ends = []
    for k, p in enumerate((np.asarray(a_xy, dtype=float), np.asarray(b_xy, dtype=float))):
        e, u, off = _project(p, seg)
        i, j = index[world.edges[e][0]], index[world.edges[e][1]]
        length = float(np.hypot(*(xy[i] - xy[j])))
        graph[n + k, i] = graph[i, n + k] = max(off + u * length, 1e-9)
        graph[n + k, j] = graph[j, n + k] = max(off + (1.0 - u) * length, 1e-9)
        ends.append((e, u, off, length))
    (ea, ua, oa, la), (eb, ub, ob, _) = ends
    if ea == eb:  # both on one edge: straight along it
        graph[n, n + 1] = graph[n + 1, n] = max(oa + ob + abs(ua - ub) * la, 1e-9)
    return float(dijkstra(graph, directed=False, indices=n)[n + 1])
