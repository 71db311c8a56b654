"""A dependency-free progress bar for long runs (stderr; quiet when not a terminal)."""

from __future__ import annotations

import sys
import time


class Progress:
    """Progress over a known number of ticks, showing simulated time and speed.

    On a terminal the bar redraws in place; otherwise (or with ``redraw=False``, as when several
    processes share the terminal) it prints a line every 10%.
    """

    def __init__(
        self,
        total: int,
        label: str,
        dt: float | None = None,
        stream=None,
        enabled: bool = True,
        redraw: bool | None = None,
    ):
        self.total, self.label, self.dt = max(1, total), label, dt
        self.stream = stream or sys.stderr
        self.enabled = enabled
        # redraw in place on a terminal (None: when the stream is one); lines otherwise
        self.tty = (hasattr(self.stream, "isatty") and self.stream.isatty()) if redraw is None else bool(redraw)
        self.start = time.perf_counter()
        self._last_decile = -1

    def __call__(self, done: int, total: int | None = None) -> None:
        if not self.enabled:
            return
        total = total or self.total
        frac = min(1.0, done / total)
        if not self.tty:
            decile = int(frac * 10)
            if decile == self._last_decile:
                return
            self._last_decile = decile
        elapsed = max(time.perf_counter() - self.start, 1e-9)
        text = f"{self.label} {frac * 100:5.1f}% {done}/{total} ticks"
        if self.dt:
            sim = done * self.dt
            text += f"  sim {sim:7.0f} s  x{sim / elapsed:,.0f} real time"
        else:
            text += f"  {done / elapsed:,.0f} ticks/s"
        if self.tty:
            bar = "#" * int(frac * 30)
            self.stream.write(f"\r[{bar:<30}] {text}")
            if done >= total:
                self.stream.write("\n")
        else:
            self.stream.write(text + "\n")
        self.stream.flush()
