"""GTSAM Pose2 pose-graph SLAM baseline, fed the same odometry and scene numbers as RatSLAM."""

from .config import (
    BackendConfig,
    KeyframeConfig,
    LoopClosureConfig,
    OdometryNoiseConfig,
    OptimisationConfig,
    PoseGraphConfig,
    YawBiasConfig,
)
from .pose_graph import PoseGraphSLAM

__all__ = [
    "BackendConfig",
    "KeyframeConfig",
    "LoopClosureConfig",
    "OdometryNoiseConfig",
    "OptimisationConfig",
    "PoseGraphConfig",
    "PoseGraphSLAM",
    "YawBiasConfig",
]
