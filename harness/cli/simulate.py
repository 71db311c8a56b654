"""``ratslam-harness simulate WORLD --out LOG.csv``: a world simulated into an observation log and a PNG."""

from __future__ import annotations

from .common import finite, positive, rate, seed, yes_option


def add_parser(sub) -> None:
    s = sub.add_parser("simulate", help="simulate a world and write an observation log (CSV) and a PNG")
    s.add_argument("world", help="a shipped world's name or a world .toml file")
    s.add_argument("--out", required=True, help="observation log to write (CSV)")
    s.add_argument("--png", help="PNG of the run (default: next to the log)")
    s.add_argument("--duration", type=positive, help="simulated seconds (default: the world's)")
    s.add_argument("--seed", type=seed, default=0, help="random seed (default 0)")
    s.add_argument("--bias", type=finite, help="odometric yaw bias, deg/s (default: the world's)")
    s.add_argument("--fp", type=rate, help="false-positive scene rate per tick (default: the world's)")
    s.add_argument(
        "--camera",
        choices=("forward", "panoramic"),
        help="write a camera log: each tick's rendered image (PNG, next to the log) instead of its scene number",
    )
    s.add_argument("--quiet", action="store_true", help="no progress output")
    yes_option(s)
    s.set_defaults(func=command)


def command(args) -> None:
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
