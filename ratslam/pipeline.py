"""The RatSLAM pipeline: local view cells -> pose cells -> experience map, one call per tick."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from slamkit.arcs import check_tick
from slamkit.config_fields import from_dict
from slamkit.poses import fit_se2, place

from .columns import Growable
from .config import RatSLAMConfig
from .experience_map import ExperienceMap
from .front_end import Adoption, FrontEnd, Rebuild
from .local_view import LocalView
from .pose_cells import PoseCells
from .view_gate import ViewGate
from .yaw_bias_correction import remove_yaw_bias, settle

# format 2: the latest snap; 3: nested config; 4: path noise per experience; 5: loop-closure
# candidate and the latest re-entry's fix (a state without the yaw-bias search's arrays, saved
# before it, loads with the search starting afresh)
# format 6: the ticks taken and each tick's anchor (kept for a rebuild after an adopted yaw-rate bias)
_FORMAT = "ratslam-state-6"
_WITHOUT_TICKS = "ratslam-state-5"  # loads with yaw_bias.rebuild off: its ticks were not kept


def _anchor_columns() -> Growable:
    """Each tick's anchor: the current experience and the offset from it."""
    return Growable({"node": ((), np.int64), "offset": ((3,), float)})


class RatSLAM:
    """RatSLAM with experience mapping (Milford, Prasser & Wyeth, ACRA 2005).

    Each :meth:`step` does, in order: the scene's view cell injects energy into the pose cells
    if it is familiar; the pose cells iterate and path-integrate the odometry (plus the optional
    path-integration bias); the view cell learns its association with the active pose cells; the
    experience map integrates the wheel odometry, selects/creates the current experience
    (eqs 2-11) for the scene the view gate lets through (:class:`ratslam.view_gate.ViewGate`:
    seen for ``experience_map.view_confirm_ticks`` consecutive ticks, the peak not snapped for
    ``experience_map.snap_settle_ticks``; the map's re-entry policy may hold a new loop closure
    until the next scene agrees: ``experience_map.loop_closure_sequence``), and runs its
    correction (eqs 12-14). Beforehand, unless ``yaw_bias.search`` is off, the tick feeds the
    yaw-rate bias search (:mod:`ratslam.yaw_bias_correction`); once it adopts a bias the system
    is rebuilt from the first tick with the bias taken off (``yaw_bias.rebuild``: each tick's
    inputs are kept for it; the experiences are renumbered, :attr:`final_anchors`) or, with
    ``rebuild`` off, the map's transitions are corrected; every later tick feeds the corrected
    yaw rate.

    The search, the view cells and the pose cells form the :attr:`front_end`
    (:class:`ratslam.front_end.FrontEnd`), which systems configured alike in those parts may
    share while they step one stream (:func:`ratslam.front_end.shared_front_ends`).

    The system never sees ground truth: only ``dt``, ``v_trans``, ``v_rot``, ``scene_id`` (and,
    from a camera, the view's rotation relative to its template).
    """

    def __init__(self, config: RatSLAMConfig | None = None):
        self._config = config if config is not None else RatSLAMConfig()
        self.front_end = FrontEnd(self._config)
        """The search, view cells and pose cells this system reads (possibly shared)."""
        # each tick's anchor, kept while a rebuild may need them
        self._anchors = _anchor_columns() if self.front_end.history is not None else None
        self._adoptions = 0  # the front end's adopted biases this system has acted on
        self.rebuilds = 0
        """How often an adopted yaw-rate bias rebuilt the system (``yaw_bias.rebuild``)."""
        self._reset_map()

    def _reset_map(self) -> None:
        """Fresh experience map and view gate, at tick 0."""
        self.experience_map = ExperienceMap(self._config)
        self._view_gate = ViewGate(self._config)
        self._tick = 0

    # ------------------------------------------------------------------ stepping
    def step(self, dt: float, v_trans: float, v_rot: float, scene_id: int, view_rotation: float = 0.0) -> None:
        """Advance one tick: ``dt`` seconds, ``v_trans`` m/s, ``v_rot`` rad/s, ``scene_id``
        (int, -1 = nothing recognisable) and ``view_rotation`` (rad: a camera view's rotation
        relative to its template, :mod:`ratslam.view_matcher`; the view's energy is injected at the
        template's heading plus it; 0 for scene numbers)."""
        scene_id = int(scene_id)
        self._check_tick(dt, v_trans, v_rot, scene_id)
        if not math.isfinite(view_rotation):
            raise ValueError(f"step: view_rotation must be a finite number of radians, got {view_rotation!r}")
        front = self.front_end
        inputs = (dt, v_trans, v_rot, scene_id, view_rotation)
        if front.tick == self._tick:
            out = front.advance(*inputs)
        elif front.tick == self._tick + 1 and front.inputs == inputs:  # a system sharing it took this tick
            assert front.output is not None
            out = front.output
        else:
            raise RuntimeError(
                f"step: this system is at tick {self._tick}, the front end it shares at tick {front.tick}"
                + (" with other inputs" if front.tick == self._tick + 1 else "")
                + ": systems sharing a front end must take the same ticks"
            )
        if len(front.adoptions) > self._adoptions:
            for adoption in front.adoptions[self._adoptions :]:
                self._adopt(adoption)
            self._adoptions = len(front.adoptions)
        self._map_step(self._tick, dt, v_trans, scene_id, out.v_rot, out.peak, out.snapped)

    def _map_step(
        self, k: int, dt: float, v_trans: float, scene_id: int, v_rot: float, peak: np.ndarray, snapped: bool
    ) -> None:
        """Tick ``k`` through the view gate and experience map given the front end's outputs:
        ``v_rot`` the yaw rate with the bias found so far taken off, the pose-cell ``peak`` and
        whether it ``snapped``."""
        em = self.experience_map
        em.integrate(dt, v_trans, v_rot)
        em.update(k, peak, self._view_gate.confirmed(k, scene_id, snapped))
        for _ in range(self._config.experience_map.correction_iterations):
            em.correct()
        if self._anchors is not None:
            self._anchors.append(node=em.current, offset=em.offset)
        self._tick = k + 1

    def _check_tick(self, dt: float, v_trans: float, v_rot: float, scene_id: int) -> None:
        """A ValueError naming the problem for a tick the pipeline cannot take."""
        check_tick(dt, v_trans, v_rot)
        pc = self._config.pose_cells
        extent = min(pc.nx, pc.ny) * pc.cell_size_m
        if abs(v_trans * dt) >= extent:  # the packet would wrap around the grid within the tick
            raise ValueError(
                f"step: v_trans * dt = {v_trans * dt:.6g} m in one tick, not less than the pose-cell grid's "
                f"{extent:g} m (pose_cells.nx/ny x cell_size_m)"
            )

    def _adopt(self, adoption: Adoption) -> None:
        """Act on a bias the front end's search adopted: rebuild the map from the front end's
        replay (``yaw_bias.rebuild``) or correct its transitions in place."""
        if adoption.rebuilt:
            replay = self.front_end.replay
            assert replay is not None and self.front_end.adoptions[-1] is adoption, "adopted this tick"
            self._rebuild(replay, adoption.settle_map)
        else:
            remove_yaw_bias(self.experience_map, adoption.change, adoption.settle_map)

    def _rebuild(self, replay: Rebuild, settle_map: bool) -> None:
        """A fresh experience map stepped through every tick so far on the front end's replay
        (the pose cells and view cells stepped again with the adopted bias taken off, as if it had
        been known from the first tick). With ``settle_map`` the new map's correction is then
        solved to its fixed point (:func:`settle`, as a map corrected in place is: the per-tick
        correction, eqs 12-14, relaxes it only locally). The new map is then laid onto the frame
        of the map before the rebuild (the SE(2) least-squares fit of where each map places the
        ticks so far), so the map the user holds does not turn or shift as a whole at the
        correction; only its shape changes."""
        assert self._anchors is not None
        before = self._placed()
        self._reset_map()
        self._anchors = _anchor_columns()
        h, n = self.front_end.history, len(replay.v_rot)
        assert h is not None
        inputs = (h.view(k)[:n].tolist() for k in ("dt", "v_trans", "scene"))
        columns = (*inputs, replay.v_rot.tolist(), replay.peak, replay.snapped.tolist())
        for k, (dt, v, scene, w, peak, snapped) in enumerate(zip(*columns)):
            self._map_step(k, dt, v, scene, w, peak, snapped)
        em = self.experience_map
        if settle_map:
            settle(em)
        frame = fit_se2(self._placed()[:, :2], before[:, :2])
        em.set_poses(place(np.array([frame]), np.zeros(em.size, dtype=np.int64), em.poses))
        self.rebuilds += 1

    def _placed(self) -> np.ndarray:
        """Each tick so far as the current map places it (its anchor on the map's poses)."""
        assert self._anchors is not None
        return place(self.experience_map.poses, self._anchors.view("node"), self._anchors.view("offset"))

    # ------------------------------------------------------------------ read access
    @property
    def config(self) -> RatSLAMConfig:
        """The configuration (a frozen dataclass; ``dataclasses.asdict`` gives provenance)."""
        return self._config

    @property
    def tick(self) -> int:
        """Number of steps taken (the step index of the latest step is ``tick - 1``)."""
        return self._tick

    @property
    def pose(self) -> tuple[float, float, float]:
        """(x, y, θ) in the experience-map frame: the current experience's map pose composed
        with the odometry integrated since it was entered."""
        return self.experience_map.pose

    @property
    def anchor(self) -> tuple[int, tuple[float, float, float]]:
        """``(experience, offset)``: the experience the pose hangs from (-1 before the first) and
        the odometry accumulated since it was entered, in its frame: :attr:`pose` is that
        experience's map pose composed with ``offset``, now or, with the map's final poses, as the
        final map places this tick."""
        em = self.experience_map
        return em.current, em.offset

    @property
    def final_anchors(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Each tick's anchor in the final map, ``(experience (N,), offset (N, 3))``, as
        :attr:`anchor` gave it after that tick or, for the ticks before a rebuild, as the rebuilt
        map holds it (experiences are renumbered by a rebuild). None unless ``yaw_bias.rebuild``
        (with the search on) keeps them."""
        if self._anchors is None:
            return None
        return self._anchors.view("node").copy(), self._anchors.view("offset").copy()

    @property
    def yaw_bias(self) -> float:
        """The yaw-rate bias (rad/s) taken off the odometry: 0 until the search adopts one."""
        return self.front_end.yaw_bias.bias

    @property
    def pose_cells(self) -> PoseCells:
        """The pose cells (the front end's)."""
        return self.front_end.pose_cells

    @property
    def local_view(self) -> LocalView:
        """The local view cells (the front end's)."""
        return self.front_end.local_view

    @property
    def pose_cell_activity(self) -> np.ndarray:
        """Pose-cell activity, shape (nx, ny, n_theta), read-only."""
        return self.pose_cells.activity

    @property
    def peak(self) -> np.ndarray:
        """Activity peak (x', y', θ') in cell units, wrapped into [0, n)."""
        return self.pose_cells.peak

    @property
    def peak_metres(self) -> np.ndarray:
        """Peak as (x m, y m, θ rad): cell coordinates times the cell sizes."""
        p = self.pose_cells.peak
        c = self._config.pose_cells
        return np.array([p[0] * c.cell_size_m, p[1] * c.cell_size_m, p[2] * c.theta_cell_rad])

    @property
    def snapped(self) -> bool:
        """Whether this tick's peak jumped by more than ``pose_cells.snap_threshold_cells`` (wrap-aware;
        :func:`ratslam.snaps.is_snap`)."""
        return self.front_end.snapped

    @property
    def experience_poses(self) -> np.ndarray:
        """Map poses (N, 3) of the experiences: x m, y m, θ rad."""
        return self.experience_map.poses.copy()

    @property
    def experience_cells(self) -> np.ndarray:
        """Pose-cell coordinates (N, 3) of the experiences."""
        return self.experience_map.cells.copy()

    @property
    def experience_views(self) -> np.ndarray:
        """Scene number (view) of each experience, (N,)."""
        return self.experience_map.views.copy()

    @property
    def experience_first_tick(self) -> np.ndarray:
        """Step index at which each experience was created, (N,)."""
        return self.experience_map.first_tick.copy()

    @property
    def experience_last_tick(self) -> np.ndarray:
        """Step index at which each experience last became the current one (entered), (N,)."""
        return self.experience_map.last_tick.copy()

    @property
    def links(self) -> np.ndarray:
        """Transitions (M, 2) as (from, to) experience indices."""
        return self.experience_map.links

    @property
    def link_d(self) -> np.ndarray:
        """Distance d_ij of each transition (m)."""
        return self.experience_map.link_column("d").copy()

    @property
    def link_theta(self) -> np.ndarray:
        """Bearing θ_ij of j relative to i's heading (rad)."""
        return self.experience_map.link_column("theta").copy()

    @property
    def link_phi(self) -> np.ndarray:
        """Heading change φ_ij (rad)."""
        return self.experience_map.link_column("phi").copy()

    @property
    def link_dt(self) -> np.ndarray:
        """Elapsed time of each transition (s)."""
        return self.experience_map.link_column("dt").copy()

    @property
    def current_experience(self) -> int:
        """Index of the current experience (-1 before the first)."""
        return self.experience_map.current

    # ------------------------------------------------------------------ persistence
    def save(self, path) -> None:
        """Write the whole state (config, pose cells, view cells, map) to one ``.npz`` file."""
        arrays: dict[str, Any] = self.front_end.get_state()  # the search's adopted bias is in its state
        arrays.update(self.experience_map.get_state())
        arrays["rs_tick"] = np.array([self._tick, int(self.snapped), *self._view_gate.get_state()], dtype=np.int64)
        arrays["rs_rebuilds"] = np.array([self.rebuilds], dtype=np.int64)
        if self._anchors is not None:
            arrays.update(self._anchors.state("rs_anchors_"))
        meta = {"format": _FORMAT, "config": dataclasses.asdict(self._config)}
        arrays["meta_json"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
        with open(Path(path), "wb") as fh:
            np.savez(fh, **arrays)

    @classmethod
    def load(cls, path) -> RatSLAM:
        """Restore a system written by :meth:`save`; stepping it continues bit-identically. A
        state saved before the ticks were kept (format 5) loads with ``yaw_bias.rebuild`` off: a
        bias adopted later corrects its map in place."""
        with np.load(Path(path)) as data:
            s = {k: data[k] for k in data.files}
        meta = json.loads(bytes(s["meta_json"]).decode())
        fmt = meta.get("format")
        if fmt not in (_FORMAT, _WITHOUT_TICKS):
            raise ValueError(f"{path}: not a RatSLAM state file of this version (format {fmt!r}, expected {_FORMAT!r})")
        config = from_dict(RatSLAMConfig, meta["config"])
        if fmt == _WITHOUT_TICKS:
            config = config.replace(yaw_bias={"rebuild": False})
        obj = cls(config)
        tick, snapped = (int(v) for v in s["rs_tick"][:2])
        obj.front_end.set_state(s, tick, bool(snapped))
        obj.experience_map.set_state(s)
        obj._tick = tick
        obj._view_gate.set_state(s["rs_tick"][2:])
        obj.rebuilds = int(s["rs_rebuilds"][0]) if "rs_rebuilds" in s else 0
        if obj._anchors is not None:
            obj._anchors.load_state(s, "rs_anchors_")
        return obj


def compile_map_kernels(config: RatSLAMConfig) -> None:
    """Compile (or load from numba's disk cache) the view cells' and the experience map's kernels
    without iterating the pose cells' attractor, so that a process can compile them beside one
    compiling the attractor (:func:`ratslam.pose_cells.compile_kernels`): a scene seen, another,
    then the first again (learning, injection, experiences created, linked, re-entered and
    corrected)."""
    cells = PoseCells(config)
    view = LocalView(config)
    em = ExperienceMap(config)
    min_age = config.local_view.min_age_ticks
    for tick, scene in enumerate((0, 1, 0)):
        k = tick * (min_age + 1)  # old enough for the first scene's associations to inject
        view.inject(scene, k, cells)
        view.learn(k, cells)
        em.integrate(1.0, 0.5, 0.0)
        em.update(k, cells.peak, scene)
        em.correct()
