"""World files: the TOML format, its loader and its validation.

A world file describes one simulated environment (see ``worlds/README.md`` for the format).
Loading validates everything before anything runs; every problem is reported as one line
``<file>: <field>: <problem>`` through :class:`WorldFileError`.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import NoReturn

import numpy as np

from .errors import InputError
from .geometry import point_segment_distance, polyline_segments, rectangle_outline, segments_cross

WORLDS_DIR = Path(__file__).resolve().parent


class WorldFileError(InputError):
    """A world file is malformed or inconsistent. The message is one line: file, field, problem."""

    def __init__(self, path, field_name: str, problem: str):
        super().__init__(f"{path}: {field_name}: {problem}")
        self.path, self.field, self.problem = str(path), field_name, problem

    def __reduce__(self):  # pickled back from a worker process with its own arguments
        return (type(self), (self.path, self.field, self.problem))


@dataclass(frozen=True)
class RobotSpec:
    """The simulated robot: a disc driven like a differential-drive base."""

    radius: float = 0.2  # m
    speed: float = 0.3  # m/s cruise speed (paper: ~0.3 m/s)
    max_turn_rate_deg: float = 60.0  # deg/s
    arrive_radius: float = 0.35  # m; a waypoint counts as reached within this distance
    turnaround_rate: float = 0.01  # per metre driven along corridors of >= 3 m: chance to turn around


@dataclass(frozen=True)
class OdometrySpec:
    """Wheel odometry model: true body velocities with systematic errors (scale, turn, slip),
    a constant yaw bias and white noise (see :mod:`worlds.odometry_model`)."""

    bias_deg_s: float = 0.0  # constant added to v_rot (Figs 8-10 use 1.5 / 3.0 / 6.0)
    noise_trans: float = 0.01  # m/s, std of Gaussian noise on v_trans per tick
    noise_rot: float = 0.01  # rad/s, std of Gaussian noise on v_rot per tick
    scale_error: float = 0.0  # fraction: distances reported 1 + scale_error times too long
    turn_scale_error: float = 0.0  # fraction: turns reported 1 + turn_scale_error times too large
    drift_deg_per_m: float = 0.0  # heading drift per metre driven (unequal wheel radii)
    slip_rate: float = 0.0  # slip episodes per second
    slip_duration: float = 1.0  # s per slip episode
    slip_fraction: float = 0.2  # the slipping wheel's over-report, as a fraction of the speed


def max_bias_deg_s(tick_rate: float) -> float:
    """The largest yaw-rate bias a log at ``tick_rate`` Hz can carry: half a turn per tick (beyond
    it a heading change cannot be told from one the other way round)."""
    return 180.0 * tick_rate


@dataclass(frozen=True)
class SceneSpec:
    """Synthetic place recognition: scene numbers computed from the pose.

    Position is quantised into ``cell_size`` squares and heading into ``heading_sectors``;
    each scene cell gets a number. A fraction ``alias_rate`` of the cells near the route shares
    its number with a distant cell (aliasing), ``blank_rate`` of them show nothing recognisable
    (-1). Near cell borders the neighbouring number flickers in. At ``false_positive_rate`` per
    tick a previously seen number is reported in a place where it does not belong.
    """

    cell_size: float = 1.0  # m
    heading_sectors: int = 4
    alias_rate: float = 0.1
    alias_min_distance: float = 3.0  # m; aliased cells are at least this far apart
    blank_rate: float = 0.1
    flicker_width: float = 0.1  # m from a cell border
    flicker_prob: float = 0.5  # chance of the neighbour's number right at the border
    false_positive_rate: float = 0.002  # per tick
    layout_seed: int = 0  # fixes which number each place shows (a property of the world)
    lookalikes: tuple = ()  # ((src_rect, dst_rect), ...): dst cells show src cells' numbers


@dataclass(frozen=True)
class CameraSpec:
    """The simulated camera (:mod:`worlds.camera`): a greyscale image rendered by casting one ray
    per column against the walls.

    Columns are evenly spaced in bearing over ``fov_deg`` (the forward camera; the panoramic one
    covers 360 degrees with ``panoramic_width`` columns), rows evenly spaced in elevation over
    ``vfov_deg``. Walls are ``wall_height`` tall seen from ``eye_height``; floor and ceiling are
    plain. Each wall is cut into panels of ``panel_width`` metres, each panel showing one of
    ``motifs`` seeded patterns (``plain_fraction`` of them plain), so places alias as real
    corridors do. ``same_as`` pairs of rectangles ``[src, dst]`` give the walls in ``dst`` the
    appearance of the walls in ``src`` (``None``: the world's ``scenes.lookalikes``).
    """

    width: int = 64  # columns of the forward camera, one ray each
    height: int = 16  # rows
    fov_deg: float = 50.0  # horizontal field of view of the forward camera (the paper's robot)
    panoramic_width: int = 128  # columns of the panoramic (360 degree) camera
    vfov_deg: float = 30.0  # vertical field of view
    eye_height: float = 1.0  # m above the floor
    wall_height: float = 2.0  # m
    max_range: float = 50.0  # m; a ray that hits nothing shows only floor and ceiling
    shading_distance: float = 6.0  # m: brightness falls as 1 / (1 + distance / shading_distance)
    noise: float = 0.0  # std of Gaussian sensor noise per pixel (image values in [0, 1])
    lighting_amplitude: float = 0.0  # brightness gain 1 + amplitude * sin(2 pi t / period)
    lighting_period_s: float = 600.0  # s
    texture_seed: int = 0  # fixes the motifs and which panel shows which (the world's look)
    motifs: int = 6  # patterns the panels are drawn from (a small set: places alias)
    panel_width: float = 1.0  # m of wall per panel
    plain_fraction: float = 0.5  # share of panels that are plain wall
    same_as: tuple | None = None  # ((src_rect, dst_rect), ...); None = scenes.lookalikes

    def lookalike_regions(self, scenes: SceneSpec) -> tuple:
        """The rectangle pairs whose walls look alike (``same_as``, or the scenes' look-alikes)."""
        return scenes.lookalikes if self.same_as is None else self.same_as


@dataclass(frozen=True)
class World:
    """A validated world: geometry, route network and simulation defaults."""

    name: str
    path: str
    description: str
    size: tuple[float, float]
    walls: np.ndarray  # (W, 2, 2) wall segments, obstacles' outlines included
    obstacles: np.ndarray  # (O, 4) filled rectangles x0, y0, x1, y1
    start: tuple[float, float, float]  # x, y (m), theta (rad)
    nodes: dict  # name -> (x, y)
    edges: tuple  # ((a, b), ...) undirected route edges between node names
    route_mode: str  # "lap" (drive `tour` forever) or "explore"
    tour: tuple  # node names driven first (the whole route in "lap" mode)
    tick_rate: float = 7.0
    duration: float = 900.0
    robot: RobotSpec = field(default_factory=RobotSpec)
    odometry: OdometrySpec = field(default_factory=OdometrySpec)
    scenes: SceneSpec = field(default_factory=SceneSpec)
    camera: CameraSpec = field(default_factory=CameraSpec)

    @property
    def dt(self) -> float:
        return 1.0 / self.tick_rate

    def node_xy(self, name: str) -> np.ndarray:
        return np.asarray(self.nodes[name], dtype=float)

    def edge_segments(self) -> np.ndarray:
        """Route edges as segments (E, 2, 2)."""
        return np.array([[self.nodes[a], self.nodes[b]] for a, b in self.edges], dtype=float).reshape(-1, 2, 2)


# --- loading ---------------------------------------------------------------------------------

_TOP_KEYS = {
    "name",
    "description",
    "size",
    "start",
    "walls",
    "obstacles",
    "route",
    "robot",
    "sim",
    "odometry",
    "scenes",
    "camera",
}
_REQUIRED = ("name", "size", "start", "walls", "route")


class _Reader:
    """Typed access to one TOML table that remembers the field path for error messages."""

    def __init__(self, path, table: dict, prefix: str):
        self.path, self.table, self.prefix = path, table, prefix

    def fail(self, key: str, problem: str) -> NoReturn:
        raise WorldFileError(self.path, f"{self.prefix}{key}", problem)

    def check_keys(self, allowed):
        for key in self.table:
            if key not in allowed:
                self.fail(key, f"unknown key (allowed: {', '.join(sorted(allowed))})")

    def number(self, key, default=None, *, minimum=None, positive=False, maximum=None):
        if key not in self.table:
            if default is None:
                self.fail(key, "missing")
            return float(default)
        v = self.table[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.fail(key, f"must be a number, got {v!r}")
        if not math.isfinite(v):
            self.fail(key, f"must be finite, got {v!r}")
        if positive and v <= 0:
            self.fail(key, f"must be positive, got {v!r}")
        if minimum is not None and v < minimum:
            self.fail(key, f"must be >= {minimum}, got {v!r}")
        if maximum is not None and v > maximum:
            self.fail(key, f"must be <= {maximum}, got {v!r}")
        return float(v)

    def integer(self, key, default, *, minimum=None):
        v = self.table.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int):
            self.fail(key, f"must be an integer, got {v!r}")
        if minimum is not None and v < minimum:
            self.fail(key, f"must be >= {minimum}, got {v!r}")
        return v

    def string(self, key, default=None, choices=None):
        if key not in self.table and default is None:
            self.fail(key, "missing")
        v = self.table.get(key, default)
        if not isinstance(v, str):
            self.fail(key, f"must be a string, got {v!r}")
        if choices and v not in choices:
            self.fail(key, f"must be one of {', '.join(choices)}, got {v!r}")
        return v

    def vector(self, key, n, value=None, label=None):
        """A list of ``n`` finite numbers (``value`` given: validate that instead of table[key])."""
        v = self.table.get(key) if value is None else value
        name = label or key
        if v is None:
            self.fail(name, "missing")
        if (
            not isinstance(v, list)
            or len(v) != n
            or any(isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x) for x in v)
        ):
            self.fail(name, f"must be a list of {n} finite numbers, got {v!r}")
        return [float(x) for x in v]

    def table_of(self, key) -> _Reader:
        v = self.table.get(key, {})
        if not isinstance(v, dict):
            self.fail(key, f"must be a table, got {v!r}")
        return _Reader(self.path, v, f"{self.prefix}{key}.")

    def list_of(self, key) -> list:
        v = self.table.get(key, [])
        if not isinstance(v, list):
            self.fail(key, f"must be a list, got {v!r}")
        return v


def resolve_world_path(name_or_path) -> Path:
    """A shipped world's name (``small_loop``) or a path to a user's ``.toml`` file."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        return p
    shipped = WORLDS_DIR / f"{name_or_path}.toml"
    if not shipped.exists():
        names = ", ".join(list_worlds())
        raise WorldFileError(name_or_path, "world", f"no such world file or shipped world (shipped: {names})")
    return shipped


def list_worlds() -> list[str]:
    """Names of the worlds shipped with the package."""
    return sorted(p.stem for p in WORLDS_DIR.glob("*.toml"))


def load_world(name_or_path) -> World:
    """Load and validate a world by shipped name or file path. Raises :class:`WorldFileError`."""
    if isinstance(name_or_path, World):
        return name_or_path
    path = resolve_world_path(name_or_path)
    try:
        raw = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise WorldFileError(path, "file", "not found") from None
    except tomllib.TOMLDecodeError as e:
        raise WorldFileError(path, "toml", f"not valid TOML ({e})") from None
    except (OSError, UnicodeDecodeError) as e:
        raise WorldFileError(path, "file", f"cannot be read ({e})") from None
    return _parse(path, raw)


def _parse(path, raw: dict) -> World:
    top = _Reader(path, raw, "")
    top.check_keys(_TOP_KEYS)
    for key in _REQUIRED:
        if key not in raw:
            top.fail(key, "missing")
    name = top.string("name")
    size = top.vector("size", 2)
    if min(size) <= 0:
        top.fail("size", f"must be positive, got {size}")

    start_t = top.table_of("start")
    start_t.check_keys({"pose"})
    sx, sy, sth = start_t.vector("pose", 3)

    walls, obstacles = _parse_walls(top)
    nodes, edges, mode, tour = _parse_route(top)

    robot_t = top.table_of("robot")
    robot_t.check_keys(set(RobotSpec.__dataclass_fields__))
    d = RobotSpec()
    robot = RobotSpec(
        radius=robot_t.number("radius", d.radius, positive=True),
        speed=robot_t.number("speed", d.speed, positive=True),
        max_turn_rate_deg=robot_t.number("max_turn_rate_deg", d.max_turn_rate_deg, positive=True),
        arrive_radius=robot_t.number("arrive_radius", d.arrive_radius, positive=True),
        turnaround_rate=robot_t.number("turnaround_rate", d.turnaround_rate, minimum=0.0),
    )
    sim_t = top.table_of("sim")
    sim_t.check_keys({"tick_rate", "duration"})
    tick_rate = sim_t.number("tick_rate", 7.0, positive=True)
    duration = sim_t.number("duration", 900.0, positive=True)

    odo_t = top.table_of("odometry")
    odo_t.check_keys(set(OdometrySpec.__dataclass_fields__))
    odometry = OdometrySpec(
        bias_deg_s=odo_t.number(
            "bias_deg_s", 0.0, minimum=-max_bias_deg_s(tick_rate), maximum=max_bias_deg_s(tick_rate)
        ),
        noise_trans=odo_t.number("noise_trans", OdometrySpec.noise_trans, minimum=0.0),
        noise_rot=odo_t.number("noise_rot", OdometrySpec.noise_rot, minimum=0.0),
        scale_error=odo_t.number("scale_error", OdometrySpec.scale_error, minimum=-0.5, maximum=0.5),
        turn_scale_error=odo_t.number("turn_scale_error", OdometrySpec.turn_scale_error, minimum=-0.5, maximum=0.5),
        drift_deg_per_m=odo_t.number("drift_deg_per_m", OdometrySpec.drift_deg_per_m, minimum=-10.0, maximum=10.0),
        slip_rate=odo_t.number("slip_rate", OdometrySpec.slip_rate, minimum=0.0),
        slip_duration=odo_t.number("slip_duration", OdometrySpec.slip_duration, positive=True),
        slip_fraction=odo_t.number("slip_fraction", OdometrySpec.slip_fraction, minimum=0.0, maximum=1.0),
    )
    scenes = _parse_scenes(top)
    camera = _parse_camera(top)

    world = World(
        name=name,
        path=str(path),
        description=top.string("description", ""),
        size=(size[0], size[1]),
        walls=walls,
        obstacles=obstacles,
        start=(sx, sy, math.remainder(math.radians(sth), 2.0 * math.pi)),
        nodes=nodes,
        edges=edges,
        route_mode=mode,
        tour=tour,
        tick_rate=tick_rate,
        duration=duration,
        robot=robot,
        odometry=odometry,
        scenes=scenes,
        camera=camera,
    )
    _check_consistency(path, world)
    return world


def _parse_walls(top: _Reader):
    walls_t = top.table_of("walls")
    walls_t.check_keys({"segments", "polylines", "rectangles"})
    parts = []
    for i, s in enumerate(walls_t.list_of("segments")):
        x0, y0, x1, y1 = walls_t.vector(None, 4, value=s, label=f"segments[{i}]")
        if math.hypot(x1 - x0, y1 - y0) < 1e-9:
            walls_t.fail(f"segments[{i}]", "zero-length wall")
        parts.append(np.array([[[x0, y0], [x1, y1]]]))
    for i, pl in enumerate(walls_t.list_of("polylines")):
        if not isinstance(pl, list) or len(pl) < 2:
            walls_t.fail(f"polylines[{i}]", "must be a list of at least two [x, y] points")
        pts = [walls_t.vector(None, 2, value=p, label=f"polylines[{i}][{j}]") for j, p in enumerate(pl)]
        seg = polyline_segments(pts)
        lengths = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
        if np.any(lengths < 1e-9):
            walls_t.fail(f"polylines[{i}][{int(np.argmin(lengths)) + 1}]", "zero-length wall (repeated point)")
        parts.append(seg)
    for i, r in enumerate(walls_t.list_of("rectangles")):
        parts.append(rectangle_outline(*_rect(walls_t, r, f"rectangles[{i}]")))
    if not parts:
        walls_t.fail("segments", "a world needs at least one wall")

    obs_t = top.table_of("obstacles")
    obs_t.check_keys({"rectangles"})
    obstacles = np.array(
        [_rect(obs_t, r, f"rectangles[{i}]") for i, r in enumerate(obs_t.list_of("rectangles"))], dtype=float
    ).reshape(-1, 4)
    parts += [rectangle_outline(*o) for o in obstacles]
    return np.concatenate(parts).astype(float), obstacles


def _rect(reader: _Reader, value, label):
    x0, y0, x1, y1 = reader.vector(None, 4, value=value, label=label)
    if x1 <= x0 or y1 <= y0:
        reader.fail(label, f"rectangle needs x0 < x1 and y0 < y1, got {value!r}")
    return x0, y0, x1, y1


def _parse_route(top: _Reader):
    route_t = top.table_of("route")
    route_t.check_keys({"nodes", "edges", "mode", "tour"})
    nodes_t = route_t.table_of("nodes")
    if not nodes_t.table:
        route_t.fail("nodes", "missing or empty")
    nodes = {k: tuple(nodes_t.vector(k, 2)) for k in nodes_t.table}
    edges = []
    for i, e in enumerate(route_t.list_of("edges")):
        if not (isinstance(e, list) and len(e) == 2 and all(isinstance(n, str) for n in e)):
            route_t.fail(f"edges[{i}]", f"must be a pair of node names, got {e!r}")
        for n in e:
            if n not in nodes:
                route_t.fail(f"edges[{i}]", f"unknown node {n!r}")
        if e[0] == e[1]:
            route_t.fail(f"edges[{i}]", "edge from a node to itself")
        edges.append((e[0], e[1]))
    if not edges:
        route_t.fail("edges", "missing or empty")
    mode = route_t.string("mode", "explore", choices=("lap", "explore"))
    tour = route_t.list_of("tour")
    for i, n in enumerate(tour):
        if n not in nodes:
            route_t.fail(f"tour[{i}]", f"unknown node {n!r}")
    undirected = {frozenset(e) for e in edges}
    for i, (a, b) in enumerate(zip(tour, tour[1:])):
        if frozenset((a, b)) not in undirected:
            route_t.fail(f"tour[{i + 1}]", f"no edge between {a!r} and {b!r}")
    if mode == "lap" and (len(tour) < 3 or tour[0] != tour[-1]):
        route_t.fail("tour", "lap mode needs a closed tour (first node repeated last)")
    return nodes, tuple(edges), mode, tuple(tour)


def _parse_scenes(top: _Reader) -> SceneSpec:
    t = top.table_of("scenes")
    t.check_keys(set(SceneSpec.__dataclass_fields__))
    d = SceneSpec()
    lookalikes = []
    for i, pair in enumerate(t.list_of("lookalikes")):
        if not (isinstance(pair, list) and len(pair) == 2):
            t.fail(f"lookalikes[{i}]", "must be a pair of rectangles [[x0,y0,x1,y1], [x0,y0,x1,y1]]")
        src = _rect(t, pair[0], f"lookalikes[{i}][0]")
        dst = _rect(t, pair[1], f"lookalikes[{i}][1]")
        lookalikes.append((src, dst))
    return SceneSpec(
        cell_size=t.number("cell_size", d.cell_size, positive=True),
        heading_sectors=t.integer("heading_sectors", d.heading_sectors, minimum=1),
        alias_rate=t.number("alias_rate", d.alias_rate, minimum=0.0, maximum=1.0),
        alias_min_distance=t.number("alias_min_distance", d.alias_min_distance, minimum=0.0),
        blank_rate=t.number("blank_rate", d.blank_rate, minimum=0.0, maximum=1.0),
        flicker_width=t.number("flicker_width", d.flicker_width, minimum=0.0),
        flicker_prob=t.number("flicker_prob", d.flicker_prob, minimum=0.0, maximum=1.0),
        false_positive_rate=t.number("false_positive_rate", d.false_positive_rate, minimum=0.0, maximum=1.0),
        layout_seed=t.integer("layout_seed", d.layout_seed, minimum=0),
        lookalikes=tuple(lookalikes),
    )


def _parse_camera(top: _Reader) -> CameraSpec:
    """The optional ``[camera]`` table (every key optional; defaults in :class:`CameraSpec`)."""
    t = top.table_of("camera")
    t.check_keys(set(CameraSpec.__dataclass_fields__))
    d = CameraSpec()
    same_as = None
    if "same_as" in t.table:
        pairs = []
        for i, pair in enumerate(t.list_of("same_as")):
            if not (isinstance(pair, list) and len(pair) == 2):
                t.fail(f"same_as[{i}]", "must be a pair of rectangles [[x0,y0,x1,y1], [x0,y0,x1,y1]]")
            pairs.append((_rect(t, pair[0], f"same_as[{i}][0]"), _rect(t, pair[1], f"same_as[{i}][1]")))
        same_as = tuple(pairs)
    wall_height = t.number("wall_height", d.wall_height, positive=True)
    eye_height = t.number("eye_height", d.eye_height, positive=True)
    if eye_height >= wall_height:
        t.fail("eye_height", f"must be below wall_height ({wall_height:g} m), got {eye_height:g}")
    return CameraSpec(
        width=t.integer("width", d.width, minimum=4),
        height=t.integer("height", d.height, minimum=2),
        fov_deg=t.number("fov_deg", d.fov_deg, positive=True, maximum=360.0),
        panoramic_width=t.integer("panoramic_width", d.panoramic_width, minimum=4),
        vfov_deg=t.number("vfov_deg", d.vfov_deg, positive=True, maximum=170.0),
        eye_height=eye_height,
        wall_height=wall_height,
        max_range=t.number("max_range", d.max_range, positive=True),
        shading_distance=t.number("shading_distance", d.shading_distance, positive=True),
        noise=t.number("noise", d.noise, minimum=0.0, maximum=1.0),
        lighting_amplitude=t.number("lighting_amplitude", d.lighting_amplitude, minimum=0.0, maximum=0.99),
        lighting_period_s=t.number("lighting_period_s", d.lighting_period_s, positive=True),
        texture_seed=t.integer("texture_seed", d.texture_seed, minimum=0),
        motifs=t.integer("motifs", d.motifs, minimum=2),
        panel_width=t.number("panel_width", d.panel_width, positive=True),
        plain_fraction=t.number("plain_fraction", d.plain_fraction, minimum=0.0, maximum=1.0),
        same_as=same_as,
    )


MAX_SCENE_CELLS = 10_000_000
"""More scene cells than this (size / cell_size squared) is a unit mistake, not a world."""
MAX_TICKS = 100_000_000
"""More ticks than this (duration x tick_rate) would not fit in memory."""


def _check_scale(path, w: World):
    """Sizes that would exhaust memory or make the robot pass through walls."""
    cells = float(math.ceil(w.size[0] / w.scenes.cell_size)) * float(math.ceil(w.size[1] / w.scenes.cell_size))
    if cells * w.scenes.heading_sectors > MAX_SCENE_CELLS:
        raise WorldFileError(
            path,
            "scenes.cell_size",
            f"{cells:.3g} cells of {w.scenes.cell_size:g} m in a {w.size} m world (at most {MAX_SCENE_CELLS:.0e})",
        )
    if w.duration * w.tick_rate > MAX_TICKS:
        raise WorldFileError(
            path, "sim.duration", f"{w.duration:g} s at {w.tick_rate:g} Hz is more than {MAX_TICKS:.0e} ticks"
        )
    step = w.robot.speed / w.tick_rate
    if step >= w.robot.radius:  # the physics would let the robot tunnel through a thin wall
        raise WorldFileError(
            path,
            "robot.speed",
            f"{w.robot.speed:g} m/s at {w.tick_rate:g} Hz moves {step:.3g} m per tick, not less than the robot's "
            f"radius {w.robot.radius:g} m (it would pass through walls)",
        )


def _inside(xy, size, margin: float = 1e-9) -> bool:
    return -margin <= xy[0] <= size[0] + margin and -margin <= xy[1] <= size[1] + margin


def _rect_inside(rect, size) -> bool:
    """Whether rectangle ``[x0, y0, x1, y1]`` lies inside the world's size."""
    return _inside(rect[:2], size) and _inside(rect[2:], size)


def _check_bounds(path, w: World):
    """Everything placed inside the world's size: walls, obstacles, route nodes, look-alike regions."""
    for i, o in enumerate(w.obstacles):
        if not _rect_inside(o, w.size):
            raise WorldFileError(
                path, f"obstacles.rectangles[{i}]", f"{o.tolist()} is outside the world's size {list(w.size)}"
            )
    for seg in w.walls:
        for xy in seg:
            if not _inside(xy, w.size):
                raise WorldFileError(
                    path, "walls", f"a wall reaches {xy.round(3).tolist()}, outside the world's size {list(w.size)}"
                )
    for name, xy in w.nodes.items():
        if not _inside(xy, w.size):
            raise WorldFileError(path, f"route.nodes.{name}", f"{list(xy)} is outside the world's size {list(w.size)}")
    for i, (src, dst) in enumerate(w.scenes.lookalikes):
        for k, r in enumerate((src, dst)):
            if not _rect_inside(r, w.size):
                raise WorldFileError(
                    path, f"scenes.lookalikes[{i}][{k}]", f"{list(r)} is outside the world's size {list(w.size)}"
                )
        if not (math.isclose(src[2] - src[0], dst[2] - dst[0]) and math.isclose(src[3] - src[1], dst[3] - dst[1])):
            raise WorldFileError(path, f"scenes.lookalikes[{i}]", "the two regions must have the same size")
    for i, (src, dst) in enumerate(w.camera.same_as or ()):
        for k, r in enumerate((src, dst)):
            if not _rect_inside(r, w.size):
                raise WorldFileError(
                    path, f"camera.same_as[{i}][{k}]", f"{list(r)} is outside the world's size {list(w.size)}"
                )
        if not (math.isclose(src[2] - src[0], dst[2] - dst[0]) and math.isclose(src[3] - src[1], dst[3] - dst[1])):
            raise WorldFileError(path, f"camera.same_as[{i}]", "the two regions must have the same size")


def _check_consistency(path, w: World):
    """Geometry checks: sizes, everything inside the world, start pose clear of walls, route
    edges do not cross walls."""
    _check_scale(path, w)
    _check_bounds(path, w)
    start = np.array([w.start[:2]])
    clearance = point_segment_distance(start, w.walls).min()
    if clearance < w.robot.radius:
        raise WorldFileError(
            path,
            "start.pose",
            f"robot at ({w.start[0]}, {w.start[1]}) overlaps a wall "
            f"(clearance {clearance:.3f} m < radius {w.robot.radius} m)",
        )
    for o in w.obstacles:
        if o[0] <= w.start[0] <= o[2] and o[1] <= w.start[1] <= o[3]:
            raise WorldFileError(path, "start.pose", f"inside obstacle {o.tolist()}")
    if not (0 <= w.start[0] <= w.size[0] and 0 <= w.start[1] <= w.size[1]):
        raise WorldFileError(path, "start.pose", f"outside the world's size {list(w.size)}")
    near = min(w.nodes, key=lambda n: math.dist(w.nodes[n], w.start[:2]))
    to_route = np.array([[w.start[:2], w.nodes[near]]], dtype=float)
    if segments_cross(to_route, w.walls).any():  # the robot starts on the route's nearest node
        raise WorldFileError(
            path,
            "start.pose",
            f"a wall stands between the start and the route's nearest node {near!r} ({list(w.nodes[near])})",
        )
    crossing = segments_cross(w.edge_segments(), w.walls)
    if crossing.any():
        i, j = np.argwhere(crossing)[0]
        a, b = w.edges[i]
        raise WorldFileError(
            path, f"route.edges[{i}]", f"edge {a!r}-{b!r} crosses a wall ({w.walls[j].ravel().round(3).tolist()})"
        )
    for name, xy in w.nodes.items():
        c = point_segment_distance(np.array([xy]), w.walls).min()
        if c < w.robot.radius:
            raise WorldFileError(path, f"route.nodes.{name}", f"too close to a wall ({c:.3f} m < robot radius)")
    for o_i, o in enumerate(w.obstacles):
        for name, xy in w.nodes.items():
            if o[0] <= xy[0] <= o[2] and o[1] <= xy[1] <= o[3]:
                raise WorldFileError(path, f"route.nodes.{name}", f"inside obstacle rectangles[{o_i}]")
