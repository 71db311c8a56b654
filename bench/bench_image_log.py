"""End-to-end speed of a camera log: ``ratslam-harness replay`` of a 15-minute 10 Hz image log.

    python bench/bench_image_log.py --out DIR [--world open_plan] [--duration 900] [--rate 10]
        [--kind png64 png320 jpeg640] [--no-recording] [--draft-check]

Each kind of log is made first (not timed), in ``DIR``:

- ``png64``: the simulator's camera log (``simulate --camera forward``) of the world run at
  ``--rate`` Hz: 64x16 grey PNGs;
- ``png320``: the same with the camera at 320x240 (vertical field of view 37.5 degrees);
- ``jpeg640``: a real camera's stand-in: the 320x240 frames with sensor noise 0.03, enlarged to
  640x480, tinted to colour and saved as JPEGs (quality 90) named by their time stamps, then turned
  into an image log by ``import images`` with the run's TUM odometry.

Then each log is replayed end to end by the command a user runs, in a fresh process, and its
wall time is printed with the multiple of real time. ``--draft-check`` also matches the
``jpeg640`` log's images with and without the reduced JPEG decoding.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from PIL import Image

from harness.record.log_output import simulate_to_files
from harness.run.runner import dead_reckon
from worlds import load_world
from worlds.camera import Camera, to_uint8
from worlds.files import write_tum


def world_file(out: Path, world: str, rate: float, size: tuple[int, int], noise: float = 0.0) -> Path:
    """A copy of a shipped world at ``rate`` Hz with the forward camera at ``size``."""
    w = load_world(world)
    text = Path(w.path).read_text()
    text = text.replace(f"tick_rate = {w.tick_rate}", f"tick_rate = {rate}")
    text = text.replace(f'name = "{w.name}"', f'name = "{w.name}_{size[0]}x{size[1]}"')
    vfov = 37.5 if size[1] * 4 == size[0] * 3 else w.camera.vfov_deg
    text += f"\n[camera]\nwidth = {size[0]}\nheight = {size[1]}\nvfov_deg = {vfov}\nnoise = {noise}\n"
    path = out / f"{w.name}_{rate:g}hz_{size[0]}x{size[1]}.toml"
    path.write_text(text)
    return path


def make_log(kind: str, out: Path, world: str, rate: float, duration: float) -> Path:
    log_path = out / f"{kind}.csv"
    if kind == "png64":
        simulate_to_files(
            world_file(out, world, rate, (64, 16)), log_path, duration=duration, camera="forward", show_progress=False
        )
    elif kind == "png320":
        simulate_to_files(
            world_file(out, world, rate, (320, 240)), log_path, duration=duration, camera="forward", show_progress=False
        )
    else:
        wf = world_file(out, world, rate, (320, 240), noise=0.03)
        sim = simulate_to_files(wf, out / "jpeg_source.csv", duration=duration, show_progress=False)
        log = sim.log
        frames = Camera(load_world(wf), "forward", seed=0).render_poses(log.ground_truth(), log.t)
        folder = out / "jpeg_frames"
        folder.mkdir(exist_ok=True)
        for k, frame in enumerate(frames):
            grey = Image.fromarray(to_uint8(frame), mode="L").resize((640, 480), Image.Resampling.BILINEAR)
            rgb = Image.merge("RGB", (grey, grey.point(lambda v: int(v * 0.9)), grey.point(lambda v: int(v * 0.8))))
            rgb.save(folder / f"{log.t[k]:.3f}.jpg", quality=90)
        poses = np.vstack(([0.0, 0.0, 0.0], dead_reckon(log)))
        t = np.concatenate(([log.t[0] - log.dt[0]], log.t))
        write_tum(out / "odom.tum", t, poses[:, 0], poses[:, 1], poses[:, 2])
        gt = np.vstack((log.ground_truth()[:1], log.ground_truth()))
        write_tum(out / "gt.tum", t, gt[:, 0], gt[:, 1], gt[:, 2])
        cmd = ["import", "images", str(folder), "--odometry", str(out / "odom.tum"), "--gt", str(out / "gt.tum")]
        subprocess.run([sys.executable, "-m", "harness.cli", *cmd, "--out", str(log_path), "--fov", "50"], check=True)
    return log_path


def draft_check(log_path: Path) -> None:
    """Match a JPEG log's images at the fixed 0.04 with the reduced (draft) decoding and fully
    decoded: seconds, templates and quality against the log's ground truth."""
    from harness.camera import stream as camera_stream
    from harness.camera.view_quality import judge
    from ratslam import ViewConfig
    from worlds import ObservationLog

    log = ObservationLog.read_csv(log_path)
    config = ViewConfig(template_width=32, template_height=16)
    reduced = camera_stream._draft_to
    for name, draft in (("reduced", reduced), ("full", lambda c: None)):
        camera_stream._draft_to = draft
        t0 = time.perf_counter()
        matched = camera_stream.match_camera_log(log, log_path, config)
        elapsed = time.perf_counter() - t0
        new = np.diff(np.maximum.accumulate(np.concatenate(([-1], matched.scene_id)))) > 0
        q = judge(log.ground_truth(), log.t, matched.scene_id, new, matched.view_rotation)
        print(
            f"{name} decoding: matched in {elapsed:.1f} s, {int(new.sum())} templates, "
            f"precision {q['precision']:.3f}, recall {q['recall']:.3f}",
            flush=True,
        )
    camera_stream._draft_to = reduced


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--world", default="open_plan")
    ap.add_argument("--duration", type=float, default=900.0)
    ap.add_argument("--rate", type=float, default=10.0)
    ap.add_argument("--kind", nargs="+", default=["png64", "png320", "jpeg640"])
    ap.add_argument("--no-recording", action="store_true")
    ap.add_argument("--draft-check", action="store_true", help="jpeg640: matching with and without reduced decoding")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    for kind in args.kind:
        log_path = make_log(kind, args.out, args.world, args.rate, args.duration)
        cmd = [sys.executable, "-m", "harness.cli", "replay", str(log_path), "--out", str(args.out / f"run_{kind}")]
        cmd += ["--quiet"] + (["--no-recording"] if args.no_recording else [])
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
        speed = f"{args.duration / wall:.1f}x real time"
        print(f"{kind}: {args.duration:g} s at {args.rate:g} Hz replayed in {wall:.1f} s, {speed}", flush=True)
        if args.draft_check and kind == "jpeg640":
            draft_check(log_path)


if __name__ == "__main__":
    main()
