"""The default Rerun blueprint of a run: the paper's panels side by side.

Left, the world (walls, ground truth, odometry, experience map, GTSAM estimate, false
positives); top right, the pose-cell (x', y') activity with the peak trail (snaps in red, thin);
bottom right, the metrics over time (errors in metres, then counts). The time cursor follows
the newest data, so a finished recording opens at its last tick.

Entity paths and their meaning are listed in :mod:`harness.record.recorder`.
"""

from __future__ import annotations

from typing import Any

import rerun.blueprint as rrb

#: Entities whose per-tick segments accumulate: drawn from the first tick to the time cursor.
TRAIL_ENTITIES = ("/world/ground_truth", "/world/odometry", "/world/false_positives", "/pose_cells/peak")


def _trail() -> rrb.VisibleTimeRanges:
    return rrb.VisibleTimeRanges(
        rrb.VisibleTimeRange(
            "tick", start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.cursor_relative()
        )
    )


#: Goal navigation (:mod:`harness.navigation.experiment`): the true paths driven, per system.
NAV_TRAIL_ENTITIES = ("/world/nav/ratslam/driven", "/world/nav/gtsam/driven")


def default_blueprint(grid_shape, world_bounds=None, navigation: bool = False, camera: bool = False) -> rrb.Blueprint:
    """Blueprint for a recording written by :class:`harness.record.recorder.Recorder`.

    ``grid_shape``: pose-cell grid (nx, ny, ...), framing the activity panel;
    ``world_bounds``: ``(x0, y0, x1, y1)`` metres framing the world panel (None: fit the data);
    ``navigation``: a goal-navigation recording (:mod:`harness.navigation.experiment`): the driven
    paths as trails and a third time-series panel for ``/metrics/nav`` (success, time ratio);
    ``camera``: a camera run's recording: the view and its matched template above the pose cells.
    """
    nx, ny = int(grid_shape[0]), int(grid_shape[1])
    world_kw: dict[str, Any] = {}
    if world_bounds is not None:
        x0, y0, x1, y1 = (float(v) for v in world_bounds)
        mx, my = 0.05 * (x1 - x0) + 0.5, 0.05 * (y1 - y0) + 0.5
        # The world is drawn with y up: the /world entity is mirrored (see Recorder), so its
        # y range appears negated in the view's coordinates.
        world_kw["visual_bounds"] = rrb.VisualBounds2D(x_range=[x0 - mx, x1 + mx], y_range=[-y1 - my, -y0 + my])
    trails = TRAIL_ENTITIES + (NAV_TRAIL_ENTITIES if navigation else ())
    nav_name = "; navigation: goal (green), planned route, driven path" if navigation else ""
    world = rrb.Spatial2DView(
        name="World: ground truth (white), odometry (orange), experience map (blue), GTSAM (magenta), "
        "false positives (red)" + nav_name,
        origin="/",
        contents=["+ /world/**"],
        overrides={p: _trail() for p in trails if p.startswith("/world")},
        **world_kw,
    )
    pose_cells = rrb.Spatial2DView(
        name="Pose cells: x'y' activity, peak trail (cyan), snaps (red)",
        origin="/",
        contents=["+ /pose_cells/**"],
        overrides={"/pose_cells/peak": _trail()},
        visual_bounds=rrb.VisualBounds2D(x_range=[-0.5, nx + 0.5], y_range=[-ny - 0.5, 0.5]),
    )
    whole_run = rrb.TimeAxis(
        view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.infinite(), end=rrb.TimeRangeBoundary.infinite())
    )
    errors = rrb.TimeSeriesView(name="ATE so far (m)", origin="/metrics/ate", axis_x=whole_run)
    counts = rrb.TimeSeriesView(
        name="Counts",
        origin="/metrics",
        contents=["+ /metrics/**", "- /metrics/ate/**", "- /metrics/nav/**"],
        axis_x=whole_run,
    )
    series: list[Any] = [errors, counts]
    if navigation:
        series.append(
            rrb.TimeSeriesView(
                name="Navigation: reached (0/1), success rate, time ratio", origin="/metrics/nav", axis_x=whole_run
            )
        )
    right = rrb.Vertical(pose_cells, rrb.Horizontal(*series), row_shares=[3, 2])
    if camera:
        views = rrb.Horizontal(
            rrb.Spatial2DView(name="Camera: the view", origin="/camera/image"),
            rrb.Spatial2DView(name="The template it matched (or stored)", origin="/camera/template"),
        )
        right = rrb.Vertical(views, pose_cells, rrb.Horizontal(*series), row_shares=[1, 3, 2])
    return rrb.Blueprint(
        rrb.Horizontal(world, right, column_shares=[3, 2]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline="tick", play_state="following"),
    )
