"""The run directory: staged writes and provenance.

A run is written into a hidden staging directory next to its destination and moved into place
only when complete, so an interrupted run never leaves a half-written report behind. The files
themselves are written elsewhere, through :mod:`worlds.files`: ``metrics.json``, the TUM
trajectories and ``maps.npz`` by :mod:`harness.figure_run`, ``config.toml`` by
:mod:`harness.config_file`, ``report.md`` and the panels by :mod:`harness.report`;
``recording.rrd`` is streamed by :mod:`harness.recorder` (rerun writes it under its own
temporary name).
"""

from __future__ import annotations

import os
import platform
import shutil
import subprocess
import sys
from contextlib import contextmanager
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path

from worlds.errors import InputError

PACKAGES = ("ratslam-harness", "numpy", "scipy", "gtsam", "rerun-sdk", "pymunk", "matplotlib")


class OutputError(InputError):
    """The output location cannot be used (one line: path and problem)."""


@contextmanager
def staged_directory(final: Path):
    """Yield a fresh staging directory; on success it replaces ``final`` atomically-ish.

    On any exception (including Ctrl-C) the staging directory is removed and ``final`` is
    left as it was.
    """
    final = Path(final)
    parent = final.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"{final}: cannot create the output's parent directory ({e.strerror})") from None
    if final.exists() and not final.is_dir():
        raise OutputError(f"{final}: exists and is not a directory")
    if not os.access(parent, os.W_OK):
        raise OutputError(f"{final}: output location is not writable")
    stage = parent / f".{final.name}.partial-{os.getpid()}"
    shutil.rmtree(stage, ignore_errors=True)
    stage.mkdir()
    try:
        yield stage
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    old = parent / f".{final.name}.old-{os.getpid()}"
    if final.exists():
        os.replace(final, old)
    os.replace(stage, final)
    shutil.rmtree(old, ignore_errors=True)


def git_commit() -> str:
    """The commit of the source tree this package runs from, or 'unknown'."""
    here = Path(__file__).resolve().parent
    try:
        out = subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=5)
        if out.returncode == 0:
            dirty = subprocess.run(
                ["git", "-C", str(here), "status", "--porcelain", "--untracked-files=no"],
                capture_output=True,
                text=True,
                timeout=5,
            ).stdout.strip()
            return out.stdout.strip() + ("-dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        pass
    return "unknown"


def provenance(**extra) -> dict:
    """Who made this run and with what: package versions, commit, platform, command line."""
    versions: dict[str, str | None] = {}
    for p in PACKAGES:
        try:
            versions[p] = metadata.version(p)
        except metadata.PackageNotFoundError:
            versions[p] = None
    return {
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
        "git_commit": git_commit(),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "command": " ".join(sys.argv),
        "packages": versions,
        **extra,
    }
