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


RUN_MARKER = "metrics.json"
"""Every run directory (figure, replay, navigation) holds this file: an existing directory is
replaced only if it is empty or holds it (an earlier run), never a folder of the user's."""


@contextmanager
def staged_directory(final: Path, inputs: tuple[Path, ...] = ()):
    """Yield a fresh staging directory; on success it replaces ``final`` atomically-ish.

    An existing ``final`` must be empty or an earlier run directory (it holds
    :data:`RUN_MARKER`), and must not contain any of ``inputs`` (the files the run reads):
    otherwise nothing is written and :class:`OutputError` says why. On any exception (including
    Ctrl-C) the staging directory is removed and ``final`` is left as it was.
    """
    final = Path(os.path.abspath(final))  # "." or "dir/.." name the directory itself
    parent = final.parent
    if final == parent:
        raise OutputError(f"{final}: cannot write a run over the file system's root")
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"{final}: cannot create the output's parent directory ({e.strerror})") from None
    _check_replaceable(final, inputs)
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


def _check_replaceable(final: Path, inputs: tuple[Path, ...]) -> None:
    """Refuse an output that would delete something the run did not write (module doc)."""
    if not final.exists():
        return
    if not final.is_dir():
        raise OutputError(f"{final}: exists and is not a directory")
    for f in inputs:
        if Path(os.path.realpath(f)).is_relative_to(os.path.realpath(final)):
            raise OutputError(f"{final}: holds the input {f}; the run would replace it (choose another --out)")
    if any(final.iterdir()) and not (final / RUN_MARKER).is_file():
        raise OutputError(
            f"{final}: exists, is not empty and is not an earlier run directory (no {RUN_MARKER}); "
            "choose another --out or remove it"
        )


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
