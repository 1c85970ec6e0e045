"""Progress display for the long commands, drawn by tqdm on stderr and only on a terminal."""

from __future__ import annotations

import sys
from collections.abc import Iterable, Iterator
from typing import TextIO, TypeVar

from tqdm import tqdm

__all__ = ["Progress", "track"]

T = TypeVar("T")


class Progress:
    """Counts the steps of a job on a tqdm bar.

    Parameters
    ----------
    total : int
        Number of steps.
    label : str
        Text before the bar.
    stream : file, optional
        Where to draw (stderr by default). Nothing is drawn when ``enabled`` is False or the
        stream is not a terminal, so a log file or a pipe gets no carriage-return noise.
    enabled : bool, optional
        False turns the display off (the commands' ``--no-progress``).
    """

    def __init__(self, total: int, label: str, stream: TextIO | None = None, enabled: bool = True) -> None:
        self.total = max(1, int(total))
        self.label = label
        self.stream = stream or sys.stderr
        isatty = getattr(self.stream, "isatty", None)
        self.enabled = enabled and bool(isatty is not None and isatty())
        self.done = 0
        self._bar = tqdm(total=self.total, desc=label, file=self.stream, disable=not self.enabled,
                         leave=True, dynamic_ncols=True)

    def step(self, note: str = "") -> None:
        """Advance by one step; ``note`` says what the step was."""
        self.done += 1
        if note:
            self._bar.set_postfix_str(note[:30], refresh=False)
        self._bar.update(1)
        if self.done >= self.total:
            self.close()

    def close(self) -> None:
        """End the display (idempotent)."""
        self._bar.close()


def track(items: Iterable[T], label: str, total: int | None = None, enabled: bool = True) -> Iterator[T]:
    """Iterate over ``items`` with a progress display on stderr when it is a terminal.

    Parameters
    ----------
    items : iterable
        The steps.
    label : str
        Text before the bar.
    total : int, optional
        Number of steps, when ``items`` has no length.
    enabled : bool, optional
        False turns the display off.
    """
    isatty = getattr(sys.stderr, "isatty", None)
    on = enabled and bool(isatty is not None and isatty())
    yield from tqdm(items, desc=label, total=total, file=sys.stderr, disable=not on, leave=True,
                    dynamic_ncols=True)
