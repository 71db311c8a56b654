"""Goal-directed navigation on the experience map (the paper's future work).

The paper notes that the experience map, unlike the pose cells, suits goal-directed navigation:
"by incorporating time durations into the inter-experience link transitions, the quickest route
to any location in the map can be found". Every transition stores the time it took to drive, so
the quickest route is a shortest path over transitions weighted by elapsed time. A transition
``i -> j`` can be driven back from ``j`` to ``i`` (it joins two places), so both directions count.

A goal is a point in the experience map's own frame (a "click on the map"). The experience
nearest to it, within ``goal_radius`` metres, is the goal experience; the route starts at the
current experience (:func:`slamkit.routes.quickest_route`, the planner the pose graph's navigator
uses too). Planning reads only the map (no ground truth) and always terminates: a goal with no
experience near it, or one not joined to the current experience, gives a result saying so.
"""

from __future__ import annotations

import numpy as np

from slamkit.routes import Route, quickest_route

from .localisation import LocaliserConfig, MapLocaliser
from .pipeline import RatSLAM


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

    @property
    def rebuilds(self) -> int:
        """How often an adopted yaw-rate bias rebuilt the map (experiences renumbered)."""
        return self.slam.rebuilds

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
    def rebuilds(self) -> int:
        """The map is fixed: never rebuilt."""
        return 0

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
