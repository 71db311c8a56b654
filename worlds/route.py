"""Where the robot drives: a path-following controller on the world's route network.

``lap`` worlds drive their closed tour forever. ``explore`` worlds drive their tour (if any)
first, then explore: at every node prefer an untravelled edge, else head for the nearest node
that still has one, and once every edge has been driven, wander without backtracking (except at
dead ends). Now and then the robot turns around in the middle of a long corridor.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from .world import World

LONG_EDGE = 3.0  # m; turn-arounds happen only on corridors at least this long


class RouteFollower:
    """Chooses waypoints and turns them into (v_trans, v_rot) commands, one call per tick."""

    def __init__(self, world: World, rng: np.random.Generator):
        self.world, self.rng = world, rng
        self.robot = world.robot
        self.max_turn = math.radians(world.robot.max_turn_rate_deg)
        self.adjacency: dict[str, list[str]] = {n: [] for n in world.nodes}
        for a, b in world.edges:
            self.adjacency[a].append(b)
            self.adjacency[b].append(a)
        for n in self.adjacency:
            self.adjacency[n].sort()
        self.untravelled = {frozenset(e) for e in world.edges}
        self.plan: deque[str] = deque(world.tour)
        self.previous = self._nearest_node(world.start[:2])
        if self.plan and self.plan[0] == self.previous:
            self.plan.popleft()
        self.on_tour = bool(self.plan)
        self.reversed = False  # the current edge is being driven back after a turn-around
        self.target = self._next_target()
        self.turnarounds = 0

    # -- waypoint logic ------------------------------------------------------------------------
    def _nearest_node(self, xy) -> str:
        return min(self.world.nodes, key=lambda n: math.dist(self.world.nodes[n], xy))

    def _next_target(self) -> str:
        if not self.plan:
            if self.world.route_mode == "lap":
                self.plan.extend(self.world.tour[1:])
            else:
                self.on_tour = False
                self.plan.extend(self._explore_from(self.previous))
        return self.plan.popleft()

    def _explore_from(self, node: str) -> list[str]:
        fresh = [m for m in self.adjacency[node] if frozenset((node, m)) in self.untravelled]
        if fresh:
            return [fresh[self.rng.integers(len(fresh))]]
        if self.untravelled:
            path = self._path_to_untravelled(node)
            if path:
                return path
        options = self.adjacency[node]
        if len(options) > 1 and self._came_from in options:
            options = [m for m in options if m != self._came_from]
        return [options[self.rng.integers(len(options))]]

    def _path_to_untravelled(self, start: str) -> list[str]:
        """Breadth-first path (excluding ``start``) to the nearest node with an untravelled edge."""
        parent: dict[str, str] = {}  # every node reached, but the start, from where
        queue = deque([start])
        while queue:
            n = queue.popleft()
            if n != start and any(frozenset((n, m)) in self.untravelled for m in self.adjacency[n]):
                path = []
                while n != start:
                    path.append(n)
                    n = parent[n]
                return path[::-1]
            for m in self.adjacency[n]:
                if m != start and m not in parent:
                    parent[m] = n
                    queue.append(m)
        return []

    _came_from = None

    def _arrive(self):
        if not self.reversed:  # a corridor abandoned half-way does not count as driven
            self.untravelled.discard(frozenset((self.previous, self.target)))
        self.reversed = False
        self._came_from, self.previous = self.previous, self.target
        self.target = self._next_target()

    # -- control -------------------------------------------------------------------------------
    def command(self, x: float, y: float, theta: float, dt: float) -> tuple[float, float]:
        """Velocity command (m/s, rad/s) for the robot at (x, y, theta)."""
        tx, ty = self.world.nodes[self.target]
        if math.hypot(tx - x, ty - y) < self.robot.arrive_radius:
            self._arrive()
            tx, ty = self.world.nodes[self.target]
        self._maybe_turn_around(x, y, dt)
        tx, ty = self.world.nodes[self.target]
        error = (math.atan2(ty - y, tx - x) - theta + math.pi) % (2 * math.pi) - math.pi
        v_rot = max(-self.max_turn, min(self.max_turn, 2.5 * error))
        # Slow down while the heading is off; turn on the spot beyond 60 degrees.
        v_trans = self.robot.speed * max(0.0, 1.0 - abs(error) / (math.pi / 3))
        return v_trans, v_rot

    def _maybe_turn_around(self, x, y, dt):
        rate = self.robot.turnaround_rate
        if rate <= 0 or self.on_tour or self.reversed or self.world.route_mode == "lap":
            return
        a, b = self.world.nodes[self.previous], self.world.nodes[self.target]
        if math.dist(a, b) < LONG_EDGE or min(math.dist(a, (x, y)), math.dist(b, (x, y))) < 1.0:
            return
        if self.rng.random() < rate * self.robot.speed * dt:
            # Head back to where this corridor started and choose afresh from there.
            self.plan.clear()
            self._came_from = None
            self.previous, self.target = self.target, self.previous
            self.reversed = True
            self.turnarounds += 1
