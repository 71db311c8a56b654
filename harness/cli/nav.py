"""``ratslam-harness nav WORLD``: goal navigation on RatSLAM's experience map and on GTSAM's pose graph."""

from __future__ import annotations

from worlds import load_world

from .common import seed, yes_option


def add_parser(sub) -> None:
    nv = sub.add_parser(
        "nav",
        help="goal navigation: explore a world, then drive to goals on RatSLAM's experience map "
        "and on GTSAM's pose graph (success rate, time ratio)",
    )
    nv.add_argument("world", help="a shipped world's name or a world .toml file")
    nv.add_argument("--seed", type=seed, default=0, help="seed of the exploration and the goals (default 0)")
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
    yes_option(nv)
    nv.set_defaults(func=command)


def command(args) -> None:
    from worlds.files import read_json

    from ..run.budget import check_goals, check_ticks

    world = load_world(args.world)
    check_goals("--goals", args.goals, args.yes)
    if args.exploration is not None:
        check_ticks(f"--exploration {args.exploration:g}", args.exploration * world.tick_rate, args.yes)
    from ..navigation.experiment import run_nav_experiment  # the systems, once the input is checked

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
