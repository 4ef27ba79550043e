"""Progress of long work, through one channel: the lines a command prints as it goes, and
the fraction done of its long tasks.

The library tells the channel two things: :func:`say` a line (one per stage smoothed, per
log written, ...), :func:`report` how much of a task is done (the smoother over a pass's
rows, the least squares over the runs). Whoever runs the work decides where that goes, by
installing a :class:`Progress` for it with :func:`reporting`. By default none is installed
and both go nowhere: a library call, a test and a pipe's stderr stay quiet.

- The Python API's ``progress=`` (a callable that receives each line as a ``str``) installs
  :class:`Lines` for the call (:func:`lines_to`): the lines go to the callable, the
  fractions on to the progress installed around the call, if any.
- The command line installs a :class:`TerminalProgress`: each line on stdout, and the
  fraction done on one line of stderr, rewritten in place, only when stderr is a terminal
  and only once the work has run for ``DELAY`` seconds; that line is erased before any other
  line is printed and when the work ends.
"""

from __future__ import annotations

import contextvars
import shutil
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Protocol, TextIO

__all__ = [
    "DELAY",
    "INTERVAL",
    "LineReceiver",
    "Lines",
    "Progress",
    "TerminalProgress",
    "drop",
    "lines_to",
    "report",
    "reporting",
    "say",
]

DELAY = 2.0
"""s of work before the progress line first shows (short commands never show it)."""

INTERVAL = 0.2
"""s between rewrites of the line."""


LineReceiver = Callable[[str], None]
"""What the Python API's ``progress=`` is: a callable that receives each line (str) as the
command line would print it (:func:`lines_to`)."""


class Progress(Protocol):
    """Where the progress of the work goes: its lines and its fractions done."""

    def line(self, text: str) -> None:
        """A line the work says, as the command prints it."""

    def fraction(self, task: str, fraction: float) -> None:
        """``fraction`` (in [0, 1]) of ``task`` is done."""


_channel: contextvars.ContextVar[Progress | None] = contextvars.ContextVar(
    "rsp_inertia_progress", default=None
)


def say(text: str) -> None:
    """Give the installed progress a line (nothing happens without one).

    Parameters
    ----------
    text : str
        The line, as the command prints it.
    """
    channel = _channel.get()
    if channel is not None:
        channel.line(text)


def report(task: str, done: float, total: float = 1.0) -> None:
    """Tell the installed progress that ``done`` of ``total`` of ``task`` is done (nothing
    happens without one).

    Parameters
    ----------
    task : str
        The task's name, as the progress line shows it.
    done : float
        How much of the task is done, in the units of ``total``.
    total : float, optional
        The whole task; the progress receives done / total clipped to [0, 1] (1 when
        ``total`` is not positive).
    """
    channel = _channel.get()
    if channel is not None:
        channel.fraction(task, min(max(done / total, 0.0), 1.0) if total > 0 else 1.0)


@contextmanager
def reporting(channel: Progress | None) -> Iterator[None]:
    """Install ``channel`` as the progress of the work done inside the block (None:
    silence); a :class:`TerminalProgress`'s line is erased on leaving it."""
    token = _channel.set(channel)
    try:
        yield
    finally:
        if isinstance(channel, TerminalProgress):
            channel.clear()
        _channel.reset(token)


@contextmanager
def lines_to(receive: LineReceiver | None) -> Iterator[None]:
    """The Python API's ``progress=``: the lines of the work inside the block go to
    ``receive``, its fractions on to the progress installed around it (:class:`Lines`).
    None leaves the installed progress as it is (none by default: the lines go nowhere)."""
    if receive is None:
        yield
        return
    with reporting(Lines(receive, _channel.get())):
        yield


def drop(text: str) -> None:
    """Receives a line and drops it: ``with lines_to(drop)`` keeps the lines of a part of
    the work unsaid, while its fractions still go to the installed progress."""


class Lines:
    """A :class:`Progress` that hands each line to a callable and each fraction on to an
    outer progress (or nowhere)."""

    def __init__(self, receive: LineReceiver, outer: Progress | None = None):
        self.receive = receive
        """Receives each line."""
        self.outer = outer
        """Receives the fractions (None: they go nowhere)."""

    def line(self, text: str) -> None:
        self.receive(text)

    def fraction(self, task: str, fraction: float) -> None:
        if self.outer is not None:
            self.outer.fraction(task, fraction)


class TerminalProgress:
    """The command line's :class:`Progress`: each line on stdout, at once; with
    ``fractions``, "task: 42%" on one line of a terminal's stderr, rewritten in place
    (module docstring) and erased before each line."""

    def __init__(
        self,
        stream: TextIO | None = None,
        clock: Callable[[], float] = time.monotonic,
        fractions: bool = True,
    ):
        self.stream = sys.stderr if stream is None else stream
        """Where the fraction's line goes."""
        self.clock = clock
        """Seconds, monotonic (a test passes its own)."""
        self.start = clock()
        """When the work began."""
        self.shown = 0
        """Characters of the line on screen now (0: none)."""
        self.last = -float("inf")
        """When the line was last written."""
        isatty = getattr(self.stream, "isatty", None)
        self.enabled = fractions and bool(isatty and isatty())
        """Only a terminal gets the fraction's line, and only when ``fractions``."""

    def line(self, text: str) -> None:
        """Print ``text`` on stdout (sys.stdout when printed), the fraction's line erased
        first, so that the two never share a line."""
        self.clear()
        print(text, flush=True)

    def fraction(self, task: str, fraction: float) -> None:
        """Rewrite the line with ``fraction`` of ``task`` done: not before ``DELAY`` s of
        work, at most once per ``INTERVAL`` s."""
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
        """Erase the fraction's line (nothing if none shows)."""
        if self.shown:
            self.stream.write("\r" + " " * self.shown + "\r")
            self.stream.flush()
            self.shown = 0
