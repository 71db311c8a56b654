"""``ratslam-harness run FIGURE``: a paper figure end to end (simulate, both systems, report)."""

from __future__ import annotations

from worlds import load_world

from .common import positive, print_run_summary, ratslam_choice, ratslam_option, recording, seed, workers, yes_option


def add_parser(sub) -> None:
    r = sub.add_parser("run", help="run a paper figure end to end (simulate, both systems, report)")
    r.add_argument("figure", help="figure name (see `list`)")
    r.add_argument(
        "--out", help="run directory (default: runs/FIGURE; --out reports/FIGURE regenerates the committed report)"
    )
    r.add_argument("--seed", type=seed, help="random seed (default: the figure's)")
    r.add_argument("--duration", type=positive, help="simulated seconds (default: the figure's)")
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
        type=workers,
        help="processes for the figure's variants "
        "(default: one per variant, at most one per core; 1 = sequential, same output)",
    )
    ratslam_option(r, "both")
    r.add_argument("--quiet", action="store_true", help="no progress output")
    yes_option(r)
    r.set_defaults(func=command)


def command(args) -> None:
    from ..figures.registry import get_figure
    from ..run.config_file import read_config_file

    fig = get_figure(args.figure)  # unknown names fail before anything starts
    config = read_config_file(args.config) if args.config else None
    _check_figure_size(fig, config, args.duration, args.yes)
    from ..figures.run import run_figure  # the systems and the report, once the input is checked

    out = run_figure(
        args.figure,
        out=args.out,
        seed=args.seed,
        duration=args.duration,
        show_progress=not args.quiet,
        recorder_factory=recording(args.no_recording),
        workers=args.workers,
        config=config,
        ratslam=ratslam_choice(args.ratslam, config, "both"),
        camera=args.camera,
    )
    print_run_summary(out)


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
