"""``ratslam-harness``: the command-line entry point (thin layer over the library).

Every user-facing error derives from :class:`worlds.errors.InputError` and is printed as one
line on stderr with exit status 2; any other exception is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import signal
import sys
import typing
from pathlib import Path

import numpy as np

from worlds import InputError, list_worlds, load_world

from ..record.log_output import check_writable
from ..run.directory import output_errors

if typing.TYPE_CHECKING:
    from ..figures.stream_run import RatSLAMChoice


class CliError(InputError):
    """A command-line usage error: printed as one line on stderr, exit status 2 (as every
    :class:`~worlds.errors.InputError` is)."""


def _cmd_list(args) -> None:
    from ..figures.registry import FIGURES

    print("figures:")
    for fig in FIGURES.values():
        source = fig.world or f"real log {fig.real_log}"
        length = "whole log" if fig.duration is None else f"{fig.duration / 60:g} min"
        print(f"  {fig.name:<7} {fig.title} [{source}, {length}]")
    print("worlds:")
    for name in list_worlds():
        w = load_world(name)
        print(f"  {name:<14} {w.size[0]:g} m x {w.size[1]:g} m, {w.duration / 60:g} min default")
    print("experiments:")
    print("  nav            goal navigation on RatSLAM's experience map and GTSAM's pose graph (nav WORLD)")


def _cmd_simulate(args) -> None:
    from ..record.log_output import simulate_to_files

    sim = simulate_to_files(
        args.world,
        args.out,
        png=args.png,
        duration=args.duration,
        seed=args.seed,
        bias_deg_s=args.bias,
        fp_rate=args.fp,
        show_progress=not args.quiet,
        camera=args.camera,
        yes=args.yes,
    )
    images = f", {len(sim.log)} {args.camera} camera images in {sim.csv.stem}_images/" if args.camera else ""
    print(f"wrote {sim.csv} ({len(sim.log)} ticks, {sim.log.t[-1]:.0f} s simulated{images}) and {sim.png}")


def _cmd_run(args) -> None:
    from ..figures.registry import get_figure
    from ..figures.run import run_figure
    from ..record.recorder import recorder_factory
    from ..run.config_file import read_config_file

    fig = get_figure(args.figure)  # unknown names fail before anything starts
    config = read_config_file(args.config) if args.config else None
    _check_figure_size(fig, config, args.duration, args.yes)
    out = run_figure(
        args.figure,
        out=args.out,
        seed=args.seed,
        duration=args.duration,
        show_progress=not args.quiet,
        recorder_factory=None if args.no_recording else recorder_factory,
        workers=args.workers,
        config=config,
        ratslam=_ratslam_choice(args.ratslam, config, "both"),
        camera=args.camera,
    )
    _print_run_summary(out)


def _check_figure_size(fig, config, duration, yes: bool) -> None:
    """A figure's pose-cell grid (with the configuration file's fields) and stream length against
    the budget (:mod:`harness.run.budget`), before anything runs."""
    from ..figures.registry import figure_configs
    from ..run.budget import check_grid, check_ticks

    rs, pg = figure_configs(fig)
    if config is not None:
        rs, _ = config.apply(rs, pg)
    check_grid(config.source if config is not None and config.source else fig.name, rs.shape, yes)
    duration = fig.duration if duration is None else duration
    if fig.world is not None and duration is not None:
        check_ticks(f"{fig.name}: --duration {duration:g}", duration * load_world(fig.world).tick_rate, yes)


def _cmd_replay(args) -> None:
    from ..figures.run import replay
    from ..record.recorder import recorder_factory
    from ..run.config_file import read_config_file

    config = read_config_file(args.config) if args.config else None
    out = replay(
        args.log,
        args.out,
        show_progress=not args.quiet,
        recorder_factory=None if args.no_recording else recorder_factory,
        config=config,
        ratslam=_ratslam_choice(args.ratslam, config, "defaults"),
        yes=args.yes,
        fov_deg=args.fov,
    )
    _print_run_summary(out)


def _ratslam_choice(given: str | None, config, default: RatSLAMChoice) -> RatSLAMChoice:
    """``--ratslam``: as given; else the configuration file's own when it names a preset (its
    fields go on top of the preset, run alone), else ``default``."""
    if given is not None:
        return typing.cast("RatSLAMChoice", given)
    return "defaults" if config is not None and config.preset is not None else default


def _ratslam_option(parser, default: str) -> None:
    parser.add_argument(
        "--ratslam",
        choices=("defaults", "published", "both"),
        help="RatSLAM's configuration: the project's defaults, the paper's published algorithm "
        f"(RatSLAMConfig.published()), or both on the same stream (default: {default}; a --config "
        "file with a preset: that file's configuration)",
    )


def _cmd_import_plaza(args) -> None:
    from worlds.real_data import load_plaza

    out = check_writable(args.out)
    log = load_plaza(args.name, seed=args.seed, fp_rate=args.fp, duration=args.duration)
    with output_errors(out):
        log.write_csv(out)
    speed = float(np.median(np.abs(log.v_trans)))
    print(
        f"wrote {out} ({len(log)} ticks, {log.t[-1] - log.t[0] + log.dt[0]:.0f} s, median speed "
        f"{speed:.2f} m/s at {1.0 / float(np.median(log.dt)):.0f} Hz; scene numbers synthesised from "
        f"the ground truth)"
    )


def _cmd_import_tum(args) -> None:
    from worlds.real_data import PLAZA_SCENES
    from worlds.trajectory_import import import_tum

    out = check_writable(args.out, inputs=(args.odometry, args.gt, args.labels))
    log = import_tum(
        args.odometry,
        ground_truth=args.gt,
        labels=args.labels,
        synthesise=PLAZA_SCENES if args.synthesise else None,
        label_max_age=args.label_max_age,
        seed=args.seed,
    )
    _write_imported(log, out)


def _write_imported(log, out: Path) -> None:
    with output_errors(out):
        log.write_csv(out)
    seen = int((log.scene_id >= 0).sum())
    print(
        f"wrote {out} ({len(log)} ticks, {seen} with a scene number{', ground truth' if log.has_ground_truth else ''})"
    )


def _cmd_import_rosbag(args) -> None:
    if args.image is not None:
        _cmd_import_bag_images(args)
        return
    if args.camera_info is not None:
        raise InputError("--camera-info: goes with --image (a camera topic)")
    from worlds.bag_import import import_bag
    from worlds.real_data import PLAZA_SCENES

    out = check_writable(args.out, inputs=(args.bag,))
    log = import_bag(
        args.bag,
        args.odom,
        ground_truth_topic=args.gt,
        label_topic=args.labels,
        synthesise=PLAZA_SCENES if args.synthesise else None,
        twist=args.twist,
        label_max_age=args.label_max_age,
        seed=args.seed,
    )
    _write_imported(log, out)


def _cmd_import_images(args) -> None:
    from worlds.image_folder import import_image_folder
    from worlds.image_log import CameraDescription, write_image_log

    out = check_writable(args.out, inputs=(args.odometry, args.gt))
    paired = import_image_folder(
        args.folder, args.odometry, ground_truth=args.gt, rate=args.rate, time_unit=args.time_unit
    )
    camera = None if args.fov is None else CameraDescription(args.fov, source="ratslam-harness import images")
    log = write_image_log(out, paired.odometry, paired.images, camera)
    skipped = (
        f"; {paired.skipped} ticks before the first image and {paired.skipped_at_end} after the last left out"
        if paired.skipped or paired.skipped_at_end
        else ""
    )
    print(
        f"wrote {out} and {out.stem}_images/ ({len(log)} ticks, {len(set(paired.images))} images"
        f"{', ground truth' if log.has_ground_truth else ''}{skipped})"
    )


def _import_images_parser(isub) -> None:
    """``import images FOLDER --odometry ODOM.tum --out LOG.csv``: an image folder as an image log."""
    im = isub.add_parser(
        "images",
        help="a folder of camera images (time stamps or frame numbers in their names) and a TUM odometry "
        "trajectory as an image log: each tick with the latest image at or before it",
    )
    im.add_argument("folder", help="folder of .png / .jpg images, each name carrying its time stamp or frame number")
    im.add_argument("--odometry", required=True, help="odometry trajectory (TUM: t x y z qx qy qz qw)")
    im.add_argument("--out", required=True, help="image log to write (CSV; its images go to LOG_images/)")
    im.add_argument("--gt", help="ground-truth trajectory (TUM), interpolated at the odometry's times")
    im.add_argument(
        "--rate", type=_positive, help="the names carry frame numbers taken at this rate (Hz) from the odometry's start"
    )
    im.add_argument(
        "--time-unit", choices=("s", "ms", "us", "ns"), default="s", help="unit of the names' time stamps (default s)"
    )
    _import_fov_option(im)
    im.set_defaults(func=_cmd_import_images)


def _fov(text: str) -> float:
    v = _positive(text)
    if v > 360.0:
        raise argparse.ArgumentTypeError(f"must be at most 360 degrees, got {text!r}")
    return v


def _import_fov_option(parser) -> None:
    parser.add_argument(
        "--fov", type=_fov, help="the camera's horizontal field of view, degrees (written to camera.toml for replay)"
    )


def _fov_option(parser) -> None:
    parser.add_argument(
        "--fov",
        type=_fov,
        help="a camera log's horizontal field of view, degrees (360: panoramic; default: [ratslam.view] "
        "field_of_view_deg in --config, else the log's camera.toml)",
    )


def _rosbag_image_options(rb, labels) -> None:
    """``import rosbag --image TOPIC [--camera-info TOPIC]``: an image log in place of the place
    labels."""
    labels.add_argument(
        "--image",
        help="camera topic (sensor_msgs/Image or CompressedImage): write an image log, each tick with the "
        "latest image, for replay's view matcher",
    )
    rb.add_argument(
        "--camera-info",
        help="sensor_msgs/CameraInfo topic for the field of view (default: the one in the image topic's namespace)",
    )


def _import_video_parser(isub) -> None:
    """``import video VIDEO --odometry ODOM --out LOG.csv``: a video's frames as an image log."""
    vd = isub.add_parser(
        "video",
        help="a video file and an odometry trajectory: an image log, each tick with the latest frame",
    )
    vd.add_argument("video", help="video file (any container and codec FFmpeg reads; needs the [video] extra)")
    vd.add_argument(
        "--odometry", required=True, help="odometry: TUM trajectory or observation log CSV (its scene numbers dropped)"
    )
    vd.add_argument("--out", required=True, help="image log to write (CSV; its images go in <stem>_images/)")
    vd.add_argument("--gt", help="ground-truth trajectory (TUM) for a TUM odometry, interpolated at its ticks")
    when = vd.add_mutually_exclusive_group()
    when.add_argument("--fps", type=_positive, help="frame k at the odometry's first pose time + k / FPS")
    when.add_argument(
        "--timestamps", help="one time per frame (s, the odometry's clock), one a line (default: the video's own)"
    )
    _import_fov_option(vd)
    vd.set_defaults(func=_cmd_import_video)


def _print_image_import(out: Path, result) -> None:
    log = result.log
    print(
        f"wrote {out} ({len(log)} ticks, {result.images} images of {result.shape[1]} x {result.shape[0]} in "
        f"{out.stem}_images/{', ground truth' if log.has_ground_truth else ''}; oldest image paired "
        f"{result.max_age_s:.3f} s before its tick)"
    )
    if result.dropped or result.dropped_at_end:
        print(
            f"  {result.dropped} ticks before the first image and {result.dropped_at_end} after the last were dropped"
        )
    if result.fov_deg is not None:
        from worlds.image_log import CAMERA_FILE

        print(f"  field of view {result.fov_deg:.2f} deg ({result.fov_note}) in {out.stem}_images/{CAMERA_FILE}")
    else:
        print(f"  field of view unknown ({result.fov_note}): give it to replay with --fov DEG")


def _cmd_import_bag_images(args) -> None:
    from worlds.bag_images import import_bag_images

    out = check_writable(args.out, inputs=(args.bag,))
    result = import_bag_images(
        args.bag,
        args.odom,
        args.image,
        out,
        ground_truth_topic=args.gt,
        camera_info_topic=args.camera_info,
        twist=args.twist,
    )
    _print_image_import(out, result)


def _cmd_import_video(args) -> None:
    from worlds.video_import import import_video

    out = check_writable(args.out, inputs=(args.video, args.odometry, args.gt, args.timestamps))
    result = import_video(
        args.video, args.odometry, out, fps=args.fps, timestamps=args.timestamps, ground_truth=args.gt, fov_deg=args.fov
    )
    _print_image_import(out, result)


def _cmd_report(args) -> None:
    with output_errors(args.dir):
        _report(args)


def _report(args) -> None:
    if (Path(args.dir) / "runs.csv").is_file():
        from ..sweeps.report import rebuild_sweep_report

        print(f"wrote {rebuild_sweep_report(args.dir)}")
        return
    from ..navigation.experiment import is_nav_run, rebuild_nav_report
    from ..report.run_report import write_report

    print(f"wrote {rebuild_nav_report(args.dir) if is_nav_run(args.dir) else write_report(args.dir)}")


def _cmd_sweep(args) -> None:
    from ..sweeps.run import run_sweep
    from ..sweeps.spec import check_sweep_size, read_sweep_spec

    spec = read_sweep_spec(args.spec)
    n = spec.run_count()  # counted, not expanded: a spec of a billion runs fails at once
    if n > spec.max_runs and not args.yes:
        raise CliError(
            f"{args.spec}: max_runs: the spec expands to {n:,} runs, more than {spec.max_runs:,}; "
            "pass --yes to run them all"
        )
    check_sweep_size(spec, args.yes)
    try:
        out = run_sweep(spec, args.out, workers=args.workers, scheduler=args.scheduler)
    except KeyboardInterrupt:
        runs = Path(args.out) / "runs"
        kept = sum(1 for _ in runs.glob("*/result.json")) if runs.is_dir() else 0
        where = f"the {kept} completed runs are kept in {runs}" if kept else "no run had completed"
        print(f"ratslam-harness: interrupted; {where}: rerun the same command to finish the sweep", file=sys.stderr)
        raise SystemExit(130) from None
    print(f"sweep directory: {out}\n  runs:   {out / 'runs.csv'}\n  report: {out / 'report.md'}")


def _cmd_nav(args) -> None:
    from worlds.files import read_json

    from ..navigation.experiment import run_nav_experiment
    from ..run.budget import check_goals, check_ticks

    world = load_world(args.world)
    check_goals("--goals", args.goals, args.yes)
    if args.exploration is not None:
        check_ticks(f"--exploration {args.exploration:g}", args.exploration * world.tick_rate, args.yes)
    out = run_nav_experiment(
        args.world,
        out=args.out,
        seed=args.seed,
        n_goals=args.goals,
        exploration_s=args.exploration,
        recording=not args.no_recording,
        show_progress=not args.quiet,
        lookalikes=not args.no_lookalikes,
        ratslam_localise=not args.stepping,
    )
    m = read_json(out / "metrics.json")
    for name, s in m["summary"].items():
        ratio = s["median_time_ratio"]
        print(
            f"  {name}: {s['reached']}/{s['goals']} goals reached, median time ratio "
            f"{'n/a' if ratio is None else f'{ratio:.2f}'}, {s['replans_total']} replans"
        )
    for c in m["claims"]:
        print(f"  [{'held' if c['held'] else 'NOT held'}] {c['statement']}")
    print(f"run directory: {out}\n  report:    {out / 'report.md'}\n  map:       {out / 'ratslam_map.npz'}")
    if (out / "recording.rrd").exists():
        print(f"  recording: {out / 'recording.rrd'}  (open it with: rerun {out / 'recording.rrd'})")


def _print_run_summary(out: Path) -> None:
    from ..report.results import RunResult

    run = RunResult.from_json(out / "metrics.json")
    published = {c.key: c for c in (run.published.claims or [])} if run.published is not None else {}
    for c in run.claims or []:
        print(f"  [{'held' if c.held else 'NOT held'}] {c.statement} -- {c.measured}")
        if c.key in published:
            p = published[c.key]
            print(f"      as published: [{'held' if p.held else 'NOT held'}] {p.measured}")
    print(f"run directory: {out}")
    print(f"  report:    {out / 'report.md'}")
    rrd = out / "recording.rrd"
    if rrd.exists():
        print(f"  recording: {rrd}  (open it with: rerun {rrd})")


def _workers(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text!r}")
    return v


def _seed(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if not 0 <= v < 2**63:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer below 2**63, got {text!r}")
    return v


def _positive(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not v > 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return v


def _finite(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if v != v or v in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return v


def _rate(text: str) -> float:
    v = _finite(text)
    if not 0.0 <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"must be a rate in [0, 1], got {text!r}")
    return v


class _OneLineParser(argparse.ArgumentParser):
    """argparse, but usage errors are one line on stderr like every other error."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def _label_options(parser, labels_help: str):
    """Place labels given (``--labels``) or synthesised from the ground truth, and their options;
    the group of the label sources (one of them required)."""
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--labels", help=labels_help)
    group.add_argument(
        "--synthesise",
        action="store_true",
        help="scene numbers from the ground truth by the scene model (2 m cells, 4 sectors)",
    )
    parser.add_argument(
        "--label-max-age", type=_positive, help="a label holds for this long, s (default: two median tick lengths)"
    )
    parser.add_argument("--seed", type=_seed, default=0, help="seed of synthesised flicker and false positives")
    return group


def _yes_option(parser) -> None:
    parser.add_argument(
        "--yes",
        action="store_true",
        help="run even beyond the size budget (pose-cell grid, stream length, goals; see harness.run.budget)",
    )


def build_parser() -> argparse.ArgumentParser:
    p = _OneLineParser(
        prog="ratslam-harness", description="RatSLAM experience mapping beside a GTSAM pose graph, on simulated worlds."
    )
    sub = p.add_subparsers(dest="command", required=True, parser_class=_OneLineParser)

    sub.add_parser("list", help="list shipped worlds").set_defaults(func=_cmd_list)

    s = sub.add_parser("simulate", help="simulate a world and write an observation log (CSV) and a PNG")
    s.add_argument("world", help="a shipped world's name or a world .toml file")
    s.add_argument("--out", required=True, help="observation log to write (CSV)")
    s.add_argument("--png", help="PNG of the run (default: next to the log)")
    s.add_argument("--duration", type=_positive, help="simulated seconds (default: the world's)")
    s.add_argument("--seed", type=_seed, default=0, help="random seed (default 0)")
    s.add_argument("--bias", type=_finite, help="odometric yaw bias, deg/s (default: the world's)")
    s.add_argument("--fp", type=_rate, help="false-positive scene rate per tick (default: the world's)")
    s.add_argument(
        "--camera",
        choices=("forward", "panoramic"),
        help="write a camera log: each tick's rendered image (PNG, next to the log) instead of its scene number",
    )
    s.add_argument("--quiet", action="store_true", help="no progress output")
    _yes_option(s)
    s.set_defaults(func=_cmd_simulate)

    r = sub.add_parser("run", help="run a paper figure end to end (simulate, both systems, report)")
    r.add_argument("figure", help="figure name (see `list`)")
    r.add_argument(
        "--out", help="run directory (default: runs/FIGURE; --out reports/FIGURE regenerates the committed report)"
    )
    r.add_argument("--seed", type=_seed, help="random seed (default: the figure's)")
    r.add_argument("--duration", type=_positive, help="simulated seconds (default: the figure's)")
    r.add_argument(
        "--config",
        help="TOML file with [ratslam] and [gtsam] tables of config fields, "
        "applied on top of each variant's configuration",
    )
    r.add_argument(
        "--camera",
        choices=("forward", "panoramic"),
        help="both systems see the simulated camera through the view matcher instead of scene numbers "
        "(default out: reports/FIGURE_CAMERA)",
    )
    r.add_argument("--no-recording", action="store_true", help="skip the Rerun recording")
    r.add_argument(
        "--workers",
        type=_workers,
        help="processes for the figure's variants "
        "(default: one per variant, at most one per core; 1 = sequential, same output)",
    )
    _ratslam_option(r, "both")
    r.add_argument("--quiet", action="store_true", help="no progress output")
    _yes_option(r)
    r.set_defaults(func=_cmd_run)

    rp = sub.add_parser("replay", help="replay an observation log (CSV) through both systems")
    rp.add_argument(
        "log",
        help="observation log: t,dt,v_trans,v_rot,scene_id (or image)[,gt_x,gt_y,gt_theta,false_positive]",
    )
    rp.add_argument("--out", required=True, help="run directory to write")
    rp.add_argument(
        "--config",
        help="TOML file with [ratslam] and [gtsam] tables of config fields (a run's own config.toml reproduces it)",
    )
    rp.add_argument("--no-recording", action="store_true", help="skip the Rerun recording")
    _ratslam_option(rp, "defaults")
    _fov_option(rp)
    rp.add_argument("--quiet", action="store_true", help="no progress output")
    _yes_option(rp)
    rp.set_defaults(func=_cmd_replay)

    imp = sub.add_parser("import", help="write an observation log (CSV) from recorded robot data")
    isub = imp.add_subparsers(dest="source", required=True, parser_class=_OneLineParser)
    pz = isub.add_parser(
        "plaza",
        help="a CMU Plaza data set shipped with gtsam: real wheel odometry, "
        "scene numbers synthesised from its ground truth",
    )
    pz.add_argument("name", choices=("plaza1", "plaza2"), help="data set")
    pz.add_argument("--out", required=True, help="observation log to write (CSV)")
    pz.add_argument("--seed", type=_seed, default=0, help="seed of flicker and false positives (default 0)")
    pz.add_argument("--fp", type=_rate, help="false-positive scene rate per tick (default 0.002)")
    pz.add_argument("--duration", type=_positive, help="keep only the first S seconds")
    pz.set_defaults(func=_cmd_import_plaza)

    tm = isub.add_parser(
        "tum",
        help="TUM trajectories (t x y z qx qy qz qw): odometry, optional ground "
        "truth, and place labels (t,scene_id CSV) or synthesised scene numbers",
    )
    tm.add_argument("odometry", help="odometry trajectory (TUM)")
    tm.add_argument("--out", required=True, help="observation log to write (CSV)")
    tm.add_argument("--gt", help="ground-truth trajectory (TUM), interpolated at the odometry's times")
    _label_options(tm, "place labels: CSV with header t,scene_id, in time order")
    tm.set_defaults(func=_cmd_import_tum)

    rb = isub.add_parser(
        "rosbag",
        help="a ROS 1 or ROS 2 bag: nav_msgs/Odometry, optional ground truth, and "
        "an integer place-label topic or synthesised scene numbers",
    )
    rb.add_argument("bag", help="bag file (ROS 1) or bag directory (ROS 2)")
    rb.add_argument("--odom", required=True, help="odometry topic (nav_msgs/Odometry)")
    rb.add_argument("--out", required=True, help="observation log to write (CSV)")
    rb.add_argument("--gt", help="ground-truth topic (nav_msgs/Odometry or geometry_msgs/PoseStamped)")
    rb.add_argument("--twist", action="store_true", help="odometry from the messages' twist, not pose differences")
    labels = _label_options(rb, "place-label topic (std_msgs integer, field data)")
    rb.set_defaults(func=_cmd_import_rosbag)
    _rosbag_image_options(rb, labels)
    _import_images_parser(isub)
    _import_video_parser(isub)

    sw = sub.add_parser(
        "sweep",
        help="a robustness study: conditions x seeds x system configurations "
        "(resumable: rerun the same command to finish a killed sweep)",
    )
    sw.add_argument("spec", help="sweep spec (TOML; see sweeps/ for examples)")
    sw.add_argument("--out", required=True, help="sweep directory (runs/, runs.csv, report.md)")
    sw.add_argument("--workers", type=_workers, help="local worker processes (default: one per core)")
    sw.add_argument("--scheduler", help="run on a Dask distributed cluster at this address (tcp://HOST:8786)")
    sw.add_argument(
        "--yes",
        action="store_true",
        help="run even if the spec expands to more than max_runs, or its runs exceed the size budget",
    )
    sw.set_defaults(func=_cmd_sweep)

    nv = sub.add_parser(
        "nav",
        help="goal navigation: explore a world, then drive to goals on RatSLAM's experience map "
        "and on GTSAM's pose graph (success rate, time ratio)",
    )
    nv.add_argument("world", help="a shipped world's name or a world .toml file")
    nv.add_argument("--seed", type=_seed, default=0, help="seed of the exploration and the goals (default 0)")
    nv.add_argument("--goals", type=int, default=50, help="goals driven to on each map (default 50)")
    nv.add_argument("--exploration", type=float, help="exploration, simulated seconds (default: the world's)")
    nv.add_argument("--out", help="run directory (default: runs/nav_WORLD)")
    nv.add_argument("--no-recording", action="store_true", help="skip the Rerun recording")
    mode = nv.add_mutually_exclusive_group()
    mode.add_argument(
        "--localise",
        dest="stepping",
        action="store_false",
        default=False,
        help="navigate RatSLAM's explored map, fixed, by localising on it (ratslam.localisation: a Kalman filter "
        "on the odometry and scene sightings, relocalisation, the way back when lost); the default",
    )
    mode.add_argument(
        "--stepping",
        action="store_true",
        default=False,
        help="navigate with RatSLAM stepping on (pose cells, view cells, experience map: its own pose and a map "
        "that goes on changing) instead",
    )
    nv.add_argument(
        "--no-lookalikes",
        action="store_true",
        help="the world's look-alike regions show their own scenes (as Fig 4's distinct_rooms variant)",
    )
    nv.add_argument("--quiet", action="store_true", help="no progress output")
    _yes_option(nv)
    nv.set_defaults(func=_cmd_nav)

    rep = sub.add_parser("report", help="rebuild report.md and the PNG panels of a run or sweep directory")
    rep.add_argument("dir", help="run directory, or sweep directory (rebuilt from its runs.csv)")
    rep.set_defaults(func=_cmd_report)
    return p


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    # a terminated run cleans up its staging directory as Ctrl-C does
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        args.func(args)
    except KeyboardInterrupt:
        print("ratslam-harness: interrupted; nothing was written", file=sys.stderr)
        return 130
    except InputError as e:  # every user-facing error; anything else is a bug and shows its traceback
        print(f"ratslam-harness: error: {e}", file=sys.stderr)
        return 2
    return 0
