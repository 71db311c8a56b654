"""``ratslam-harness import SOURCE``: an observation log (CSV) from recorded robot data: a CMU Plaza
data set, TUM trajectories, a ROS bag, an image folder or a video."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from worlds import InputError

from ..record.log_output import check_writable
from ..run.directory import output_errors
from .common import OneLineParser, fov, positive, rate, seed


def add_parser(sub) -> None:
    imp = sub.add_parser("import", help="write an observation log (CSV) from recorded robot data")
    isub = imp.add_subparsers(dest="source", required=True, parser_class=OneLineParser)
    _plaza_parser(isub)
    _tum_parser(isub)
    _rosbag_parser(isub)
    _images_parser(isub)
    _video_parser(isub)


# ---------------------------------------------------------------------------- parsers


def _plaza_parser(isub) -> None:
    pz = isub.add_parser(
        "plaza",
        help="a CMU Plaza data set shipped with gtsam: real wheel odometry, "
        "scene numbers synthesised from its ground truth",
    )
    pz.add_argument("name", choices=("plaza1", "plaza2"), help="data set")
    pz.add_argument("--out", required=True, help="observation log to write (CSV)")
    pz.add_argument("--seed", type=seed, default=0, help="seed of flicker and false positives (default 0)")
    pz.add_argument("--fp", type=rate, help="false-positive scene rate per tick (default 0.002)")
    pz.add_argument("--duration", type=positive, help="keep only the first S seconds")
    pz.set_defaults(func=_plaza)


def _tum_parser(isub) -> None:
    tm = isub.add_parser(
        "tum",
        help="TUM trajectories (t x y z qx qy qz qw): odometry, optional ground "
        "truth, and place labels (t,scene_id CSV) or synthesised scene numbers",
    )
    tm.add_argument("odometry", help="odometry trajectory (TUM)")
    tm.add_argument("--out", required=True, help="observation log to write (CSV)")
    tm.add_argument("--gt", help="ground-truth trajectory (TUM), interpolated at the odometry's times")
    _label_options(tm, "place labels: CSV with header t,scene_id, in time order")
    tm.set_defaults(func=_tum)


def _rosbag_parser(isub) -> None:
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
    rb.set_defaults(func=_rosbag)
    # ``--image TOPIC [--camera-info TOPIC]``: an image log in place of the place labels
    labels.add_argument(
        "--image",
        help="camera topic (sensor_msgs/Image or CompressedImage): write an image log, each tick with the "
        "latest image, for replay's view matcher",
    )
    rb.add_argument(
        "--camera-info",
        help="sensor_msgs/CameraInfo topic for the field of view (default: the one in the image topic's namespace)",
    )


def _images_parser(isub) -> None:
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
        "--rate", type=positive, help="the names carry frame numbers taken at this rate (Hz) from the odometry's start"
    )
    im.add_argument(
        "--time-unit", choices=("s", "ms", "us", "ns"), default="s", help="unit of the names' time stamps (default s)"
    )
    _fov_option(im)
    im.set_defaults(func=_images)


def _video_parser(isub) -> None:
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
    when.add_argument("--fps", type=positive, help="frame k at the odometry's first pose time + k / FPS")
    when.add_argument(
        "--timestamps", help="one time per frame (s, the odometry's clock), one a line (default: the video's own)"
    )
    _fov_option(vd)
    vd.set_defaults(func=_video)


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
        "--label-max-age", type=positive, help="a label holds for this long, s (default: two median tick lengths)"
    )
    parser.add_argument("--seed", type=seed, default=0, help="seed of synthesised flicker and false positives")
    return group


def _fov_option(parser) -> None:
    parser.add_argument(
        "--fov", type=fov, help="the camera's horizontal field of view, degrees (written to camera.toml for replay)"
    )


# ---------------------------------------------------------------------------- commands


def _plaza(args) -> None:
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


def _tum(args) -> None:
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


def _rosbag(args) -> None:
    if args.image is not None:
        _bag_images(args)
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


def _write_imported(log, out: Path) -> None:
    with output_errors(out):
        log.write_csv(out)
    seen = int((log.scene_id >= 0).sum())
    print(
        f"wrote {out} ({len(log)} ticks, {seen} with a scene number{', ground truth' if log.has_ground_truth else ''})"
    )


def _images(args) -> None:
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


def _bag_images(args) -> None:
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


def _video(args) -> None:
    from worlds.video_import import import_video

    out = check_writable(args.out, inputs=(args.video, args.odometry, args.gt, args.timestamps))
    result = import_video(
        args.video, args.odometry, out, fps=args.fps, timestamps=args.timestamps, ground_truth=args.gt, fov_deg=args.fov
    )
    _print_image_import(out, result)


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
