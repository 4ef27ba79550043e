"""Progress of long work: one line on a terminal after DELAY, throttled, erased; nothing else.

The terminal is a StringIO that says it is one; the clock is a list of instants the test
moves by hand, so that DELAY and INTERVAL are checked exactly, without sleeping.
"""

from __future__ import annotations

import io

from rsp_inertia.infra import progress
from rsp_inertia.infra.progress import DELAY, INTERVAL, TerminalProgress, clear, report, reporting


class FakeTerminal(io.StringIO):
    """A stream that claims to be a terminal."""

    def isatty(self) -> bool:
        return True


class Clock:
    """Seconds set by the test."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_nothing_on_a_stream_that_is_not_a_terminal():
    stream, clock = io.StringIO(), Clock()
    line = TerminalProgress(stream, clock)
    with reporting(line):
        for k in range(100):
            clock.now = k * INTERVAL
            report("runs", k, 100)
        clear()
    assert stream.getvalue() == ""


def test_the_line_shows_after_the_delay_throttled_and_is_erased():
    stream, clock = FakeTerminal(), Clock()
    line = TerminalProgress(stream, clock)
    with reporting(line):
        clock.now = 0.99 * DELAY
        report("runs", 1, 4)
        assert stream.getvalue() == ""  # short work never shows
        clock.now = DELAY
        report("runs", 2, 4)
        assert stream.getvalue() == "\rruns: 50% (2 s)"
        clock.now = DELAY + 0.5 * INTERVAL
        report("runs", 3, 4)
        assert stream.getvalue() == "\rruns: 50% (2 s)"  # within INTERVAL of the last write
        clock.now = DELAY + INTERVAL
        report("runs", 3, 4)
        assert stream.getvalue().endswith("\rruns: 75% (2 s)")
        clear()
        shown = len("runs: 75% (2 s)")
        assert stream.getvalue().endswith("\r" + " " * shown + "\r")
        written = stream.getvalue()
        clear()  # nothing shows: nothing to erase
        assert stream.getvalue() == written
    assert stream.getvalue() == written


def test_a_shorter_line_blanks_the_rest_of_a_longer_one():
    stream, clock = FakeTerminal(), Clock()
    line = TerminalProgress(stream, clock)
    clock.now = DELAY
    line("a long task name", 0.5)
    clock.now += INTERVAL
    line("short", 1.0)
    last = stream.getvalue().split("\r")[-1]
    assert last == "short: 100% (2 s)".ljust(len("a long task name: 50% (2 s)"))


def test_leaving_the_block_erases_the_line_and_silences_report():
    stream, clock = FakeTerminal(), Clock()
    with reporting(TerminalProgress(stream, clock)):
        clock.now = DELAY
        report("runs", 1, 2)
    assert stream.getvalue().endswith("\r" + " " * len("runs: 50% (2 s)") + "\r")
    written = stream.getvalue()
    clock.now += 10 * INTERVAL
    report("runs", 2, 2)
    assert stream.getvalue() == written


def test_report_without_a_reporter_does_nothing(capsys):
    assert progress._reporter.get() is None
    report("runs", 1, 2)
    report("runs", 1, 0)
    clear()
    assert capsys.readouterr() == ("", "")


def test_a_reporter_receives_the_fraction_clipped():
    seen = []
    with reporting(lambda task, fraction: seen.append((task, fraction))):
        report("rows", 5, 10)
        report("rows", 12, 10)
        report("rows", 0, 0)
    assert seen == [("rows", 0.5), ("rows", 1.0), ("rows", 1.0)]


def test_a_line_wider_than_the_terminal_keeps_its_end(monkeypatch):
    # A wrapped line could not be rewritten in place: it is cut to the width less one.
    monkeypatch.setenv("COLUMNS", "30")
    stream, clock = FakeTerminal(), Clock()
    line = TerminalProgress(stream, clock)
    clock.now = DELAY
    line("/a/long/path/of/an/experiment/stage1/braking.csv: smoothing", 0.25)
    shown = stream.getvalue()
    assert shown == "\r..." + "braking.csv: smoothing: 25% (2 s)"[-26:]
    assert len(shown) == 1 + 29
