"""The run directory: staged writes and provenance.

A run is written into a hidden staging directory next to its destination and moved into place
only when complete, so an interrupted run never leaves a half-written report behind. The files
themselves are written elsewhere, through :mod:`worlds.files`: ``metrics.json``, the TUM
trajectories and ``maps.npz`` by :mod:`harness.figures.run`, ``config.toml`` by
:mod:`harness.run.config_file`, ``report.md`` and the panels by :mod:`harness.report.run_report`;
``recording.rrd`` by :mod:`harness.record.recorder` (under its own temporary name). The staged run
lists what it wrote in ``manifest.txt``: a run directory is replaced only if it holds nothing
else (:func:`staged_directory`).
"""

from __future__ import annotations

import errno
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


MANIFEST = "manifest.txt"
"""Every run directory (figure, replay, navigation) lists the files its run wrote in this file
(report rebuilds and screenshots add theirs): an existing directory is replaced only if it is
empty or holds nothing but the files its manifest lists, never a folder or a file of the user's."""

WRITE_ERRNOS = frozenset(
    getattr(errno, name)
    for name in ("ENOSPC", "EDQUOT", "EROFS", "EACCES", "EPERM", "EFBIG", "ENOTDIR", "EISDIR", "EIO", "ENAMETOOLONG")
    if hasattr(errno, name)
)
"""``OSError`` numbers that mean the output location cannot take the output (read-only, full,
not a directory, no permission): reported as one line (:func:`output_errors`), not a traceback."""


@contextmanager
def output_errors(where):
    """Turn an ``OSError`` of :data:`WRITE_ERRNOS` raised inside the block into a one-line
    :class:`OutputError` naming ``where`` (the output) and the problem."""
    try:
        yield
    except OSError as e:
        if e.errno not in WRITE_ERRNOS:
            raise
        name = f" ({e.filename})" if e.filename and str(e.filename) != str(where) else ""
        raise OutputError(f"{where}: cannot be written: {e.strerror or e}{name}") from None


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` exists (on this machine)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale(parent: Path, pattern: str) -> list[Path]:
    """Remove the staging leftovers ``parent/pattern`` (names ending ``-PID``, ``.partial-PID``
    or ``.old-PID``) whose process is dead: what a killed run left behind. Returns them."""
    removed = []
    for p in Path(parent).glob(pattern):
        tail = p.name.rsplit("-", 1)[-1]
        if tail.isdigit() and int(tail) != os.getpid() and not pid_alive(int(tail)):
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p, ignore_errors=True)
            else:
                p.unlink(missing_ok=True)
            removed.append(p)
    return removed


def _files(root: Path) -> list[str]:
    """Every file under ``root`` (recursive, symlinks as files), as sorted POSIX paths relative to it."""
    out = []
    for dirpath, dirnames, filenames in os.walk(root):
        for name in filenames + [d for d in dirnames if os.path.islink(os.path.join(dirpath, d))]:
            out.append(Path(dirpath, name).relative_to(root).as_posix())
    return sorted(out)


def _leftover(name: str) -> bool:
    """A temporary file of this program's own atomic writers (``worlds.files``, the recorder)."""
    base = name.rsplit("/", 1)[-1]
    return base.startswith(".") and (".tmp" in base or ".partial-" in base)


def read_manifest(run_dir) -> set[str] | None:
    """The files a run directory's manifest lists, or None if it has none."""
    path = Path(run_dir) / MANIFEST
    if not path.is_file():
        return None
    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError):
        return None
    return {ln for ln in lines if ln and not ln.startswith("#")}


def write_manifest(run_dir, files) -> Path:
    """Write ``run_dir``'s manifest listing ``files`` (paths relative to it)."""
    from worlds.files import atomic_write_text

    body = "".join(f"{f}\n" for f in sorted(set(files) - {MANIFEST}))
    return atomic_write_text(
        Path(run_dir) / MANIFEST,
        "# The files ratslam-harness wrote into this run directory. A later run replaces the directory\n"
        "# only if it holds nothing else; keep your own files elsewhere.\n" + body,
    )


def add_to_manifest(run_dir, paths) -> None:
    """Add ``paths`` (files written into ``run_dir`` after its run: a rebuilt report, a
    screenshot) to its manifest; nothing if the directory has none (e.g. a run being staged)."""
    run_dir = Path(run_dir)
    listed = read_manifest(run_dir)
    if listed is None:
        return
    root = Path(os.path.realpath(run_dir))
    new = set()
    for p in paths:
        real = Path(os.path.realpath(p))
        if real.is_relative_to(root):
            new.add(real.relative_to(root).as_posix())
    if not new <= listed:
        write_manifest(run_dir, listed | new)


@contextmanager
def staged_directory(final: Path, inputs: tuple[Path, ...] = ()):
    """Yield a fresh staging directory; on success it replaces ``final`` atomically-ish.

    An existing ``final`` must be empty or an earlier run directory holding nothing but the files
    its manifest (:data:`MANIFEST`) lists, and must not contain any of ``inputs`` (the files the
    run reads): otherwise nothing is written and :class:`OutputError` says why. The staging
    directory gets a manifest of what the run wrote before it moves into place. Staging
    directories left by killed runs (their process dead) are removed first. On any exception
    (including Ctrl-C) the staging directory is removed and ``final`` is left as it was; a
    destination that cannot take the run (read-only, full, not a directory) is one line.
    """
    final = Path(os.path.abspath(final))  # "." or "dir/.." name the directory itself
    parent = final.parent
    if final == parent:
        raise OutputError(f"{final}: cannot write a run over the file system's root")
    for p in (parent, *parent.parents):
        if p.exists():
            if not p.is_dir():
                raise OutputError(f"{final}: {p} is a file, not a directory")
            break
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OutputError(f"{final}: cannot create the output's parent directory ({e.strerror})") from None
    _check_replaceable(final, inputs)
    if not os.access(parent, os.W_OK):
        raise OutputError(f"{final}: output location is not writable")
    remove_stale(parent, f".{final.name}.partial-*")
    remove_stale(parent, f".{final.name}.old-*")
    stage = parent / f".{final.name}.partial-{os.getpid()}"
    shutil.rmtree(stage, ignore_errors=True)
    with output_errors(final):
        stage.mkdir()
    try:
        with output_errors(final):
            yield stage
            write_manifest(stage, _files(stage))
            old = parent / f".{final.name}.old-{os.getpid()}"
            if final.exists():
                os.replace(final, old)
            try:
                os.replace(stage, final)
            except BaseException:
                if old.exists() and not final.exists():
                    os.replace(old, final)
                raise
        shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise


def _check_replaceable(final: Path, inputs: tuple[Path, ...]) -> None:
    """Refuse an output that would delete something the run did not write (module doc)."""
    if not final.exists() and not final.is_symlink():
        return
    if not final.is_dir() or final.is_symlink():
        raise OutputError(f"{final}: exists and is not a directory (choose another --out)")
    for f in inputs:
        if Path(os.path.realpath(f)).is_relative_to(os.path.realpath(final)):
            raise OutputError(f"{final}: holds the input {f}; the run would replace it (choose another --out)")
    files = [f for f in _files(final) if f != MANIFEST and not _leftover(f)]
    listed = read_manifest(final)
    if listed is None:
        if files:
            raise OutputError(
                f"{final}: exists and holds {files[0]} (no {MANIFEST}: not a run directory of this program); "
                "choose another --out or remove it"
            )
        return
    unlisted = [f for f in files if f not in listed]
    if unlisted:
        raise OutputError(
            f"{final}: holds {unlisted[0]}, which its run did not write (not in its {MANIFEST}); "
            "choose another --out or move the file"
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
