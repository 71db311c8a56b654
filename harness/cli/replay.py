"""``ratslam-harness replay LOG --out DIR``: an observation log (scene numbers or images) through both
systems."""

from __future__ import annotations

from .common import fov, print_run_summary, ratslam_choice, ratslam_option, recording, yes_option


def add_parser(sub) -> None:
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
    ratslam_option(rp, "defaults")
    rp.add_argument(
        "--fov",
        type=fov,
        help="a camera log's horizontal field of view, degrees (360: panoramic; default: [ratslam.view] "
        "field_of_view_deg in --config, else the log's camera.toml)",
    )
    rp.add_argument("--quiet", action="store_true", help="no progress output")
    yes_option(rp)
    rp.set_defaults(func=command)


def command(args) -> None:
    from ..figures.run import replay
    from ..run.config_file import read_config_file

    config = read_config_file(args.config) if args.config else None
    out = replay(
        args.log,
        args.out,
        show_progress=not args.quiet,
        recorder_factory=recording(args.no_recording),
        config=config,
        ratslam=ratslam_choice(args.ratslam, config, "defaults"),
        yes=args.yes,
        fov_deg=args.fov,
    )
    print_run_summary(out)
