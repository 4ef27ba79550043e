"""Progress of long work: a fraction done per task, shown on a terminal, silent elsewhere.

The numeric kernels (the smoother over a pass's rows, the least squares over the runs) call
:func:`report` with the task's name and how much of it is done; whoever runs them decides
whether that shows. By default nothing does: a library call, a test and a pipe stay quiet.
The command line installs a :class:`TerminalProgress` with :func:`reporting`; it writes one
line on stderr, rewritten in place, only when stderr is a terminal and only once the work
has run for ``DELAY`` seconds, and clears it before any other line is printed.
"""

from __future__ import annotations

import contextvars
import shutil
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TextIO

__all__ = ["DELAY", "INTERVAL", "TerminalProgress", "clear", "report", "reporting"]

DELAY = 2.0
"""s of work before the progress line first shows (short commands never show it)."""

INTERVAL = 0.2
"""s between rewrites of the line."""

Reporter = Callable[[str, float], None]
"""Receives (task, fraction done in [0, 1])."""

_reporter: contextvars.ContextVar[Reporter | None] = contextvars.ContextVar(
    "rsp_inertia_progress", default=None
)


def report(task: str, done: float, total: float = 1.0) -> None:
    """Tell the installed reporter that ``done`` of ``total`` of ``task`` is done (nothing
    happens without one).

    Parameters
    ----------
    task : str
        The task's name, as the progress line shows it.
    done : float
        How much of the task is done, in the units of ``total``.
    total : float, optional
        The whole task; the reporter receives done / total clipped to [0, 1] (1 when
        ``total`` is not positive).
    """
    reporter = _reporter.get()
    if reporter is not None:
        reporter(task, min(max(done / total, 0.0), 1.0) if total > 0 else 1.0)


def clear() -> None:
    """Erase the progress line, if one shows (before printing a line of output)."""
    reporter = _reporter.get()
    if isinstance(reporter, TerminalProgress):
        reporter.clear()


@contextmanager
def reporting(reporter: Reporter | None) -> Iterator[None]:
    """Install ``reporter`` for the work done inside the block (None: silence)."""
    token = _reporter.set(reporter)
    try:
        yield
    finally:
        if isinstance(reporter, TerminalProgress):
            reporter.clear()
        _reporter.reset(token)


class TerminalProgress:
    """One line on a terminal, "task: 42%", rewritten in place (module docstring)."""

    def __init__(self, stream: TextIO | None = None, clock: Callable[[], float] = time.monotonic):
        self.stream = sys.stderr if stream is None else stream
        """Where the line goes."""
        self.clock = clock
        """Seconds, monotonic (a test passes its own)."""
        self.start = clock()
        """When the work began."""
        self.shown = 0
        """Characters of the line on screen now (0: none)."""
        self.last = -float("inf")
        """When the line was last written."""
        isatty = getattr(self.stream, "isatty", None)
        self.enabled = bool(isatty and isatty())
        """Only a terminal gets the line."""

    def __call__(self, task: str, fraction: float) -> None:
        now = self.clock()
        if not self.enabled or now - self.start < DELAY or now - self.last < INTERVAL:
            return
        self.last = now
        elapsed = now - self.start
        text = f"{task}: {100 * fraction:.0f}% ({elapsed:.0f} s)"
        # A line longer than the terminal wraps, and "\r" would rewrite only its last row:
        # keep the end (the fraction), marking the cut.
        width = shutil.get_terminal_size().columns - 1
        if len(text) > width:
            text = "..." + text[len(text) - width + 3:]
        pad = max(self.shown - len(text), 0)
        self.stream.write("\r" + text + " " * pad)
        self.stream.flush()
        self.shown = len(text)

    def clear(self) -> None:
        """Erase the line (nothing if none shows)."""
        if self.shown:
            self.stream.write("\r" + " " * self.shown + "\r")
            self.stream.flush()
            self.shown = 0
