"""The simulated camera: greyscale images rendered by casting one ray per column against the walls.

A camera sits at the robot's pose (its centre, ``camera.eye_height`` above the floor) and looks
along its heading. Each image column is one ray in the plane, at a bearing evenly spaced over the
field of view (``camera.fov_deg`` for the forward camera, the paper's robot's 50 degrees; 360
degrees for the panoramic one), column 0 on the left. Each row is an elevation evenly spaced over
``camera.vfov_deg``, row 0 at the top. A ray's nearest wall at distance ``d`` fills the rows whose
line of sight meets the wall between the floor and ``camera.wall_height``; the rows below see the
floor, those above the ceiling (both plain). The projection is cylindrical, so a turn of the robot
by one column's bearing shifts the image by exactly one column (what the view matcher's shifts
measure).

What a wall shows: each wall is cut into panels of ``camera.panel_width`` metres along its line;
each panel shows one of ``camera.motifs`` patterns (plain wall, door, window, poster, stripes,
shelves; drawn once from ``camera.texture_seed``), chosen by a hash of the panel's place (the
wall's line, the side seen and the panel's index along the line). A small set of motifs repeated
over the floor makes distant places look alike, as real corridors do; no per-wall noise makes a
place unique. Walls inside the ``dst`` rectangle of a look-alike pair (``camera.same_as``, by
default the world's ``scenes.lookalikes``) are textured as if they stood at the same place in the
``src`` rectangle, so look-alike rooms look alike.

Brightness falls with distance as ``1 / (1 + d / camera.shading_distance)``; an optional lighting
change multiplies the image by ``1 + amplitude sin(2 pi t / period)``; optional sensor noise adds
Gaussian noise drawn from ``(seed, tick)``. An image is a pure function of the world, the kind of
camera, the seed, the pose, the time and the tick: the same inputs give the same image, bit for bit.

Rendering is vectorised over rays, walls and frames with numpy (:meth:`Camera.render_poses` renders
a whole run in chunks); ``bench/bench_camera.py`` measures it.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from .world import World, load_world

CameraKind = Literal["forward", "panoramic"]
CAMERA_KINDS: tuple[str, ...] = ("forward", "panoramic")

MOTIF_SIZE = 16
"""Rows and columns of each motif's raster (v up the wall, u along the panel)."""
FLOOR_TONE, CEILING_TONE = 0.30, 0.85
OFFSET_QUANTUM = 0.05
"""Wall lines closer than this (m) to each other count as one line for the texture."""
CHUNK_RAY_WALLS = 1 << 17
"""Ray-wall pairs cast at once by :meth:`Camera.render_poses` (measured fastest: bench/bench_camera.py)."""
_NOISE_STREAM = 4  # the camera noise's stream of a seed (the simulator uses 1-3)

_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_GOLDEN = np.uint64(0x9E3779B97F4A7C15)


def _mix(h: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser on uint64 arrays (wrapping arithmetic)."""
    h = (h ^ (h >> np.uint64(30))) * _M1
    h = (h ^ (h >> np.uint64(27))) * _M2
    return h ^ (h >> np.uint64(31))


def _hash(seed: int, *parts: np.ndarray) -> np.ndarray:
    """A 64-bit hash of integer arrays (broadcast together), fixed by ``seed``."""
    h = _mix(np.full(np.broadcast_shapes(*(np.shape(p) for p in parts)), np.uint64(seed) + _GOLDEN))
    for p in parts:
        h = _mix(h ^ np.asarray(p, dtype=np.int64).astype(np.uint64))
    return h


def make_motifs(count: int, seed: int) -> np.ndarray:
    """The ``count`` wall patterns, (count, MOTIF_SIZE, MOTIF_SIZE) float32 in [0, 1], row 0 at the
    floor. Motif 0 is plain wall with a skirting board; the others cycle through door, window,
    poster, stripes, shelves and a dark panel with tones and proportions drawn from ``seed``."""
    rng = np.random.default_rng([seed, 7])
    n = MOTIF_SIZE
    v = (np.arange(n) + 0.5)[:, None] / n * np.ones((1, n))
    u = np.ones((n, 1)) * (np.arange(n) + 0.5)[None, :] / n
    out = np.empty((count, n, n), dtype=np.float32)
    for k in range(count):
        base = rng.uniform(0.5, 0.85)
        dark = rng.uniform(0.1, 0.35)
        m = np.full((n, n), base)
        m[v < 0.06] = dark + 0.1  # skirting board
        kind = (k - 1) % 6
        if k == 0:
            pass
        elif kind == 0:  # door
            a, b = sorted(rng.uniform(0.15, 0.85, 2))
            b = max(b, a + 0.3)
            m[(u > a) & (u < b) & (v < 0.9)] = dark
        elif kind == 1:  # window
            lo = rng.uniform(0.35, 0.5)
            inside = (u > 0.1) & (u < 0.9) & (v > lo) & (v < 0.88)
            m[inside] = rng.uniform(0.9, 1.0)
            m[inside & (np.abs(u - 0.5) < 0.04)] = dark
        elif kind == 2:  # poster: a checker in a frame
            c = rng.integers(2, 5)
            inside = (u > 0.25) & (u < 0.75) & (v > 0.4) & (v < 0.8)
            checker = ((np.floor(u * c * 2) + np.floor(v * c * 2)) % 2) == 0
            m[inside] = np.where(checker, dark, 0.95)[inside]
        elif kind == 3:  # vertical stripes
            period = rng.uniform(0.15, 0.4)
            m[(u % period) < period / 2] = dark + 0.15
        elif kind == 4:  # shelves
            for h in rng.uniform(0.2, 0.85, 3):
                m[np.abs(v - h) < 0.04] = dark
        else:  # a dark panel with a light band
            m[:] = dark + 0.1
            m[np.abs(v - rng.uniform(0.3, 0.7)) < 0.08] = base
        out[k] = np.clip(m, 0.0, 1.0)
    return out


class Camera:
    """A forward (``camera.fov_deg``) or panoramic (360 degree) camera in a world.

    ``render(x, y, theta, t, tick)`` gives one image (height, width) float32 in [0, 1];
    ``render_poses`` a whole run's. ``seed`` fixes the sensor noise (the appearance is the world's:
    ``camera.texture_seed``).
    """

    def __init__(self, world: World | str, kind: CameraKind | str = "forward", seed: int = 0):
        world = load_world(world)
        if kind not in CAMERA_KINDS:
            raise ValueError(f"camera: must be one of {', '.join(CAMERA_KINDS)}, got {kind!r}")
        spec = world.camera
        self.world, self.spec, self.kind, self.seed = world, spec, kind, int(seed)
        self.panoramic = kind == "panoramic"
        self.width = spec.panoramic_width if self.panoramic else spec.width
        self.height = spec.height
        self.fov = 2.0 * math.pi if self.panoramic else math.radians(spec.fov_deg)
        step = self.fov / self.width
        self.bearings = 0.5 * self.fov - (np.arange(self.width) + 0.5) * step  # column 0 on the left
        vfov = math.radians(spec.vfov_deg)
        elevations = 0.5 * vfov - (np.arange(self.height) + 0.5) * vfov / self.height  # row 0 at the top
        self._tan_el = np.tan(elevations)
        # walls: start a, direction e; the texture's line frame (canonical direction d, normal n)
        seg = np.asarray(world.walls, dtype=float)
        self._a, self._e = seg[:, 0], seg[:, 1] - seg[:, 0]
        d = self._e / np.linalg.norm(self._e, axis=1, keepdims=True)
        flip = (d[:, 0] < -1e-9) | ((np.abs(d[:, 0]) <= 1e-9) & (d[:, 1] < 0))
        d[flip] *= -1.0
        self._d, self._n = d, np.stack((-d[:, 1], d[:, 0]), axis=1)
        self._orient = np.round(np.degrees(np.arctan2(d[:, 1], d[:, 0]))).astype(np.int64)
        regions = spec.lookalike_regions(world.scenes)
        self._dst = np.array([r[1] for r in regions], dtype=float).reshape(-1, 4)
        self._shift = np.array([np.subtract(r[0][:2], r[1][:2]) for r in regions], dtype=float).reshape(-1, 2)
        self.motifs = make_motifs(spec.motifs, spec.texture_seed)
        # row shading of floor and ceiling: plain tones at the distance each row meets them
        eye, top = spec.eye_height, spec.wall_height - spec.eye_height
        with np.errstate(divide="ignore"):
            floor_d = np.where(self._tan_el < 0, eye / -self._tan_el, np.inf)
            ceil_d = np.where(self._tan_el > 0, top / self._tan_el, np.inf)
        plain = np.where(self._tan_el < 0, FLOOR_TONE, CEILING_TONE)
        self._plain_rows = (plain / (1.0 + np.minimum(floor_d, ceil_d) / spec.shading_distance)).astype(np.float32)

    @property
    def shape(self) -> tuple[int, int]:
        """Image shape (rows, columns)."""
        return (self.height, self.width)

    def render(self, x: float, y: float, theta: float, t: float = 0.0, tick: int = 0) -> np.ndarray:
        """The image (height, width) float32 in [0, 1] seen from pose (x, y, theta) at time ``t``
        (s; the lighting) and ``tick`` (the noise)."""
        pose = np.array([[x, y, theta]], dtype=float)
        return self.render_poses(pose, np.array([t], dtype=float), np.array([tick], dtype=np.int64))[0]

    def render_poses(self, poses, t=None, ticks=None, chunk: int | None = None) -> np.ndarray:
        """Images (N, height, width) float32 of poses (N, 3) at times ``t`` (N,) and ticks (N,)
        (default 0 and 0..N-1); frame ``k`` equals ``render(*poses[k], t[k], ticks[k])``. Frames
        are rendered ``chunk`` at a time (default: about :data:`CHUNK_RAY_WALLS` ray-wall pairs)."""
        if chunk is None:
            chunk = int(np.clip(CHUNK_RAY_WALLS // (self.width * len(self._a)), 1, 256))
        poses = np.asarray(poses, dtype=float).reshape(-1, 3)
        n = len(poses)
        t = np.zeros(n) if t is None else np.asarray(t, dtype=float)
        ticks = np.arange(n, dtype=np.int64) if ticks is None else np.asarray(ticks, dtype=np.int64)
        out = np.empty((n, self.height, self.width), dtype=np.float32)
        for lo in range(0, n, chunk):
            hi = min(n, lo + chunk)
            out[lo:hi] = self._render_chunk(poses[lo:hi], t[lo:hi], ticks[lo:hi])
        return out

    # ------------------------------------------------------------------ internals
    def _cast(self, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Nearest wall along each ray: distance (N, W) (inf: none within range) and wall index."""
        ang = poses[:, 2:3] + self.bearings[None, :]
        rx, ry = np.cos(ang)[..., None], np.sin(ang)[..., None]  # (N, W, 1)
        ex, ey = self._e[:, 0], self._e[:, 1]  # (S,)
        aox = (self._a[:, 0][None, :] - poses[:, 0:1])[:, None, :]  # (N, 1, S)
        aoy = (self._a[:, 1][None, :] - poses[:, 1:2])[:, None, :]
        denom = rx * ey - ry * ex  # (N, W, S)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / denom
            dist = (aox * ey - aoy * ex) * inv
            u = (aox * ry - aoy * rx) * inv
        ok = (dist > 1e-9) & (u >= 0.0) & (u <= 1.0) & (dist <= self.spec.max_range)
        dist = np.where(ok, dist, np.inf)
        wall = np.argmin(dist, axis=2)
        return np.take_along_axis(dist, wall[..., None], axis=2)[..., 0], wall

    def _texture(self, poses: np.ndarray, dist: np.ndarray, wall: np.ndarray):
        """Motif index and u along the panel of each hit (N, W)."""
        ang = poses[:, 2:3] + self.bearings[None, :]
        hx = poses[:, 0:1] + np.where(np.isfinite(dist), dist, 0.0) * np.cos(ang)
        hy = poses[:, 1:2] + np.where(np.isfinite(dist), dist, 0.0) * np.sin(ang)
        d, nrm = self._d[wall], self._n[wall]  # (N, W, 2)
        # the side of the wall the camera sees (before any look-alike shift: a translation)
        face = ((poses[:, 0:1] - hx) * nrm[..., 0] + (poses[:, 1:2] - hy) * nrm[..., 1]) > 0.0
        px, py = hx, hy
        for (x0, y0, x1, y1), (sx, sy) in zip(self._dst, self._shift):
            inside = (hx >= x0 - 1e-6) & (hx <= x1 + 1e-6) & (hy >= y0 - 1e-6) & (hy <= y1 + 1e-6)
            px = np.where(inside, hx + sx, px)
            py = np.where(inside, hy + sy, py)
        along = (px * d[..., 0] + py * d[..., 1]) / self.spec.panel_width
        offset = np.round((px * nrm[..., 0] + py * nrm[..., 1]) / OFFSET_QUANTUM)
        panel = np.floor(along)
        h = _hash(self.spec.texture_seed, self._orient[wall], face, offset, panel)
        unit = (h >> np.uint64(11)).astype(np.float64) * (1.0 / 2.0**53)
        rest = (h & np.uint64(0xFFFF)).astype(np.int64) % (self.spec.motifs - 1) + 1
        motif = np.where(unit < self.spec.plain_fraction, 0, rest)
        u = along - panel
        return motif, np.where(face, u, 1.0 - u)  # read left to right from either side

    def _render_chunk(self, poses: np.ndarray, t: np.ndarray, ticks: np.ndarray) -> np.ndarray:
        spec = self.spec
        dist, wall = self._cast(poses)
        motif, u = self._texture(poses, dist, wall)
        # height on the wall seen by each row: z = eye + d tan(elevation)
        with np.errstate(invalid="ignore"):
            z = spec.eye_height + dist[:, None, :] * self._tan_el[None, :, None]
            on_wall = (z >= 0.0) & (z <= spec.wall_height)
        m = MOTIF_SIZE
        iv = np.clip((np.nan_to_num(z, posinf=0.0, neginf=0.0) / spec.wall_height * m).astype(np.int64), 0, m - 1)
        iu = np.clip((u * m).astype(np.int64), 0, m - 1)[:, None, :]
        tex = self.motifs[motif[:, None, :], iv, iu]
        shade = (1.0 / (1.0 + np.where(np.isfinite(dist), dist, 0.0) / spec.shading_distance))[:, None, :]
        img = np.where(on_wall, tex * shade, self._plain_rows[None, :, None]).astype(np.float32)
        if spec.lighting_amplitude > 0.0:
            gain = 1.0 + spec.lighting_amplitude * np.sin(2.0 * np.pi * t / spec.lighting_period_s)
            img *= gain.astype(np.float32)[:, None, None]
        if spec.noise > 0.0:
            for k, tick in enumerate(ticks.tolist()):
                rng = np.random.default_rng([self.seed, _NOISE_STREAM, tick])
                img[k] += rng.normal(0.0, spec.noise, img.shape[1:]).astype(np.float32)
        return np.clip(img, 0.0, 1.0)


def to_uint8(image: np.ndarray) -> np.ndarray:
    """An image in [0, 1] as 8-bit grey levels (what a PNG stores)."""
    return np.round(np.clip(image, 0.0, 1.0) * 255.0).astype(np.uint8)
