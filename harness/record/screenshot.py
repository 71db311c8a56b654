"""Screenshot of a recording open in the Rerun viewer with its default blueprint, headless.

    python -m harness.record.screenshot RUN/recording.rrd shot.png [--tick K] [--size 1600x900]

Starts the viewer of the installed rerun-sdk in headless mode (``rerun --headless``: no window,
no X server), opens the file, waits until it has loaded, moves the time cursor to tick ``K``
(default: the last tick) and saves a PNG of the whole viewer once two consecutive screenshots
agree (the viewer fetches data lazily after the cursor moves). The viewer renders with Vulkan;
on a machine without a GPU, Mesa's software driver is needed (Debian:
``apt-get install -y mesa-vulkan-drivers``). The viewer also runs under Xvfb
(``apt-get install -y xvfb``), but the headless mode is used here
because it can wait for the data: ``rerun FILE --screenshot-to`` shoots after a fixed number of
frames, before a large recording has arrived.

Failures (no Vulkan driver, viewer crash, timeout) raise :class:`ScreenshotError` with a
one-line message; the command line prints it and exits with status 1.
"""

from __future__ import annotations

import argparse
import glob
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from worlds.errors import InputError

VULKAN_ICD_DIRS = ("/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d", "/usr/local/share/vulkan/icd.d")


class ScreenshotError(InputError, RuntimeError):
    """The screenshot could not be taken (one line: what is missing or what failed)."""


def _rerun_executable() -> str:
    here = Path(sys.executable).parent / "rerun"
    found = str(here) if here.exists() else shutil.which("rerun")
    if not found:
        raise ScreenshotError("rerun viewer executable not found (install rerun-sdk 0.41 in this environment)")
    return found


def _check_vulkan() -> None:
    if os.environ.get("VK_ICD_FILENAMES") or os.environ.get("VK_DRIVER_FILES"):
        return
    if not any(glob.glob(os.path.join(d, "*.json")) for d in VULKAN_ICD_DIRS):
        raise ScreenshotError("no Vulkan driver found (Debian: apt-get install -y mesa-vulkan-drivers)")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def screenshot(
    rrd_path, png_path, *, tick: int | None = None, size: str = "1600x900", timeout: float = 180.0, settle: float = 2.0
) -> dict:
    """Render ``rrd_path`` in the headless viewer and save ``png_path``.

    ``tick``: time cursor on the ``tick`` timeline (None: the last tick); ``size``: viewer size in
    logical points; ``timeout``: seconds to wait for the viewer and the data; ``settle``: seconds
    between the screenshots compared to decide that the view is complete. Returns ``{"png": path,
    "tick": tick, "views": {view name: [problems reported by the view]}}``.
    """
    from rerun.experimental import ViewerClient

    rrd_path, png_path = Path(rrd_path).resolve(), Path(png_path).resolve()
    if not rrd_path.is_file():
        raise ScreenshotError(f"{rrd_path}: no such recording")
    if png_path == rrd_path or png_path.suffix.lower() != ".png":
        raise ScreenshotError(f"{png_path}: the screenshot must be a .png other than the recording")
    _check_vulkan()
    exe = _rerun_executable()
    port = _free_port()
    log = tempfile.TemporaryFile()  # noqa: SIM115 (closed in the finally below)
    # Own session: the ``rerun`` script starts the viewer binary as a child, both must be stopped.
    proc = subprocess.Popen(
        [exe, "--headless", "--hide-welcome-screen", "--port", str(port), "--window-size", size],
        stdout=log,
        stderr=subprocess.STDOUT,
        stdin=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.monotonic() + timeout

    def failed(what: str) -> ScreenshotError:
        log.seek(0)
        lines = [ln.strip() for ln in log.read().decode(errors="replace").splitlines()]
        why = next((ln for ln in lines if "panicked" in ln or "No graphics adapter" in ln), "")
        return ScreenshotError(f"{rrd_path.name}: {what}" + (f" ({why})" if why else ""))

    # shots go to a temporary name next to the PNG, moved into place only once the view settled
    shot_path = png_path.with_name(f".{png_path.stem}.partial{png_path.suffix}")
    try:
        client = None
        while client is None:
            if proc.poll() is not None:
                raise failed(f"viewer exited with status {proc.returncode}")
            try:
                client = ViewerClient.connect(f"rerun+http://127.0.0.1:{port}/proxy")
                client.get_state()
            except Exception:
                client = None
                if time.monotonic() > deadline:
                    raise failed("viewer did not start in time") from None
                time.sleep(0.2)
        client.open([str(rrd_path)])
        end: int | None = None
        while True:
            if proc.poll() is not None:
                raise failed(f"viewer exited with status {proc.returncode}")
            state = client.get_state()
            rec = state.recordings[0] if state.recordings else None
            ticks = [tl for tl in (rec.timelines if rec else []) if tl.name == "tick" and tl.end is not None]
            if not state.loading and ticks:
                end = ticks[0].end
                break
            if time.monotonic() > deadline:
                raise failed("recording did not load in time")
            time.sleep(0.25)
        if tick is not None:
            end = int(tick)
        assert end is not None  # the loop above leaves only with the timeline's end
        client.set_time("tick", sequence=end, play_state="paused")
        png_path.parent.mkdir(parents=True, exist_ok=True)
        # The viewer fetches the chunks a view needs after the time cursor moves: shoot until two
        # consecutive screenshots are identical (a large recording takes several seconds).
        previous, shots = None, 0
        while True:
            time.sleep(settle)
            client.save_screenshot(str(shot_path))
            shots += 1
            current = shot_path.read_bytes()
            if current == previous:
                break
            if time.monotonic() > deadline:
                raise failed(f"the view did not settle in time ({shots} screenshots)")
            previous = current
        views = {v.name: [f"{r.severity}: {r.summary}" for r in v.reports] for v in client.get_state().views}
        if proc.poll() is not None or not shot_path.exists():
            raise failed("viewer crashed while drawing")
        os.replace(shot_path, png_path)
        return {"png": png_path, "tick": end, "views": views}
    except TimeoutError:  # the viewer did not answer a control request
        raise failed("viewer did not answer in time") from None
    finally:
        shot_path.unlink(missing_ok=True)
        _stop(proc)
        log.close()


def _stop(proc: subprocess.Popen) -> None:
    """Stop the viewer's process group (the script and the binary it started): SIGTERM, then
    SIGKILL if anything is left after 10 s."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            proc.poll()  # reap the script, the group's leader
            try:
                os.killpg(proc.pid, 0)
            except ProcessLookupError:
                return
            time.sleep(0.1)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m harness.record.screenshot", description=__doc__.split("\n\n")[0])
    p.add_argument("rrd", help="recording (.rrd)")
    p.add_argument("png", help="output PNG")
    p.add_argument("--tick", type=int, default=None, help="time cursor (default: the last tick)")
    p.add_argument("--size", default="1600x900", help="viewer size in points, WIDTHxHEIGHT")
    p.add_argument("--timeout", type=float, default=180.0)
    args = p.parse_args(argv)
    try:
        out = screenshot(args.rrd, args.png, tick=args.tick, size=args.size, timeout=args.timeout)
    except ScreenshotError as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    from ..run.directory import add_to_manifest

    add_to_manifest(Path(out["png"]).parent, [out["png"]])  # into a run directory: the run's own now
    problems = [f"{name}: {r}" for name, rs in out["views"].items() for r in rs]
    print(
        f"{out['png']} (tick {out['tick']}, {len(out['views'])} views"
        + (f"; problems: {'; '.join(problems)})" if problems else ")")
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
