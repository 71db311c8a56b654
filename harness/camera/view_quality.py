"""The view matcher's quality on a simulated camera stream, judged against ground truth.

A world is simulated, every tick's ground-truth pose rendered by the camera, and the frames
matched in order by :class:`ratslam.view_matcher.ViewMatcher`. A match is *correct* when the
matched template was stored within ``radius_m`` (1 m) and ``heading_deg`` (30 degrees) of the
current pose. Counted over every tick and over *revisits* only (matches to templates stored at
least ``revisit_s`` seconds before, the loop closures that matter; consecutive frames of one
place match the template just stored):

- precision: correct matches / matches (and with the match's rotation added to the stored
  heading: a panoramic view matches a place at any heading);
- recall: ticks matched correctly / ticks at which a correct template existed (a template stored
  earlier, older than ``revisit_s`` for revisits, within the radius and heading);
- templates per place: templates / places visited (1 m cells x 90 degree heading sectors);
- aliasing: the share of templates that matched somewhere more than ``alias_m`` (3 m) from where
  they were stored, and the median distance of the wrong revisit matches.

``python -m harness.camera.view_quality WORLD [--camera forward] [--duration S] [--seed N] [--threshold T]``
prints them (docs/camera.md has the measured numbers).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from ratslam import ViewConfig
from ratslam.view_matcher import ViewMatcher
from worlds import load_world, simulate
from worlds.camera import Camera

from .stream import camera_view_config


@dataclass(frozen=True)
class ViewQuality:
    """The matcher's quality on one stream (see the module doc)."""

    ticks: int
    templates: int
    places: int
    precision: float
    turned_precision: float
    recall: float
    revisit_precision: float
    revisit_recall: float
    revisit_matches: int
    aliased_templates: float
    wrong_revisit_median_m: float
    match_s: float  # seconds spent matching

    @property
    def templates_per_place(self) -> float:
        return self.templates / max(self.places, 1)


def match_stream(images: np.ndarray, config: ViewConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each frame's template, rotation (rad) and whether it was new, matched in order."""
    vm = ViewMatcher(config)
    n = len(images)
    template, rotation, new = np.zeros(n, dtype=np.int64), np.zeros(n), np.zeros(n, dtype=bool)
    for k, im in enumerate(images):
        m = vm.match(im)
        template[k], rotation[k], new[k] = m.template, m.rotation, m.new
    return template, rotation, new


def judge(
    poses: np.ndarray,
    t: np.ndarray,
    template: np.ndarray,
    new: np.ndarray,
    rotation: np.ndarray,
    radius_m: float = 1.0,
    heading_deg: float = 30.0,
    revisit_s: float = 30.0,
    alias_m: float = 3.0,
) -> dict:
    """Precision, recall and aliasing of a matched stream against its ground-truth poses."""
    stored_at = np.flatnonzero(new)  # template i was stored at tick stored_at[i]
    sp = poses[stored_at]
    n = len(poses)
    close_any = np.zeros(n, dtype=bool)
    close_old = np.zeros(n, dtype=bool)
    correct = np.zeros(n, dtype=bool)
    turned = np.zeros(n, dtype=bool)  # correct once the match's rotation is added to the heading
    dist = np.zeros(n)
    cos_h = math.cos(math.radians(heading_deg))
    for k in range(n):
        m = int(np.searchsorted(stored_at, k))  # templates stored before tick k
        if m:
            d = np.hypot(sp[:m, 0] - poses[k, 0], sp[:m, 1] - poses[k, 1])
            near = (d <= radius_m) & (np.cos(sp[:m, 2] - poses[k, 2]) >= cos_h)
            close_any[k] = near.any()
            close_old[k] = (near & (t[stored_at[:m]] <= t[k] - revisit_s)).any()
        if not new[k]:
            s = stored_at[template[k]]
            dist[k] = math.hypot(poses[s, 0] - poses[k, 0], poses[s, 1] - poses[k, 1])
            correct[k] = dist[k] <= radius_m and math.cos(poses[s, 2] - poses[k, 2]) >= cos_h
            turned[k] = dist[k] <= radius_m and math.cos(poses[s, 2] + rotation[k] - poses[k, 2]) >= cos_h
    matched = ~new
    revisit = matched & (t[stored_at[template]] <= t - revisit_s)
    wrong_revisit = revisit & ~correct
    aliased = np.unique(template[matched & (dist > alias_m)])
    return {
        "precision": float(correct[matched].mean()) if matched.any() else math.nan,
        "turned_precision": float(turned[matched].mean()) if matched.any() else math.nan,
        "recall": float((correct & close_any).sum() / max(close_any.sum(), 1)),
        "revisit_precision": float(correct[revisit].mean()) if revisit.any() else math.nan,
        "revisit_recall": float((correct & revisit & close_old).sum() / max(close_old.sum(), 1)),
        "revisit_matches": int(revisit.sum()),
        "aliased_templates": float(len(aliased) / max(len(stored_at), 1)),
        "wrong_revisit_median_m": float(np.median(dist[wrong_revisit])) if wrong_revisit.any() else math.nan,
    }


def places_visited(poses: np.ndarray) -> int:
    """Distinct 1 m cells x 90 degree heading sectors the poses pass through."""
    sector = np.floor((poses[:, 2] + math.pi / 4) / (math.pi / 2)).astype(np.int64) % 4
    keys = np.stack((np.floor(poses[:, 0]), np.floor(poses[:, 1]), sector), axis=1)
    return len(np.unique(keys, axis=0))


def view_quality(
    world, kind: str = "forward", duration: float | None = None, seed: int = 0, config: ViewConfig | None = None
) -> ViewQuality:
    """Simulate ``world``, render and match its stream, judge the matches (see the module doc)."""
    world = load_world(world)
    log = simulate(world, duration=duration, seed=seed)
    poses = log.ground_truth()
    images = Camera(world, kind, seed=seed).render_poses(poses, log.t)
    config = config or camera_view_config(kind)
    t0 = time.perf_counter()
    template, rotation, new = match_stream(images, config)
    elapsed = time.perf_counter() - t0
    q = judge(poses, log.t, template, new, rotation)
    return ViewQuality(ticks=len(log), templates=int(new.sum()), places=places_visited(poses), match_s=elapsed, **q)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("world", nargs="+")
    ap.add_argument("--camera", default="forward", choices=("forward", "panoramic"))
    ap.add_argument("--duration", type=float)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threshold", type=float, nargs="+", help="match thresholds (default: the config's)")
    ap.add_argument("--template", help="template size COLUMNSxROWS (default: the config's)")
    ap.add_argument("--noise", type=float, help="camera sensor noise (default: the world's)")
    ap.add_argument("--lighting", type=float, help="lighting amplitude (default: the world's)")
    ap.add_argument("--global-normalisation", action="store_true")
    ap.add_argument("--patch-radius", type=int, default=0)
    args = ap.parse_args(argv)
    base = camera_view_config(args.camera)
    changes: dict = {"global_normalisation": args.global_normalisation, "patch_normalisation_radius": args.patch_radius}
    if args.template:
        w, h = (int(v) for v in args.template.split("x"))
        changes.update(template_width=w, template_height=h)
    print(
        "world         threshold  ticks  templates  per place  precision  +rotation  recall  revisit prec"
        "  revisit rec  revisits  aliased tpl  wrong med m  match s"
    )
    for name in args.world:
        world = load_world(name)
        cam = world.camera
        if args.noise is not None:
            cam = dataclasses.replace(cam, noise=args.noise)
        if args.lighting is not None:
            cam = dataclasses.replace(cam, lighting_amplitude=args.lighting)
        world = dataclasses.replace(world, camera=cam)
        for threshold in args.threshold or [base.match_threshold]:
            cfg = dataclasses.replace(base, match_threshold=threshold, **changes)
            q = view_quality(world, args.camera, args.duration, args.seed, cfg)
            print(
                f"{world.name:<13} {threshold:>9.3f} {q.ticks:>6} {q.templates:>10} {q.templates_per_place:>10.2f}"
                f" {q.precision:>10.3f} {q.turned_precision:>10.3f} {q.recall:>7.3f} {q.revisit_precision:>13.3f}"
                f" {q.revisit_recall:>12.3f}"
                f" {q.revisit_matches:>9} {q.aliased_templates:>12.3f} {q.wrong_revisit_median_m:>12.2f}"
                f" {q.match_s:>8.1f}"
            )


if __name__ == "__main__":
    main()
