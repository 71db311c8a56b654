"""The view-template matcher: a camera image to a template number and a relative rotation.

The paper's robot "processed camera output through a sum of absolute differences view matcher,
that classifies scenes as new or already seen". Here (settings in ``RatSLAMConfig.view``,
:class:`~ratslam.config.ViewConfig`):

1. the image (grey levels, uint8 or floats in [0, 1]) is cropped and averaged down to a template
   of ``template_height`` x ``template_width``;
2. optionally normalised: globally (scaled to mean 0.5, which undoes a lighting gain) and by
   patches (each pixel's z-score in its neighbourhood, mapped to [0, 1]);
3. compared with every stored template by the mean absolute difference over horizontal shifts
   (within ``max_shift_deg`` either way for a forward camera, every shift around the circle for a
   panoramic one); a cheap exact pre-filter first skips the templates and shifts whose overlapping
   parts' mean intensities (of the upper and lower halves) already differ by the threshold;
4. the least difference below ``match_threshold`` makes the view that template (the newest
   template wins an exact tie); otherwise the view is stored as a new template.

The best shift gives the relative rotation of the view against the template's, ``shift x field of
view / width``: the view's column ``j`` matched the template's column ``j - shift``, its content
moved right by ``shift`` columns, so the camera turned left (counter-clockwise, positive) by that
much since the template was stored. RatSLAM injects the view's energy at the template's heading
plus this rotation (:meth:`ratslam.local_view.LocalView.inject`). Template numbers count from 0 in
the order the templates were stored and serve as scene numbers for both systems.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from .config import ViewConfig
from .template_kernels import all_differences, best_template


@dataclass(frozen=True)
class ViewMatch:
    """One view's outcome: the template (its number), the relative rotation (rad, positive =
    counter-clockwise since the template was stored), the mean absolute difference (0 for a new
    template) and whether the template is new."""

    template: int
    rotation: float
    difference: float
    new: bool


class ViewMatcher:
    """Stored templates and the matching of views against them (see the module doc)."""

    def __init__(self, config: ViewConfig | None = None):
        self.config = config if config is not None else ViewConfig()
        c = self.config
        w, h = c.template_width, c.template_height
        self._templates = np.zeros((16, w, h), dtype=np.float64)  # column-major: (n, width, height)
        self._cols = np.zeros((16, w))
        self._halves = np.zeros((16, w, 2))
        self._cums = np.zeros((16, w + 1, 2))
        self._n = 0
        self.col_rad = math.radians(c.field_of_view_deg) / w
        if c.panoramic:  # every shift around the circle, the smaller turns first
            order = sorted(range(w), key=lambda s: (min(s, w - s), s > w // 2))
        else:
            m = min(int(math.floor(math.radians(c.max_shift_deg) / self.col_rad + 1e-9)), w - 1)
            order = [0] + [s for k in range(1, m + 1) for s in (k, -k)]
        self.shifts = np.array(order, dtype=np.int64)

    def __len__(self) -> int:
        return self._n

    @property
    def templates(self) -> np.ndarray:
        """Stored templates (n, template_height, template_width), read-only copy."""
        return self._templates[: self._n].transpose(0, 2, 1).copy()

    def template(self, number: int) -> np.ndarray:
        """Stored template ``number`` (template_height, template_width), a copy: e.g. the image a
        view matched, for display."""
        if not 0 <= number < self._n:
            raise IndexError(f"view: no template {number} (templates stored: {self._n})")
        return self._templates[number].T.copy()

    def template_of(self, image) -> np.ndarray:
        """The template (template_height, template_width) of an image: cropped, averaged down,
        normalised as configured."""
        c = self.config
        img = np.asarray(image)
        if img.ndim != 2:
            raise ValueError(f"view: an image must be 2-D (rows, columns) grey levels, got shape {img.shape}")
        img = img.astype(np.float64) / 255.0 if img.dtype == np.uint8 else img.astype(np.float64)
        rows, cols = img.shape
        img = img[c.crop_top : rows - c.crop_bottom, c.crop_left : cols - c.crop_right]
        if img.shape[0] < c.template_height or img.shape[1] < c.template_width:
            raise ValueError(
                f"view: image {rows}x{cols} cropped to {img.shape[0]}x{img.shape[1]} is smaller than the template "
                f"{c.template_height}x{c.template_width} (view.crop_*, view.template_*)"
            )
        t = _area_mean(_area_mean(img, c.template_height, 0), c.template_width, 1)
        if c.global_normalisation:
            mean = t.mean()
            t = np.clip(t * (0.5 / mean), 0.0, 1.0) if mean > 0 else np.full_like(t, 0.5)
        if c.patch_normalisation_radius > 0:
            size = 2 * c.patch_normalisation_radius + 1
            modes = ("nearest", "wrap" if c.panoramic else "nearest")
            mu = ndimage.uniform_filter(t, size, mode=modes)
            var = np.maximum(ndimage.uniform_filter(t * t, size, mode=modes) - mu * mu, 0.0)
            t = np.clip(0.5 + (t - mu) / (4.0 * np.sqrt(var) + 1e-3), 0.0, 1.0)
        return t

    def match(self, image) -> ViewMatch:
        """The view's template and rotation; a view like no stored template is stored as new."""
        t = self.template_of(image)
        view = np.ascontiguousarray(t.T)
        cols, halves, cum = _statistics(view)
        i, s, d = best_template(
            view,
            cols,
            halves,
            cum,
            self._templates,
            self._cols,
            self._halves,
            self._cums,
            self._n,
            self.shifts,
            self.config.panoramic,
            self.config.match_threshold,
            self.config.mean_prefilter,
        )
        if i >= 0:
            return ViewMatch(int(i), self._rotation(int(s)), float(d), False)
        return ViewMatch(self._store(view, cols, halves, cum), 0.0, 0.0, True)

    def store(self, image) -> int:
        """Store the image's template without matching it (building a template set, e.g. for a
        benchmark); returns its number."""
        view = np.ascontiguousarray(self.template_of(image).T)
        return self._store(view, *_statistics(view))

    def differences(self, image) -> tuple[np.ndarray, np.ndarray]:
        """Every stored template's least difference to the image and the rotation at which it is
        least (no pre-filter, no storing: for diagnostics and tests)."""
        view = np.ascontiguousarray(self.template_of(image).T)
        d, s = all_differences(view, self._templates, self._n, self.shifts, self.config.panoramic)
        return d, np.array([self._rotation(int(k)) for k in s])

    def _rotation(self, shift: int) -> float:
        w = self.config.template_width
        if self.config.panoramic and shift > w // 2:
            shift -= w
        return shift * self.col_rad

    def _store(self, view: np.ndarray, cols: np.ndarray, halves: np.ndarray, cum: np.ndarray) -> int:
        if self._n == len(self._templates):
            grow = len(self._templates)
            self._templates = np.concatenate((self._templates, np.zeros_like(self._templates[:grow])))
            self._cols = np.concatenate((self._cols, np.zeros_like(self._cols[:grow])))
            self._halves = np.concatenate((self._halves, np.zeros_like(self._halves[:grow])))
            self._cums = np.concatenate((self._cums, np.zeros_like(self._cums[:grow])))
        k = self._n
        self._templates[k], self._cols[k], self._halves[k], self._cums[k] = view, cols, halves, cum
        self._n += 1
        return k


def _statistics(view: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A column-major template's column means (width,), the means of each column's upper and
    lower half (width, 2; the lower half has the extra row of an odd height; a one-row template's
    upper half is empty, mean 0) and their running sums over the columns (width + 1, 2)."""
    split = view.shape[1] // 2
    upper = view[:, :split].mean(axis=1) if split > 0 else np.zeros(view.shape[0])
    halves = np.stack((upper, view[:, split:].mean(axis=1)), axis=1)
    cum = np.concatenate((np.zeros((1, 2)), np.cumsum(halves, axis=0)))
    return view.mean(axis=1), halves, cum


def _area_mean(a: np.ndarray, n: int, axis: int) -> np.ndarray:
    """``a`` averaged down to ``n`` bins along ``axis`` (bin ``i`` covers input indices
    ``floor(i L / n)`` to ``floor((i + 1) L / n)``)."""
    length = a.shape[axis]
    if length == n:
        return a
    edges = (np.arange(n + 1) * length) // n
    sums = np.add.reduceat(a, edges[:-1], axis=axis)
    counts = np.diff(edges).astype(np.float64)
    return sums / (counts[:, None] if axis == 0 else counts[None, :])
