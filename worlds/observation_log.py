"""The observation log: the CSV contract through which odometry and place labels enter SLAM.

Header ``t,dt,v_trans,v_rot,scene_id`` and optionally the ground-truth columns
``gt_x,gt_y,gt_theta,false_positive`` (the pose's three together; ``false_positive`` may be left
out, a log with ground truth then has no tick labelled a false positive). A camera log has an
``image`` column instead of ``scene_id``: each tick's image file (PNG or JPEG), its path relative
to the log file; its scene numbers are -1 until a view matcher has turned the images into template
numbers (``harness.camera.stream.match_camera_log``). An optional ``view_rotation`` column (rad)
carries each view's rotation relative to its template (``RatSLAM.step``'s ``view_rotation``). Reading validates
columns, types, finite values and monotonic time, and reports a problem as one line naming the
file, the line, the column and what is wrong (:class:`ObservationLogError`). Writing is atomic
(temporary file, then rename).
"""

from __future__ import annotations

import csv
import dataclasses
import io
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InputError
from .files import atomic_write_text, read_text

REQUIRED_COLUMNS = ("t", "dt", "v_trans", "v_rot", "scene_id")
IMAGE_COLUMN = "image"
"""A camera log's column in place of ``scene_id``: image files relative to the log."""
ROTATION_COLUMN = "view_rotation"
"""Optional: each view's rotation relative to its template (rad)."""
GROUND_TRUTH_COLUMNS = ("gt_x", "gt_y", "gt_theta", "false_positive")
GROUND_TRUTH_POSE = GROUND_TRUTH_COLUMNS[:3]  # needed together; false_positive may be left out
_INT_COLUMNS = {"scene_id", "false_positive"}
SCENE_ID_MIN, SCENE_ID_MAX = -1, 2**63 - 1
"""Scene numbers are int64: -1 (no scene) up to 2**63 - 1."""
_INTEGER = re.compile(r"[+-]?[0-9]+")
DT_MISMATCH = 2.0
"""``dt`` must agree with the spacing of ``t`` within this factor (median over the log)."""
MAX_SECONDS = 1e12
"""A time ``t`` or tick length ``dt`` beyond this many seconds (about 31,700 years) is refused:
not a robot's log, and its arithmetic (durations, real-time factors) overflows to infinity."""


def parse_int(cell: str) -> int | None:
    """A decimal integer (optional sign, digits only: not "3.0", "1_0" or "0x1f"), or None."""
    return int(cell) if _INTEGER.fullmatch(cell) else None


class ObservationLogError(InputError):
    """A malformed observation log. The message is one line: file, line/column, problem."""


@dataclass
class ObservationLog:
    """One run's observations (what SLAM sees) and optional ground truth (metrics only)."""

    t: np.ndarray
    dt: np.ndarray
    v_trans: np.ndarray
    v_rot: np.ndarray
    scene_id: np.ndarray
    gt_x: np.ndarray | None = None
    gt_y: np.ndarray | None = None
    gt_theta: np.ndarray | None = None
    false_positive: np.ndarray | None = None
    image: np.ndarray | None = None  # camera log: image paths relative to the log (str objects)
    view_rotation: np.ndarray | None = None  # rad, relative to the matched template

    def __len__(self) -> int:
        return len(self.t)

    @property
    def duration(self) -> float:
        """Seconds the log covers, from the start of its first tick to the end of its last (a
        recorded log's clock may start anywhere; a simulated one starts at 0)."""
        return float(self.t[-1] - (self.t[0] - self.dt[0])) if len(self.t) else 0.0

    @property
    def has_ground_truth(self) -> bool:
        return self.gt_x is not None

    def ticks(self, start: int, stop: int) -> ObservationLog:
        """The ticks ``start:stop``, every column the log has."""
        return dataclasses.replace(
            self,
            **{f.name: v[start:stop] for f in dataclasses.fields(self) if (v := getattr(self, f.name)) is not None},
        )

    def ground_truth(self) -> np.ndarray:
        """Ground-truth poses (N, 3): x, y, theta. Raises if the log has none."""
        if self.gt_x is None or self.gt_y is None or self.gt_theta is None:
            raise ValueError("this observation log has no ground-truth columns")
        return np.column_stack([self.gt_x, self.gt_y, self.gt_theta])

    def columns(self) -> dict[str, np.ndarray]:
        cols = {c: getattr(self, c) for c in REQUIRED_COLUMNS}
        if self.image is not None:  # a camera log: the images in place of the scene numbers
            cols = {(IMAGE_COLUMN if c == "scene_id" else c): v for c, v in cols.items()}
            cols[IMAGE_COLUMN] = self.image
        if self.view_rotation is not None:
            cols[ROTATION_COLUMN] = self.view_rotation
        if self.has_ground_truth:
            cols.update({c: getattr(self, c) for c in GROUND_TRUTH_COLUMNS})
        return cols

    def write_csv(self, path) -> Path:
        """Write the log atomically. Floats use ``repr`` so a read-back is bit-exact."""
        cols = self.columns()
        names = list(cols)
        lines = [",".join(names)]
        formatted = [_format_column(name, cols[name]) for name in names]
        lines.extend(",".join(row) for row in zip(*formatted))
        return atomic_write_text(path, "\n".join(lines) + "\n")

    @classmethod
    def read_csv(cls, path) -> ObservationLog:
        """Read and validate a log written by anyone (simulator or user)."""
        path = Path(path)
        return _parse(path, read_text(path, ObservationLogError))


def _format_column(name: str, values: np.ndarray) -> list[str]:
    if name == IMAGE_COLUMN:
        return [str(v) for v in values]
    if name in _INT_COLUMNS:
        return [str(int(v)) for v in values]
    return [repr(float(v)) for v in values]


def _parse(path: Path, text: str) -> ObservationLog:
    rows = list(csv.reader(io.StringIO(text)))
    rows = [r for r in rows if r and any(c.strip() for c in r)]
    if not rows:
        raise ObservationLogError(f"{path}: empty file (expected header {','.join(REQUIRED_COLUMNS)})")
    header = [h.strip() for h in rows[0]]
    header[0] = header[0].lstrip("\ufeff")  # a byte-order mark (spreadsheets' "CSV UTF-8")
    known = set(REQUIRED_COLUMNS) | set(GROUND_TRUTH_COLUMNS) | {IMAGE_COLUMN, ROTATION_COLUMN}
    for h in header:
        if h not in known:
            raise ObservationLogError(f"{path}: header: unknown column {h!r} (allowed: {', '.join(sorted(known))})")
    if len(set(header)) != len(header):
        raise ObservationLogError(f"{path}: header: repeated column name")
    camera = IMAGE_COLUMN in header
    if camera and "scene_id" in header:
        raise ObservationLogError(f"{path}: header: a camera log has {IMAGE_COLUMN} instead of scene_id, not both")
    missing = [c for c in REQUIRED_COLUMNS if c not in header and not (camera and c == "scene_id")]
    if missing:
        raise ObservationLogError(f"{path}: header: missing column(s) {', '.join(missing)}")
    gt_present = [c for c in GROUND_TRUTH_COLUMNS if c in header]
    if gt_present and not all(c in header for c in GROUND_TRUTH_POSE):
        absent = [c for c in GROUND_TRUTH_POSE if c not in header]
        raise ObservationLogError(
            f"{path}: header: ground-truth columns need all of "
            f"{','.join(GROUND_TRUTH_POSE)}; missing {', '.join(absent)}"
        )
    data = rows[1:]
    if not data:
        raise ObservationLogError(f"{path}: no observations after the header")
    values = {
        h: np.empty(len(data), dtype=object if h == IMAGE_COLUMN else np.int64 if h in _INT_COLUMNS else float)
        for h in header
    }
    for i, row in enumerate(data):
        line = i + 2
        if len(row) != len(header):
            raise ObservationLogError(f"{path}: line {line}: expected {len(header)} fields, got {len(row)}")
        for h, cell in zip(header, row):
            values[h][i] = _parse_cell(path, line, h, cell.strip())
    if camera:
        values["scene_id"] = np.full(len(data), -1, dtype=np.int64)  # until the images are matched
    _check_semantics(path, values)
    fp = values.get("false_positive")
    if fp is None and gt_present:
        fp = np.zeros(len(data), dtype=np.int64)  # ground truth without labels: none flagged
    return ObservationLog(
        t=values["t"],
        dt=values["dt"],
        v_trans=values["v_trans"],
        v_rot=values["v_rot"],
        scene_id=values["scene_id"],
        gt_x=values.get("gt_x"),
        gt_y=values.get("gt_y"),
        gt_theta=values.get("gt_theta"),
        false_positive=None if fp is None else fp.astype(bool),
        image=values.get(IMAGE_COLUMN),
        view_rotation=values.get(ROTATION_COLUMN),
    )


def _parse_cell(path, line, column, cell):
    if column == IMAGE_COLUMN:
        if not cell:
            raise ObservationLogError(f"{path}: line {line}, column {column}: empty (an image file is needed)")
        return cell
    if column in _INT_COLUMNS:
        n = parse_int(cell)
        if n is None:
            raise ObservationLogError(f"{path}: line {line}, column {column}: not an integer ({cell!r})")
        if not -(2**63) <= n <= SCENE_ID_MAX:
            raise ObservationLogError(f"{path}: line {line}, column {column}: beyond a 64-bit integer ({cell})")
        return n  # the allowed values (scene_id >= -1, false_positive 0 or 1): _check_semantics
    try:
        v = float(cell)
    except ValueError:
        raise ObservationLogError(f"{path}: line {line}, column {column}: not a number ({cell!r})") from None
    if not np.isfinite(v):
        raise ObservationLogError(f"{path}: line {line}, column {column}: not a finite number ({cell!r})")
    return v


def _check_semantics(path, v):
    def fail(i, column, problem):
        raise ObservationLogError(f"{path}: line {int(i) + 2}, column {column}: {problem}")

    bad = np.flatnonzero(v["dt"] <= 0)
    if len(bad):
        fail(bad[0], "dt", f"must be positive, got {float(v['dt'][bad[0]])!r}")
    for column in ("t", "dt"):
        bad = np.flatnonzero(np.abs(v[column]) > MAX_SECONDS)
        if len(bad):
            fail(bad[0], column, f"beyond {MAX_SECONDS:.0e} s, got {float(v[column][bad[0]])!r} (times are in seconds)")
    bad = np.flatnonzero(np.diff(v["t"]) <= 0)
    if len(bad):
        t0, t1 = float(v["t"][bad[0]]), float(v["t"][bad[0] + 1])
        fail(bad[0] + 1, "t", f"time must increase strictly ({t0!r} then {t1!r})")
    if len(v["t"]) > 1:
        # dt is the tick's duration and t the time at its end: a dt in milliseconds, or t in
        # other units than dt, integrates the odometry wrongly by that factor
        ratio = float(np.median(v["dt"][1:] / np.diff(v["t"])))
        if not 1.0 / DT_MISMATCH <= ratio <= DT_MISMATCH:
            raise ObservationLogError(
                f"{path}: column dt: does not match the spacing of t (median dt / t step = {ratio:.4g}); dt must be "
                "each tick's duration in seconds and t the time at its end, in seconds"
            )
    bad = np.flatnonzero(v["scene_id"] < -1)
    if len(bad):
        fail(bad[0], "scene_id", f"must be >= -1 (-1 = no scene), got {v['scene_id'][bad[0]]}")
    if "false_positive" in v:
        bad = np.flatnonzero((v["false_positive"] != 0) & (v["false_positive"] != 1))
        if len(bad):
            fail(bad[0], "false_positive", f"must be 0 or 1, got {v['false_positive'][bad[0]]}")
