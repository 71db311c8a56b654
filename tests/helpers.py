"""Helpers shared by the test modules: the simulator's tick, the default pose-cell grid,
wrap-aware differences, a settled packet, and the CLI run as a user runs it."""

from __future__ import annotations

import contextlib
import io
import signal
import subprocess
import sys
import warnings

import numpy as np

from ratslam import RatSLAMConfig
from ratslam.pose_cells import PoseCells

DT = 1.0 / 7.0  # s: the paper's (and the simulator's) 7 Hz tick
CFG = RatSLAMConfig()
GRID = np.array(CFG.shape, dtype=float)  # pose-cell grid (x', y', θ') of the defaults


def wrapped_diff(a, b, n=GRID) -> np.ndarray:
    """Signed wrap-aware difference a - b on rings of sizes n (cells)."""
    d = (np.asarray(a, float) - np.asarray(b, float)) % n
    return np.where(d > np.asarray(n) / 2, d - n, d)


def settled(cfg: RatSLAMConfig = CFG, cell=None, ticks: int = 30) -> PoseCells:
    """Pose cells started at ``cell`` (default: the grid's centre) and left to settle, no motion."""
    pc = PoseCells(cfg, start_cell=cell)
    for _ in range(ticks):
        pc.step(0.0, 0.0)
    return pc


def cli_process(*args: str, cwd=None) -> subprocess.CompletedProcess:
    """``ratslam-harness ARGS`` in a fresh interpreter (exit code, stdout and stderr as text)."""
    return subprocess.run([sys.executable, "-m", "harness.cli", *args], capture_output=True, text=True, cwd=cwd)


# Python's warning filters in a fresh interpreter (``python -m harness.cli``): deprecations are not shown
_FRESH_FILTERS = (
    ("ignore", DeprecationWarning),
    ("ignore", PendingDeprecationWarning),
    ("ignore", ImportWarning),
    ("ignore", ResourceWarning),
)


def cli(*args: str, cwd=None) -> subprocess.CompletedProcess:
    """``ratslam-harness ARGS`` as :func:`cli_process` runs it, in this interpreter: the command
    line's ``main`` in ``cwd`` with stdout and stderr captured as text, its exit status (argparse's
    exits included) as the return code, warnings printed to stderr as a fresh interpreter prints
    them (each once), and what ``main`` sets for the whole process (signal handlers, the
    unraisable hook) put back afterwards. A bug's exception is raised, not turned into a status.
    Without the interpreter's start (imports, the kernels' loading: about 2 s a command)."""
    from harness.cli import main

    out, err = io.StringIO(), io.StringIO()
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    hook = sys.unraisablehook
    try:
        with (
            contextlib.chdir(cwd or "."),
            contextlib.redirect_stdout(out),
            contextlib.redirect_stderr(err),
            warnings.catch_warnings(record=True) as caught,
        ):
            warnings.resetwarnings()
            warnings.simplefilter("default")
            for action, category in _FRESH_FILTERS:
                warnings.filterwarnings(action, category=category)
            try:
                code = main(list(args))
            except SystemExit as e:  # argparse's usage errors and --help
                code = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
                if isinstance(e.code, str):
                    print(e.code, file=sys.stderr)
            for w in caught:
                err.write(warnings.formatwarning(w.message, w.category, w.filename, w.lineno, w.line))
    finally:
        for s, handler in handlers.items():
            signal.signal(s, handler)
        sys.unraisablehook = hook
    return subprocess.CompletedProcess(list(args), code, out.getvalue(), err.getvalue())
