"""GTSAM Pose2 pose-graph SLAM baseline, fed the same odometry and scene numbers as RatSLAM."""

from .config import PoseGraphConfig
from .pose_graph import PoseGraphSLAM

__all__ = ["PoseGraphConfig", "PoseGraphSLAM"]
