"""Which match threshold holds up on a user's camera: a fixed one, or one from the first minute's
self-similarity. Measured on the simulator's camera at several image sizes, with sensor noise,
changing light, and "real-looking" frames, judged against ground truth as
:mod:`harness.camera.view_quality` judges (precision, recall, templates per place).

Real-looking frames: the rendered frame enlarged twice (bicubic), blurred (Gaussian, radius
1.5 px of the enlarged frame) and stored as a JPEG of quality 85, then decoded, as an image log
from a real camera would be. The template is derived from the frames' size
(:func:`harness.camera.stream.derived_template_size`).

The self-similarity threshold is :func:`harness.camera.stream.self_similar_threshold`'s: over
the stream's first minute, each frame's least difference (over the matcher's shifts) to the
frame 0.3 m of odometry travel before it; the threshold is 0.9 times their median (the scale set
so that the simulator's default forward camera on the small loop gets about its fixed 0.04).

``python -m harness.camera.image_quality small_loop open_plan`` prints a table (docs/your-camera.md).
"""

from __future__ import annotations

import argparse
import dataclasses
import io
import time

import numpy as np
from PIL import Image, ImageFilter

from ratslam import ViewConfig
from worlds import load_world, simulate
from worlds.camera import Camera, to_uint8

from .stream import SELF_SIMILAR_SCALE, derived_template_size, self_similarity
from .view_quality import judge, match_stream, places_visited


def real_looking(frame: np.ndarray) -> np.ndarray:
    """A rendered frame as a real camera's might arrive: enlarged twice, blurred, JPEG-compressed."""
    im = Image.fromarray(frame, mode="L")
    im = im.resize((2 * im.width, 2 * im.height), Image.Resampling.BICUBIC).filter(ImageFilter.GaussianBlur(1.5))
    buf = io.BytesIO()
    im.save(buf, format="JPEG", quality=85)
    buf.seek(0)
    with Image.open(buf) as decoded:
        return np.asarray(decoded.convert("L"))


CONDITIONS: dict[str, dict] = {
    "64x16": dict(size=(64, 16)),
    "128x32": dict(size=(128, 32)),
    "320x240": dict(size=(320, 240), vfov=37.5),
    "64x16 noise 0.03": dict(size=(64, 16), noise=0.03),
    "64x16 lighting 0.3": dict(size=(64, 16), lighting=0.3),
    "real-looking 640x480": dict(size=(320, 240), vfov=37.5, noise=0.03, real=True),
}


def frames_of(world_name: str, condition: dict, duration: float | None, seed: int):
    world = load_world(world_name)
    cam = dataclasses.replace(
        world.camera,
        width=condition["size"][0],
        height=condition["size"][1],
        vfov_deg=condition.get("vfov", world.camera.vfov_deg),
        noise=condition.get("noise", world.camera.noise),
        lighting_amplitude=condition.get("lighting", world.camera.lighting_amplitude),
    )
    world = dataclasses.replace(world, camera=cam)
    log = simulate(world, duration=duration, seed=seed)
    frames = to_uint8(Camera(world, "forward", seed=seed).render_poses(log.ground_truth(), log.t))
    if condition.get("real"):
        frames = np.stack([real_looking(f) for f in frames])
    return log, frames


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("world", nargs="+")
    ap.add_argument("--duration", type=float)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--conditions", nargs="+", default=list(CONDITIONS), choices=list(CONDITIONS))
    ap.add_argument("--scale", type=float, default=SELF_SIMILAR_SCALE, help="self-similar threshold's scale")
    args = ap.parse_args(argv)
    print(
        "| world | frames | template | threshold | value | templates | per place | precision | recall "
        "| revisit precision | revisit recall | match s |"
    )
    print("|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name in args.world:
        for cond in args.conditions:
            log, frames = frames_of(name, CONDITIONS[cond], args.duration, args.seed)
            h, w = frames.shape[1:]
            tw, th = derived_template_size(w, h, panoramic=False)
            base = ViewConfig(template_width=tw, template_height=th)
            median, _ = self_similarity(frames.__getitem__, log, base)
            poses = log.ground_truth()
            for rule, value in (("fixed", base.match_threshold), ("self-similar", args.scale * median)):
                cfg = dataclasses.replace(base, match_threshold=value)
                t0 = time.perf_counter()
                template, rotation, new = match_stream(frames, cfg)
                elapsed = time.perf_counter() - t0
                q = judge(poses, log.t, template, new, rotation)
                n_t = int(new.sum())
                print(
                    f"| {name} | {cond} | {tw}x{th} | {rule} | {value:.4f} | {n_t} | "
                    f"{n_t / max(places_visited(poses), 1):.1f} | {q['precision']:.3f} | {q['recall']:.3f} | "
                    f"{q['revisit_precision']:.3f} | {q['revisit_recall']:.3f} | {elapsed:.1f} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
