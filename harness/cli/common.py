"""What several commands share: the one-line usage errors, argument types, common options, and the
summary printed after a run or replay."""

from __future__ import annotations

import argparse
import typing
from pathlib import Path

from worlds import InputError

if typing.TYPE_CHECKING:
    from ..figures.stream_run import RatSLAMChoice


class CliError(InputError):
    """A command-line usage error: printed as one line on stderr, exit status 2 (as every
    :class:`~worlds.errors.InputError` is)."""


class OneLineParser(argparse.ArgumentParser):
    """argparse, but usage errors are one line on stderr like every other error."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def recording(no_recording: bool):
    """The recorder factory of a run (None with ``--no-recording``): Rerun's SDK is loaded when the
    first recording starts, after the command's input has been checked."""
    return None if no_recording else _record_to_rrd


def _record_to_rrd(*args, **kwargs):
    """:func:`harness.record.recorder.recorder_factory`, imported on first use."""
    from ..record.recorder import recorder_factory

    return recorder_factory(*args, **kwargs)


# ---------------------------------------------------------------------------- argument types


def _number(text: str, convert, noun: str):
    try:
        return convert(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not {noun}: {text!r}") from None


def workers(text: str) -> int:
    v = _number(text, int, "an integer")
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text!r}")
    return v


def seed(text: str) -> int:
    v = _number(text, int, "an integer")
    if not 0 <= v < 2**63:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer below 2**63, got {text!r}")
    return v


def positive(text: str) -> float:
    v = _number(text, float, "a number")
    if not v > 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return v


def finite(text: str) -> float:
    v = _number(text, float, "a number")
    if v != v or v in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return v


def rate(text: str) -> float:
    v = finite(text)
    if not 0.0 <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"must be a rate in [0, 1], got {text!r}")
    return v


def fov(text: str) -> float:
    v = positive(text)
    if v > 360.0:
        raise argparse.ArgumentTypeError(f"must be at most 360 degrees, got {text!r}")
    return v


# ---------------------------------------------------------------------------- options


def yes_option(parser) -> None:
    parser.add_argument(
        "--yes",
        action="store_true",
        help="run even beyond the size budget (pose-cell grid, stream length, goals; see harness.run.budget)",
    )


def ratslam_option(parser, default: str) -> None:
    parser.add_argument(
        "--ratslam",
        choices=("defaults", "published", "both"),
        help="RatSLAM's configuration: the project's defaults, the paper's published algorithm "
        f"(RatSLAMConfig.published()), or both on the same stream (default: {default}; a --config "
        "file with a preset: that file's configuration)",
    )


def ratslam_choice(given: str | None, config, default: RatSLAMChoice) -> RatSLAMChoice:
    """``--ratslam``: as given; else the configuration file's own when it names a preset (its
    fields go on top of the preset, run alone), else ``default``."""
    if given is not None:
        return typing.cast("RatSLAMChoice", given)
    return "defaults" if config is not None and config.preset is not None else default


# ---------------------------------------------------------------------------- output


def print_run_summary(out: Path) -> None:
    """The claims of a run directory (and RatSLAM as published beside them) and where its files are."""
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
