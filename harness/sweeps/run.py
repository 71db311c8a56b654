"""Running a sweep: one task per (condition, seed), on a local process pool or a Dask cluster.

Each run simulates its condition once and runs every configured system on that stream
(:func:`harness.sweeps.task.run_one`, a pure function of its task). The driver
(:func:`run_sweep`) hands the missing runs to an :class:`Executor` and writes each result as it
arrives, staged and moved into place, into ``runs/<run id>/result.json``; the run id is a hash of
the run's full specification (world, duration, condition, seed, system configurations, code
version), so a killed sweep restarted with the same command computes only what is missing.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import math
import os
import shutil
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, wait
from pathlib import Path

from worlds.errors import InputError
from worlds.files import atomic_write_text, read_json, read_text, write_json

from ..run.directory import OutputError, output_errors, remove_stale
from ..run.workers import default_workers, pool, raise_if_interrupted, sigint_blocked, terminate, warm_kernels
from .spec import AXES, SweepSpec, system_config, system_fields
from .task import run_one

# BLAS and compiled-kernel threads per worker: every worker is one process on one core.
_ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}


# ---------------------------------------------------------------------------- tasks

# What a run's result depends on: the SLAM packages, the simulator and worlds, and the harness
# modules that run a stream and measure it (not the figures, reports or CLI).
_RESULT_SOURCES = (
    "slamkit/*.py",
    "ratslam/*.py",
    "baselines/*.py",
    "worlds/*.py",
    "worlds/*.toml",
    "harness/sweeps/task.py",
    "harness/run/conditions.py",
    "harness/report/metrics.py",
    "harness/report/evaluate.py",
    "harness/run/runner.py",
    "harness/run/stream.py",
    "harness/run/scale.py",
    "harness/sweeps/base_log.py",
    "harness/camera/stream.py",
    "harness/run/config_file.py",
)


def code_version() -> str:
    """A hash of the source a run's result depends on (``_RESULT_SOURCES``)."""
    root = Path(__file__).resolve().parents[2]
    h = hashlib.sha256()
    for pattern in _RESULT_SOURCES:
        for f in sorted(root.glob(pattern)):
            h.update(f.relative_to(root).as_posix().encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


def _system_entry(spec: SweepSpec, system, condition: dict) -> dict:
    """A system as a task carries it: its full configuration, or, for a real log, the preset and
    fields that go on top of the configuration derived from the labelled log."""
    entry = {"name": system.name, "kind": system.kind}
    if spec.log is None:
        return entry | {"config": dataclasses.asdict(system_config(system, condition))}
    return entry | {"preset": system.preset, "fields": system_fields(system, condition)}


def _base_entry(spec: SweepSpec) -> dict:
    """What the stream of every run starts from: a world (maybe seen through a camera, with the
    view matcher's settings) or a real log."""
    if spec.log is not None:
        return {"log": spec.log, "duration": spec.duration}
    base: dict = {"world": spec.world, "duration": spec.duration, "lookalikes": spec.lookalikes}
    if spec.camera is not None:
        base |= {"camera": spec.camera, "view": dataclasses.asdict(spec.camera_view())}
    return base


def run_tasks(spec: SweepSpec, code: str) -> list[dict]:
    """The sweep's tasks, in a fixed order: everything a run depends on, JSON-ready."""
    tasks = []
    base = spec.base_values()
    for varied, seed in spec.runs():
        # the full condition: a value repeated on two axes' curves (e.g. the base) runs once
        condition = {a: float(varied.get(a, base[a])) for a in spec.axis_names}
        task = {
            **_base_entry(spec),
            "condition": condition,
            "seed": seed,
            "systems": [_system_entry(spec, s, condition) for s in spec.systems],
            "code": code,
        }
        blob = json.dumps(task, sort_keys=True, allow_nan=True).encode()
        task["run_id"] = hashlib.sha256(blob).hexdigest()[:16]
        task["varied"] = next(iter(varied)) if spec.design == "one-at-a-time" else "grid"
        tasks.append(task)
    return tasks


# ---------------------------------------------------------------------------- executors


class SchedulerError(InputError, RuntimeError):
    """The Dask cluster cannot be used (one line: address and problem)."""


class Executor:
    """Runs ``fn`` over tasks somewhere; yields (task, result) as each finishes."""

    def run(self, fn: Callable[[dict], dict], tasks: list[dict]) -> Iterator[tuple[dict, dict]]:
        raise NotImplementedError

    def close(self) -> None:
        pass

    def abort(self) -> None:
        """Stop at once (interrupted): runs in flight are lost and recomputed on resume."""
        self.close()


class LocalExecutor(Executor):
    """A pool of ``workers`` fresh processes on this machine (one BLAS thread each)."""

    def __init__(self, workers: int):
        import multiprocessing

        self.workers = max(1, int(workers))
        saved = {k: os.environ.get(k) for k in _ONE_THREAD}
        os.environ.update(_ONE_THREAD)  # inherited by the spawned workers, which import numpy afresh
        try:
            warm_kernels()  # compiled (and cached on disk) once, before the workers load them
            self._pool = pool(self.workers, multiprocessing.get_context("spawn"))
            try:
                with sigint_blocked():  # every worker started now, while the environment is set
                    for started in [self._pool.submit(int, 0) for _ in range(self.workers)]:
                        started.result()
            except BaseException:
                terminate(self._pool)
                raise
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v

    def run(self, fn, tasks):
        pending: dict = {}
        queue = list(tasks)
        while queue or pending:
            while queue and len(pending) < 2 * self.workers:
                task = queue.pop(0)
                pending[self._pool.submit(fn, task)] = task
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for future in done:
                yield pending.pop(future), future.result()

    def close(self) -> None:
        self._pool.shutdown(wait=True, cancel_futures=True)

    def abort(self) -> None:
        terminate(self._pool)


class DaskExecutor(Executor):
    """The tasks on a Dask distributed cluster at ``address`` (``tcp://HOST:8786``). Dask's nanny
    starts each worker process with one BLAS/OpenMP thread (``distributed.nanny.pre-spawn-environ``)."""

    def __init__(self, address: str):
        try:
            from distributed import Client
        except ImportError:
            raise SchedulerError("--scheduler needs Dask distributed: pip install -e '.[cluster]'") from None
        if "://" not in address or not address.split("://", 1)[1]:
            raise SchedulerError(f"{address}: not a Dask scheduler address (expected tcp://HOST:PORT)")
        try:
            self._client = Client(address, timeout="20s")
        except (OSError, ValueError, TypeError) as e:
            raise SchedulerError(f"{address}: cannot reach the Dask scheduler ({e})") from None
        self._futures: dict = {}

    def run(self, fn, tasks):
        from distributed import as_completed

        self._futures = {
            self._client.submit(fn, task, key=f"ratslam-run-{task['run_id']}", pure=False): task for task in tasks
        }
        for future in as_completed(self._futures):
            yield self._futures[future], future.result()

    def close(self) -> None:
        self._client.close()

    def abort(self) -> None:
        """Cancel this command's tasks on the cluster (its other work is left alone), then disconnect."""
        with contextlib.suppress(Exception):  # an unreachable cluster: nothing more to cancel
            self._client.cancel(list(self._futures), force=True)
        self._client.close(timeout=5)


# ---------------------------------------------------------------------------- the driver


def _eta(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    return (
        f"{seconds // 3600}h{seconds % 3600 // 60:02d}m" if seconds >= 3600 else f"{seconds // 60}m{seconds % 60:02d}s"
    )


def _write_result(runs_dir: Path, task: dict, result: dict) -> None:
    """``runs/<id>/result.json``: written under a temporary name, then moved into place."""
    final = runs_dir / task["run_id"]
    stage = runs_dir / f".{task['run_id']}.partial-{os.getpid()}"
    try:
        stage.mkdir(parents=True, exist_ok=True)
        write_json(stage / "result.json", {"task": task, "result": result})
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    if final.exists():  # a result from a run that finished after a kill: keep the first
        shutil.rmtree(stage, ignore_errors=True)
        return
    os.replace(stage, final)


def _check_sweep_dir(out: Path) -> None:
    """An existing ``out`` must be a directory, empty or an earlier sweep's (it holds sweep.toml):
    a sweep writes runs.csv, report.md and sweep.toml there, and must not replace a user's."""
    if not out.exists() and not out.is_symlink():
        for p in out.parents:
            if p.exists():
                if not p.is_dir():
                    raise OutputError(f"{out}: {p} is a file, not a directory")
                break
        return
    if not out.is_dir():
        raise OutputError(f"{out}: exists and is not a directory (choose another --out)")
    if any(out.iterdir()) and not (out / "sweep.toml").is_file():
        raise OutputError(
            f"{out}: exists, is not empty and is not an earlier sweep directory (no sweep.toml); "
            "choose another --out or remove it"
        )


def completed(runs_dir: Path, tasks: Iterable[dict]) -> set[str]:
    """Run ids whose result is already in place."""
    return {t["run_id"] for t in tasks if (runs_dir / t["run_id"] / "result.json").is_file()}


def run_sweep(
    spec: SweepSpec,
    out,
    workers: int | None = None,
    scheduler: str | None = None,
    log: Callable[[str], None] | None = None,
) -> Path:
    """Run (or resume) ``spec`` into directory ``out``; write ``runs.csv`` and ``report.md``."""
    from .report import write_sweep_report

    log = log or (lambda line: print(line, file=sys.stderr, flush=True))
    out = Path(out)
    runs_dir = out / "runs"
    _check_sweep_dir(out)
    tasks = run_tasks(spec, code_version())
    unique = list({t["run_id"]: t for t in tasks}.values())
    done = completed(runs_dir, unique)
    todo = [t for t in unique if t["run_id"] not in done]
    total = len(unique)
    executor: Executor | None = None
    if todo:  # connect before writing anything: an unreachable cluster leaves no directory behind
        if scheduler:
            executor = DaskExecutor(scheduler)
        else:
            executor = LocalExecutor(workers or default_workers(len(todo)))
    try:
        with output_errors(out):
            runs_dir.mkdir(parents=True, exist_ok=True)
            remove_stale(runs_dir, ".*.partial-*")  # left by a killed sweep
            for stale in out.glob(".*.tmp*"):  # a report file a killed sweep was writing (worlds.files)
                stale.unlink(missing_ok=True)
            previous, spec_text = out / "sweep.toml", read_text(spec.path)
            if previous.is_file() and read_text(previous) != spec_text:
                log(
                    f"{previous}: another spec's (or an edited one's); replaced by {spec.path}. Runs already in "
                    f"{runs_dir} are reused where this spec asks for the same run; the report covers this spec's "
                    "runs only"
                )
            atomic_write_text(previous, spec_text)  # what the runs were made from
    except BaseException:
        if executor is not None:
            executor.abort()
        raise
    log(
        f"sweep {Path(spec.path).name}: {total} runs ({len(done)} already done, {len(todo)} to run), "
        f"{len(spec.systems)} systems each"
    )
    failures = sum(
        1
        for t in unique
        if t["run_id"] in done and read_json(runs_dir / t["run_id"] / "result.json")["result"]["error"]
    )
    if executor is not None:
        start, finished = time.perf_counter(), 0
        try:
            results = executor.run(run_one, todo)
            for task, result in results:
                with output_errors(out):
                    _write_result(runs_dir, task, result)
                raise_if_interrupted()
                finished += 1
                failures += bool(result["error"])
                elapsed = time.perf_counter() - start
                eta = elapsed / finished * (len(todo) - finished)
                cond = (
                    f"{task['varied']}={task['condition'][task['varied']]:g}"
                    if task["varied"] in AXES
                    else " ".join(f"{k}={v:g}" for k, v in task["condition"].items())
                )
                status = f"FAILED ({result['error']})" if result["error"] else f"{result['wall_s']:.1f} s"
                log(
                    f"[{len(done) + finished}/{total}] {cond} seed={task['seed']}: {status}; "
                    f"failures {failures}; ETA {_eta(eta)}"
                )
        except BaseException:
            executor.abort()  # interrupted: completed runs are on disk, the rest is recomputed on resume
            raise
        executor.close()
    with output_errors(out):
        write_sweep_report(out, tasks)
    log(f"sweep done: {total} runs, {failures} failed; {out / 'runs.csv'}, {out / 'report.md'}")
    return out
