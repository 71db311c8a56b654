"""``ratslam-harness``: the command-line entry point, a thin layer over the library with one module
per command (``list``, ``simulate``, ``run``, ``replay``, ``import``, ``sweep``, ``nav``, ``report``);
each adds its parser (``add_parser``) and does its command.

Every user-facing error derives from :class:`worlds.errors.InputError` and is printed as one
line on stderr with exit status 2; any other exception is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import signal
import sys

from worlds import InputError

from ..run.workers import interrupt, quiet_dropped_interrupt
from . import imports, listing, nav, replay, report, run, simulate, sweep
from .common import CliError, OneLineParser

__all__ = ["COMMANDS", "CliError", "build_parser", "main"]

COMMANDS = (listing, simulate, run, replay, imports, sweep, nav, report)  # in the order ``--help`` lists them


def build_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog="ratslam-harness", description="RatSLAM experience mapping beside a GTSAM pose graph, on simulated worlds."
    )
    sub = p.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    for command in COMMANDS:
        command.add_parser(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    # a terminated run cleans up its staging directory as Ctrl-C does; both are remembered, so one
    # dropped where it landed (numba compiling) is raised again at the next safe point
    signal.signal(signal.SIGTERM, interrupt)
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, interrupt)
    sys.unraisablehook = quiet_dropped_interrupt
    try:
        args.func(args)
    except KeyboardInterrupt:
        print("ratslam-harness: interrupted; nothing was written", file=sys.stderr)
        return 130
    except InputError as e:  # every user-facing error; anything else is a bug and shows its traceback
        print(f"ratslam-harness: error: {e}", file=sys.stderr)
        return 2
    return 0
