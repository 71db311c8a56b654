"""Which scenes reach the experience map (not in the paper, which acts on every view at once).

Two rules, each with its own switch in ``ExperienceMapConfig``:

- view confirmation (``view_confirm_ticks``): a scene acts on the map only once it has been
  reported for that many consecutive ticks (1 = the paper's: at once), so a one-tick false
  positive or aliased flicker neither switches nor creates experiences;
- snap settling (``snap_settle_ticks``): for that many ticks after a snap of the pose-cell peak
  (:func:`ratslam.snaps.is_snap`) the map neither switches nor creates (0 = the paper's), so the
  packet settles on its new place before the map reads it.

The pipeline asks :meth:`ViewGate.confirmed` once per tick for the scene the map sees.
"""

from __future__ import annotations

from .config import RatSLAMConfig

NO_SCENE = -1


class ViewGate:
    """View confirmation and snap settling (module doc)."""

    def __init__(self, config: RatSLAMConfig):
        self.confirm_ticks = config.experience_map.view_confirm_ticks
        self.settle_ticks = config.experience_map.snap_settle_ticks
        self.last_scene, self.scene_run = NO_SCENE, 0  # consecutive ticks of the current scene
        self.last_snap = -(1 << 62)  # step index of the latest snap

    def confirmed(self, tick: int, scene_id: int, snapped: bool) -> int:
        """The scene the map acts on at step ``tick`` (``-1``: none) given this tick's
        ``scene_id`` and whether the pose-cell peak ``snapped`` this tick."""
        if scene_id == self.last_scene:
            self.scene_run += 1
        else:
            self.last_scene, self.scene_run = scene_id, 1
        confirmed = scene_id if self.scene_run >= self.confirm_ticks else NO_SCENE
        if snapped:
            self.last_snap = tick
        if tick - self.last_snap < self.settle_ticks:
            confirmed = NO_SCENE  # the peak has not settled yet
        return confirmed

    def get_state(self) -> tuple[int, int, int]:
        """(latest scene, its consecutive ticks, step index of the latest snap)."""
        return (self.last_scene, self.scene_run, self.last_snap)

    def set_state(self, state) -> None:
        """Restore :meth:`get_state`'s values."""
        self.last_scene, self.scene_run, self.last_snap = (int(v) for v in state)
