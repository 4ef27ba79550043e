"""Progress of long work, one channel: its lines and its fractions go to the one progress
installed (nowhere without one); a terminal's line shows after DELAY, throttled, erased.

The terminal is a StringIO that says it is one; the clock is a list of instants the test
moves by hand, so that DELAY and INTERVAL are checked exactly, without sleeping.
"""

from __future__ import annotations

import io

from rsp_inertia.infra import progress
from rsp_inertia.infra.progress import (
    DELAY,
    INTERVAL,
    Lines,
    TerminalProgress,
    drop,
    lines_to,
    report,
    reporting,
    say,
)


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


class Recorder:
    """A progress that keeps what it receives."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.fractions: list[tuple[str, float]] = []

    def line(self, text: str) -> None:
        self.lines.append(text)

    def fraction(self, task: str, fraction: float) -> None:
        self.fractions.append((task, fraction))


def test_lines_and_fractions_travel_through_the_one_progress_installed():
    recorder = Recorder()
    with reporting(recorder):
        say("stage 1 forward: smoothed")
        report("runs", 1, 2)
    say("after the block")
    report("runs", 2, 2)
    assert recorder.lines == ["stage 1 forward: smoothed"]
    assert recorder.fractions == [("runs", 0.5)]


def test_the_apis_callable_gets_the_lines_and_the_outer_progress_the_fractions():
    outer, lines = Recorder(), []
    with reporting(outer):
        with lines_to(lines.append):
            say("one")
            report("runs", 1, 4)
        say("two")
        with lines_to(None):  # the API without progress=: the installed progress as it is
            say("three")
        with lines_to(drop):
            say("unsaid")
            report("runs", 2, 4)
    assert lines == ["one"]
    assert outer.lines == ["two", "three"]
    assert outer.fractions == [("runs", 0.25), ("runs", 0.5)]
    with lines_to(lines.append):  # nothing around: the fractions go nowhere
        report("runs", 3, 4)
        say("four")
    assert lines == ["one", "four"]


def test_nothing_without_a_progress(capsys):
    assert progress._channel.get() is None
    say("a line")
    report("runs", 1, 2)
    report("runs", 1, 0)
    assert capsys.readouterr() == ("", "")


def test_nothing_on_a_stream_that_is_not_a_terminal(capsys):
    stream, clock = io.StringIO(), Clock()
    with reporting(TerminalProgress(stream, clock)):
        for k in range(100):
            clock.now = k * INTERVAL
            report("runs", k, 100)
        say("a line")
    assert stream.getvalue() == ""
    assert capsys.readouterr().out == "a line\n"


def test_the_line_shows_after_the_delay_throttled_and_is_erased_before_a_line(capsys):
    stream, clock = FakeTerminal(), Clock()
    with reporting(TerminalProgress(stream, clock)):
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
        say("stage 1 forward: smoothed")
        shown = len("runs: 75% (2 s)")
        assert stream.getvalue().endswith("\r" + " " * shown + "\r")
        assert capsys.readouterr().out == "stage 1 forward: smoothed\n"
        written = stream.getvalue()
        say("another")  # nothing shows: nothing to erase
        assert stream.getvalue() == written
    assert stream.getvalue() == written


def test_without_fractions_the_terminal_gets_the_lines_only(capsys):
    stream, clock = FakeTerminal(), Clock()
    with reporting(TerminalProgress(stream, clock, fractions=False)):
        clock.now = 10 * DELAY
        report("runs", 1, 2)
        say("a line")
    assert stream.getvalue() == ""
    assert capsys.readouterr().out == "a line\n"


def test_a_shorter_line_blanks_the_rest_of_a_longer_one():
    stream, clock = FakeTerminal(), Clock()
    line = TerminalProgress(stream, clock)
    clock.now = DELAY
    line.fraction("a long task name", 0.5)
    clock.now += INTERVAL
    line.fraction("short", 1.0)
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


def test_the_fraction_is_clipped():
    recorder = Recorder()
    with reporting(recorder):
        report("rows", 5, 10)
        report("rows", 12, 10)
        report("rows", 0, 0)
    assert recorder.fractions == [("rows", 0.5), ("rows", 1.0), ("rows", 1.0)]


def test_lines_hands_each_line_to_its_callable():
    lines = []
    Lines(lines.append).line("one")
    Lines(lines.append).fraction("runs", 0.5)  # no outer progress: dropped
    assert lines == ["one"]


def test_a_line_wider_than_the_terminal_keeps_its_end(monkeypatch):
    # A wrapped line could not be rewritten in place: it is cut to the width less one.
    monkeypatch.setenv("COLUMNS", "30")
    stream, clock = FakeTerminal(), Clock()
    line = TerminalProgress(stream, clock)
    clock.now = DELAY
    line.fraction("/a/long/path/of/an/experiment/stage1/braking.csv: smoothing", 0.25)
    shown = stream.getvalue()
    assert shown == "\r..." + "braking.csv: smoothing: 25% (2 s)"[-26:]
    assert len(shown) == 1 + 29
