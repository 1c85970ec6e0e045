"""A minimal progress bar on stderr (no dependency), for the long commands."""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress"]


class Progress:
    """Counts steps of a job and redraws ``label [#####.....] k/n  t s`` in place.

    Parameters
    ----------
    total : int
        Number of steps.
    label : str
        Text before the bar.
    stream : file, optional
        Where to draw (stderr by default); nothing is drawn when ``enabled`` is False or the
        stream is not a terminal (a log file or a pipe gets no carriage-return noise).
    """

    def __init__(self, total: int, label: str, stream: TextIO | None = None, enabled: bool = True) -> None:
        self.total = max(1, int(total))
        self.label = label
        self.stream = stream or sys.stderr
        isatty = getattr(self.stream, "isatty", None)
        self.enabled = enabled and bool(isatty is not None and isatty())
        self.done = 0
        self.start = time.perf_counter()

    def step(self, note: str = "") -> None:
        """Advance by one step and redraw."""
        self.done += 1
        if not self.enabled:
            return
        width = 30
        filled = int(width * self.done / self.total)
        bar = "#" * filled + "." * (width - filled)
        elapsed = time.perf_counter() - self.start
        end = "\n" if self.done >= self.total else ""
        self.stream.write(f"\r{self.label} [{bar}] {self.done}/{self.total} {elapsed:5.1f}s {note[:30]:<30}{end}")
        self.stream.flush()
