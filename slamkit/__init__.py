"""What both SLAM packages (``ratslam/`` and ``baselines/``) share, so that neither imports the other.

- :mod:`slamkit.poses`: poses in the plane (angle wrapping, composition, relative poses, range and
  bearing);
- :mod:`slamkit.arcs`: exact circular-arc integration of odometry ticks;
- :mod:`slamkit.yaw_bias`: the yaw-rate (gyro) bias searched from revisited scene numbers, and its
  configuration fields (deg/s);
- :mod:`slamkit.routes`: the quickest route over a graph of places joined by driving times;
- :mod:`slamkit.config_fields`: configuration fields declared with their ranges, the one validator,
  and fields' earlier names.

It imports nothing of the project's own; units are metres, seconds and radians inside, degrees
where a user writes a configuration field (its name says so).
"""
