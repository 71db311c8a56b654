"""Synthetic place recognition: scene numbers computed from the robot's pose.

The paper's simulator reports a *scene number* per tick rather than an image. Here a scene
cell is a ``cell_size`` square crossed with a heading sector; each cell is assigned a number
once per world (``layout_seed``), so the same place always looks the same. Realistic defects:

- aliasing: a fraction of the cells the robot drives through shows the number of a distant cell
  (pairs drawn among the cells on the route's line, one way round on a lap);
- look-alike regions (the paper's places B and C): a whole rectangle copies another's numbers;
- blank cells: nothing recognisable in view, reported as -1;
- flicker: near a cell border the neighbouring cell's number is sometimes reported;
- false positives: at a given per-tick rate, a previously seen number is reported in a place
  where it does not belong (flagged in the ground-truth labels only).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InputError
from .world import World

NO_SCENE = -1
# How far off a route's line the robot is seen driving: the simulator's robot follows its line
# (0.15 m: a line on a cell border is driven on either side of it); a real vehicle's recorded
# path stands for a lane.
ROUTE_HALF_WIDTH = 0.15
PATH_HALF_WIDTH = 0.4


@dataclass(frozen=True)
class SceneObservations:
    """Per-tick output of the scene model (arrays of one length)."""

    scene_id: np.ndarray  # int64, -1 = nothing recognisable
    false_positive: np.ndarray  # bool, ground truth only
    true_cell: np.ndarray  # int64 index of the scene cell the robot is in, ground truth only


class SceneLayout:
    """The fixed assignment of scene numbers to scene cells, over a rectangle of the plane.

    ``SceneLayout(world)`` covers a world (origin at 0, 0), with aliasing drawn among the cells
    the robot drives through: a ``lap`` world's tour one way round, an ``explore`` world's route
    network both ways; :meth:`over_path` covers the bounding box of a recorded trajectory (a real
    robot's ground truth), with the driven path as the route (both ways: a vehicle drives its
    roads in either direction).
    """

    def __init__(self, world: World):
        if world.route_mode == "lap" and len(world.tour) > 1:
            nodes = np.array([world.nodes[n] for n in world.tour], dtype=float)
            edges = np.stack((nodes[:-1], nodes[1:]), axis=1)
            self._build(world.scenes, (0.0, 0.0), world.size, edges, True, ROUTE_HALF_WIDTH)
        else:
            self._build(world.scenes, (0.0, 0.0), world.size, world.edge_segments(), False, ROUTE_HALF_WIDTH)
        if self.alias_pairs < self.alias_pairs_wanted:
            raise InputError(
                f"{world.path}: scenes.alias_min_distance: only {self.alias_pairs} of the "
                f"{self.alias_pairs_wanted} aliased pairs that alias_rate {world.scenes.alias_rate:g} asks for "
                f"can be drawn at least {world.scenes.alias_min_distance:g} m apart among the route's cells; "
                "lower one of them"
            )

    @classmethod
    def over_path(cls, spec, x, y, margin: float = 2.0) -> SceneLayout:
        """A layout (:class:`~worlds.world.SceneSpec` ``spec``) over the bounding box, plus
        ``margin`` metres, of the path ``x, y``; aliasing is drawn among the cells seen along the
        path, as along a world's route network (look-alike rectangles are in path coordinates)."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        origin = (float(x.min()) - margin, float(y.min()) - margin)
        size = (float(x.max()) - origin[0] + margin, float(y.max()) - origin[1] + margin)
        # the path as segments between points about 0.5 m apart along it
        along = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))))
        keep = np.concatenate(([0], np.flatnonzero(np.diff(np.floor(along / 0.5)) > 0) + 1))
        pts = np.stack((x[keep], y[keep]), axis=1)
        edges = np.stack((pts[:-1], pts[1:]), axis=1)
        edges = edges[np.hypot(*(edges[:, 1] - edges[:, 0]).T) > 1e-9]
        layout = cls.__new__(cls)
        layout._build(spec, origin, size, edges, False, PATH_HALF_WIDTH)
        return layout

    def _build(self, s, origin, size, edges: np.ndarray, one_way: bool, half_width: float) -> None:
        self.cell_size = s.cell_size
        self.sectors = s.heading_sectors
        self.origin = (float(origin[0]), float(origin[1]))
        self.nx = int(np.ceil(size[0] / s.cell_size))
        self.ny = int(np.ceil(size[1] / s.cell_size))
        n_cells = self.nx * self.ny * self.sectors
        rng = np.random.default_rng(s.layout_seed)

        # Distinct numbers to start with, in a scrambled order (numbers carry no position).
        numbers = rng.permutation(n_cells).astype(np.int64)
        cx, cy = self.cell_centres()

        # Aliasing is defined over the cells the robot sees when driving the route.
        route_cells = self._route_cells(edges, one_way, half_width)

        blank = rng.random(n_cells) < s.blank_rate
        visible = route_cells[~blank[route_cells]]
        self.aliased = np.zeros(n_cells, dtype=bool)
        n_pairs = int(round(s.alias_rate * len(visible) / 2))
        order = rng.permutation(visible)
        taken = np.zeros(n_cells, dtype=bool)
        pairs = 0
        for i in order:  # once per world: pair cells at least alias_min_distance apart
            if pairs >= n_pairs:
                break
            if taken[i]:
                continue
            ci, cj = i // self.sectors, order // self.sectors
            far = np.hypot(cx[cj] - cx[ci], cy[cj] - cy[ci]) >= s.alias_min_distance
            candidates = order[far & ~taken[order]]
            if len(candidates) == 0:
                continue
            j = candidates[0]
            numbers[j] = numbers[i]
            taken[[i, j]] = True
            self.aliased[[i, j]] = True
            pairs += 1
        self.alias_pairs, self.alias_pairs_wanted = pairs, n_pairs
        # Look-alike regions last, so that aliasing cannot make two look-alike rooms differ.
        for src_rect, dst_rect in s.lookalikes:
            self._copy_region(numbers, src_rect, dst_rect)
        numbers[blank] = NO_SCENE
        self.numbers = numbers
        self.route_cells = route_cells

    def _route_cells(self, edges: np.ndarray, one_way: bool, half_width: float) -> np.ndarray:
        """Scene cells seen along the route edges, up to ``half_width`` off the line: from a to b
        only if ``one_way`` (a lap), else both ways. Cells facing against a lap's direction are never seen,
        so aliasing drawn there would test nothing."""
        cells = []
        for a, b in edges:
            d = b - a
            length = float(np.hypot(*d))
            u = np.linspace(0.0, 1.0, max(2, int(length / 0.1) + 1))[:, None]
            normal = np.array([-d[1], d[0]]) / length
            heading = np.arctan2(d[1], d[0])
            for offset in (-half_width, 0.0, half_width):
                p = a + u * d + offset * normal
                for th in (heading,) if one_way else (heading, heading + np.pi):
                    cells.append(self.cell_index(p[:, 0], p[:, 1], np.full(len(p), th)))
        if not cells:  # no route at all (a path that never moved 0.5 m): no cell seen along it
            return np.zeros(0, dtype=np.int64)
        return np.unique(np.concatenate(cells))

    def cell_centres(self):
        """Centres (x, y) of the position cells, one per (ix, iy) in row-major ix*ny+iy order."""
        ix, iy = np.meshgrid(np.arange(self.nx), np.arange(self.ny), indexing="ij")
        return (
            self.origin[0] + (ix.ravel() + 0.5) * self.cell_size,
            self.origin[1] + (iy.ravel() + 0.5) * self.cell_size,
        )

    def cell_index(self, x, y, theta):
        """Scene-cell index for poses (vectorised)."""
        ix = np.clip(np.floor((np.asarray(x) - self.origin[0]) / self.cell_size).astype(np.int64), 0, self.nx - 1)
        iy = np.clip(np.floor((np.asarray(y) - self.origin[1]) / self.cell_size).astype(np.int64), 0, self.ny - 1)
        width = 2 * np.pi / self.sectors
        sector = np.floor(np.mod(np.asarray(theta) + width / 2, 2 * np.pi) / width).astype(np.int64) % self.sectors
        return (ix * self.ny + iy) * self.sectors + sector

    def _copy_region(self, numbers, src, dst):
        """Cells in rectangle ``dst`` show the numbers of the cells at the same offset in ``src``."""
        cs = self.cell_size
        ox, oy = self.origin
        sx0, sy0 = int(np.floor((src[0] - ox) / cs)), int(np.floor((src[1] - oy) / cs))
        dx0, dy0, dx1, dy1 = (int(np.floor((v - o) / cs)) for v, o in zip(dst, (ox, oy, ox, oy)))
        for ix in range(dx0, min(dx1, self.nx)):
            for iy in range(dy0, min(dy1, self.ny)):
                jx, jy = sx0 + ix - dx0, sy0 + iy - dy0
                if 0 <= jx < self.nx and 0 <= jy < self.ny:
                    d = (ix * self.ny + iy) * self.sectors
                    s = (jx * self.ny + jy) * self.sectors
                    numbers[d : d + self.sectors] = numbers[s : s + self.sectors]


def observe_scenes(
    layout: SceneLayout,
    x,
    y,
    theta,
    rng: np.random.Generator,
    flicker_width: float,
    flicker_prob: float,
    fp_rate: float,
) -> SceneObservations:
    """Scene numbers for a whole trajectory (vectorised over ticks)."""
    x, y, theta = (np.asarray(a, dtype=float) for a in (x, y, theta))
    n = len(x)
    true_cell = layout.cell_index(x, y, theta)

    # Flicker: close to a border, sometimes the cell across it is reported.
    cs = layout.cell_size
    fx, fy = np.mod(x - layout.origin[0], cs), np.mod(y - layout.origin[1], cs)
    dist_x = np.minimum(fx, cs - fx)
    dist_y = np.minimum(fy, cs - fy)
    near_x = dist_x <= dist_y
    border = np.where(near_x, dist_x, dist_y)
    p = flicker_prob * np.clip(1.0 - border / max(flicker_width, 1e-12), 0.0, 1.0) if flicker_width > 0 else np.zeros(n)
    u_flicker, u_fp, u_pick = rng.random(n), rng.random(n), rng.random(n)
    flick = u_flicker < p
    step_x = np.where(fx < cs / 2, -cs, cs) * (near_x & flick)
    step_y = np.where(fy < cs / 2, -cs, cs) * (~near_x & flick)
    seen_cell = layout.cell_index(x + step_x, y + step_y, theta)
    scene = layout.numbers[seen_cell].copy()

    # False positives: a number seen earlier, reported where it does not belong.
    false_positive = np.zeros(n, dtype=bool)
    fp_ticks = np.flatnonzero(u_fp < fp_rate)
    if len(fp_ticks):
        valid = scene != NO_SCENE
        uniq, first = np.unique(np.where(valid, scene, NO_SCENE), return_index=True)
        keep = uniq != NO_SCENE
        by_first = uniq[keep][np.argsort(first[keep])]  # numbers in order of first sighting
        first_sorted = np.sort(first[keep])
        own = layout.numbers[true_cell]
        for k in fp_ticks:
            m = int(np.searchsorted(first_sorted, k))  # numbers first seen before tick k
            candidates = by_first[:m]
            candidates = candidates[candidates != own[k]]
            if len(candidates) == 0:
                continue
            scene[k] = candidates[int(u_pick[k] * len(candidates))]
            false_positive[k] = True
    return SceneObservations(scene_id=scene, false_positive=false_positive, true_cell=true_cell)
