"""The command line's progress line: on a terminal's stderr, erased before every printed line;
nothing in a pipe.

The experiment is the API tests' short one (tests.test_api.short_experiment: 4-9 s brakings
and an ideal reverse), so that identify takes seconds.
"""

from __future__ import annotations

import io
import subprocess
import sys

import pytest

from rsp_inertia.cli import main
from rsp_inertia.infra import progress
from tests.test_api import short_experiment


class FakeTerminal(io.StringIO):
    """A stderr that claims to be a terminal."""

    def isatty(self) -> bool:
        return True


class Recorder(io.StringIO):
    """A stdout that notes, at each write, whether stderr's last character ends a progress line
    (nothing shown, or the line erased: a trailing carriage return)."""

    def __init__(self, stderr: FakeTerminal) -> None:
        super().__init__()
        self.stderr = stderr
        self.clean: list[bool] = []

    def write(self, text: str) -> int:
        shown = self.stderr.getvalue()
        self.clean.append(shown == "" or shown.endswith("\r"))
        return super().write(text)


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    return short_experiment(tmp_path_factory.mktemp("progress") / "exp")


def test_identify_on_a_terminal_shows_the_runs_and_clears_before_printing(
    experiment, monkeypatch
):
    # No delay and no throttle, so that every report of the runs writes the line.
    monkeypatch.setattr(progress, "DELAY", 0.0)
    monkeypatch.setattr(progress, "INTERVAL", 0.0)
    stderr = FakeTerminal()
    stdout = Recorder(stderr)
    monkeypatch.setattr(sys, "stderr", stderr)
    monkeypatch.setattr(sys, "stdout", stdout)
    assert main(["identify", str(experiment)]) == 0
    shown = stderr.getvalue()
    assert "\rruns smoothed and balanced: 100%" in shown
    assert shown.endswith("\r")  # erased when identify ends
    assert stdout.clean and all(stdout.clean)
    assert "\r" not in stdout.getvalue()


def test_identify_in_a_pipe_writes_no_progress(experiment):
    done = subprocess.run(
        [sys.executable, "-m", "rsp_inertia.cli", "identify", str(experiment)],
        capture_output=True, text=True, timeout=300, check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "\r" not in done.stderr
    assert "\r" not in done.stdout
    assert "rows smoothed and balanced" in done.stdout
