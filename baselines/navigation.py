"""Goal-directed navigation on the pose graph, judged the same way as on RatSLAM's experience map.

The graph's places are its keyframes; two keyframes are joined by their odometry factor (weighted
by the time driven between them) and by every accepted loop closure (the same place seen twice:
no time to drive). The quickest route is a shortest path over these joins, driven either way, from
the latest keyframe to the keyframe nearest the goal within ``goal_radius`` m, by the planner
RatSLAM's navigators use (:func:`slamkit.routes.quickest_route`: same result type, same rules).
Planning reads only the graph, never ground truth, and always terminates.
"""

from __future__ import annotations

import numpy as np

from slamkit.routes import Route, quickest_route

from .pose_graph import PoseGraphSLAM


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

    @property
    def rebuilds(self) -> int:
        """How often an adopted yaw-rate bias rebuilt the graph (keyframes renumbered)."""
        return self.slam.yaw_bias_rebuilds

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
