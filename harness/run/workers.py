"""Worker processes that stop with the command: local workers die with their parent (also when the
parent is killed with SIGKILL), leave Ctrl-C and SIGTERM to the parent, and are terminated at once
when the parent is interrupted; RatSLAM's compiled kernels are built once, in the parent."""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from typing import Any

import numpy as np

_PR_SET_PDEATHSIG = 1  # linux/prctl.h
_interrupted = threading.Event()


def interrupt(signum, frame) -> None:
    """Ctrl-C and SIGTERM in the command line's process: remember the interrupt and raise
    KeyboardInterrupt. Where the exception lands inside a ctypes callback (numba compiling a
    kernel: "Exception ignored on calling ctypes callback function") Python drops it; the
    remembered interrupt is raised again by :func:`raise_if_interrupted` at the next safe point."""
    _interrupted.set()
    raise KeyboardInterrupt


def quiet_dropped_interrupt(unraisable) -> None:
    """``sys.unraisablehook`` of the command line: an interrupt Python dropped where it landed (a
    ctypes callback, numba compiling or loading a kernel) is not printed, since
    :func:`raise_if_interrupted` raises it again at the next safe point and the command then says
    it was interrupted in one line; anything else is reported as Python would."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt) and _interrupted.is_set():
        return
    sys.__unraisablehook__(unraisable)


def raise_if_interrupted() -> None:
    """Raise KeyboardInterrupt if :func:`interrupt` was called (its exception may have been lost)."""
    if _interrupted.is_set():
        raise KeyboardInterrupt


def die_with_parent(parent: int) -> None:
    """End this process when process ``parent`` ends: the kernel's parent-death signal on Linux
    (``prctl(PR_SET_PDEATHSIG, SIGKILL)``), elsewhere a thread polling the parent's id."""
    armed = False
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            armed = libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
        except (OSError, AttributeError):
            armed = False
    if os.getppid() != parent:  # the parent died before the signal was armed
        os._exit(1)
    if not armed:

        def watch() -> None:
            while os.getppid() == parent:
                time.sleep(0.5)
            os._exit(1)

        threading.Thread(target=watch, name="parent-watchdog", daemon=True).start()


def worker_init(parent: int) -> None:
    """Pool initializer: die with ``parent``; Ctrl-C (sent to the whole terminal's process group)
    and SIGTERM are the parent's to handle, which then terminates the workers (no tracebacks).
    Workers start with SIGINT blocked (:func:`sigint_blocked`), so a Ctrl-C while one starts
    is dropped here, never a traceback of its start-up."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    die_with_parent(parent)


@contextmanager
def sigint_blocked() -> Iterator[None]:
    """Block SIGINT in this thread while workers are started: they inherit the mask (also across
    the exec of a spawned worker) until :func:`worker_init` ignores the signal and unblocks it.
    A Ctrl-C meanwhile is held, not lost: it reaches this process when the block ends."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def free_cores() -> int:
    """Cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def default_workers(n_jobs: int) -> int:
    """Processes for ``n_jobs`` independent runs: one per job, at most one per free core."""
    return max(1, min(n_jobs, free_cores()))


def fork_context():
    """Worker start method: fork where available (no re-import, kernels already loaded)."""
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def pool(workers: int, mp_context) -> ProcessPoolExecutor:
    """A process pool whose workers are set up by :func:`worker_init`."""
    return ProcessPoolExecutor(
        max_workers=workers, mp_context=mp_context, initializer=worker_init, initargs=(os.getpid(),)
    )


def terminate(executor: ProcessPoolExecutor) -> None:
    """Stop ``executor``'s workers now (SIGTERM, then SIGKILL after 2 s) and drop its queue."""
    procs = list((getattr(executor, "_processes", None) or {}).values())
    for p in procs:
        if p.is_alive():
            p.terminate()
    for p in procs:
        p.join(2.0)
        if p.is_alive():
            p.kill()
            p.join(1.0)
    executor.shutdown(wait=False, cancel_futures=True)


def map_in_processes(fn: Callable[[Any], Any], jobs: Iterable[Any], workers: int, mp_context) -> list:
    """``[fn(job) for job in jobs]`` on ``workers`` processes; interrupted or failing, the workers
    are terminated before the exception goes on (no run keeps writing into a removed directory)."""
    ex = pool(workers, mp_context)
    try:
        with sigint_blocked():
            pending = ex.map(fn, jobs)  # submits every job: the workers start here
        results = list(pending)
    except BaseException:
        terminate(ex)
        raise
    ex.shutdown()
    return results


def _compile_kernels(parent: int, config, part: str) -> None:
    """A helper of :func:`warm_kernels`: one part of the pose cells' kernels, set up as a worker
    (with the "boxes" part, the view cells' and the experience map's kernels too)."""
    from ratslam.pipeline import compile_map_kernels
    from ratslam.pose_cells import compile_kernels

    worker_init(parent)
    compile_kernels(config, part)
    if part == "boxes":
        compile_map_kernels(config)


def warm_kernels() -> None:
    """Compile RatSLAM's numba kernels in this process (or load them from numba's disk cache):
    forked workers inherit them and spawned ones load the cache, instead of each compiling them
    again (a first compile takes tens of seconds per process on a loaded machine). The pose cells'
    kernels compile in three parts side by side, two in forked helpers that leave them in the cache
    (:func:`ratslam.pose_cells.compile_kernels`; the "boxes" helper then compiles the view cells'
    and the experience map's, :func:`ratslam.pipeline.compile_map_kernels`; this process loads
    the "layers" part from the cache when its own part is done); then a 4 m square driven
    twice with a scene per side: path integration, view injection, experience creation, loop
    closure and map correction."""
    from ratslam import PoseCellConfig, RatSLAM, RatSLAMConfig
    from ratslam.pose_cells import PoseCells, compile_kernels

    config = RatSLAMConfig(pose_cells=PoseCellConfig(nx=20, ny=20, n_theta=36))
    with sigint_blocked():
        helpers = [
            fork_context().Process(target=_compile_kernels, args=(os.getpid(), config, part), daemon=True)
            for part in ("boxes", "layers")
        ]
        for helper in helpers:
            helper.start()
    try:
        compile_kernels(config, "iteration")
        for helper in helpers:
            helper.join()
        compile_kernels(config, "layers")  # loaded from the cache the helper left
    finally:
        for helper in helpers:
            if helper.is_alive():  # interrupted: the helpers go too
                helper.terminate()
                helper.join()
    cells = PoseCells(config)  # a packet injected apart (a new box), then near it (boxes merged)
    for x in (10, 4, 2):
        cells.inject(np.array([[x, 0, 0]]), 0.5)
        cells.step(0.0, 0.0)
    rs = RatSLAM(config)
    dt = 1.0 / 7.0
    for _lap in range(2):
        for side in range(4):
            for k in range(19):
                rs.step(dt, 0.3, 0.0, side if k > 9 else -1)
            for _ in range(7):
                rs.step(dt, 0.0, (3.141592653589793 / 2) / (7 * dt), -1)
    raise_if_interrupted()  # a Ctrl-C while numba compiled may have been dropped in its callback
