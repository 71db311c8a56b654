"""Goal navigation: explore a world, then drive to goals on RatSLAM's experience map and on GTSAM's
pose graph (route controller, goals, the experiment and its report)."""
