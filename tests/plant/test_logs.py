"""Logs and programs: exact round trips, the Stieltjes motor work, atomic writes, bad input."""

import math
import os
import re
import time
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import write_atomic
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.log_checks import SPEED_MARGIN, TORQUE_MARGIN, unterminated_last_line
from rsp_inertia.plant.logs import (
    JITTER_LIMIT,
    Log,
    Program,
    dropped_samples,
    motor_work,
    read_log,
    read_program,
    write_log,
    write_program,
)


@dataclass(frozen=True)
class Encoder:
    """Stand-in for rsp_inertia.plant.config.Encoder: the readers only use it duck-typed."""

    counts_per_rev: int = 65536
    sample_rate: float = 1000.0

    @property
    def quantum(self) -> float:
        return 2.0 * math.pi / self.counts_per_rev

    @property
    def dt(self) -> float:
        return 1.0 / self.sample_rate


ENCODER = Encoder()
Q = ENCODER.quantum

finite = st.floats(allow_nan=False, allow_infinity=False)


def bits(array: np.ndarray) -> np.ndarray:
    """The float64 bit patterns, so that -0.0 != 0.0 and equality means identity."""
    return np.asarray(array, dtype=np.float64).view(np.int64)


def make_log(n: int = 50) -> Log:
    """A plausible braking pass: 6 rad/s at the release, uniform deceleration to rest."""
    t = np.arange(n) * ENCODER.dt
    angle = 6.0 * (t - t**2 / (2.0 * t[-1]))
    counts = np.floor(angle / Q) + 1000
    torque = -0.005 + 1e-4 * np.sin(np.arange(n))
    return Log(t=t, phi=counts * Q, torque=torque)


def make_program(n: int = 50) -> Program:
    t = np.arange(n) * ENCODER.dt
    return Program(
        t=t,
        phi_ref=1.0 - 0.1 * t,
        omega_ref=-0.1 + 0 * t,
        torque_ff=0.01 * np.cos(t),
        k_phi=np.full(n, 2.0),
        k_omega=np.full(n, 0.3),
    )


# ---------------------------------------------------------------------------------------------
# Round trips


@settings(max_examples=60, deadline=None)
@given(
    counts_per_rev=st.integers(16, 2**24),
    sample_rate=st.floats(10.0, 1e5),
    start=st.integers(-(10**6), 10**6),
    steps=st.lists(st.integers(0, 40), min_size=1, max_size=200),
    kind=st.sampled_from(["braking", "reverse"]),
    data=st.data(),
)
def test_log_round_trip_is_exact(
    tmp_path_factory, counts_per_rev, sample_rate, start, steps, kind, data
):
    encoder = Encoder(counts_per_rev, sample_rate)
    sign = 1 if kind == "braking" else -1
    if kind == "braking":  # a braking that stays at a reading has stopped: its reader cuts it
        steps = [step + 1 for step in steps]  # there (plant.log_checks.turning_point)
    counts = start + sign * np.cumsum([0, steps[0] + 1, *steps[1:]])  # the pass must move
    n = len(counts)
    log = Log(
        t=np.arange(n) / sample_rate,
        phi=counts * encoder.quantum,
        torque=data.draw(st.lists(finite, min_size=n, max_size=n)),
    )
    path = tmp_path_factory.mktemp("logs") / f"{kind}.csv"
    write_log(path, log)
    back = read_log(path, encoder, kind)
    for name in ("t", "phi", "torque"):
        np.testing.assert_array_equal(bits(getattr(back, name)), bits(getattr(log, name)))


@settings(max_examples=40, deadline=None)
@given(n=st.integers(2, 100), sample_rate=st.floats(10.0, 1e5), data=st.data())
def test_program_round_trip_is_exact(tmp_path_factory, n, sample_rate, data):
    columns = [data.draw(st.lists(finite, min_size=n, max_size=n)) for _ in range(5)]
    program = Program(np.arange(n) / sample_rate, *columns)
    path = tmp_path_factory.mktemp("programs") / "program.csv"
    write_program(path, program)
    back = read_program(path, Encoder(sample_rate=sample_rate))
    for name in ("t", "phi_ref", "omega_ref", "torque_ff", "k_phi", "k_omega"):
        np.testing.assert_array_equal(bits(getattr(back, name)), bits(getattr(program, name)))


def test_files_are_byte_identical_when_written_twice(tmp_path):
    log = make_log(200)
    write_log(tmp_path / "a.csv", log)
    write_log(tmp_path / "b.csv", log)
    write_log(tmp_path / "c.csv", read_log(tmp_path / "a.csv", ENCODER, "braking"))
    first = (tmp_path / "a.csv").read_bytes()
    assert first == (tmp_path / "b.csv").read_bytes() == (tmp_path / "c.csv").read_bytes()
    assert first.startswith(b"t,phi,torque\n0.0,") and b"\r" not in first

    write_program(tmp_path / "p.csv", make_program())
    write_program(tmp_path / "q.csv", make_program())
    program = (tmp_path / "p.csv").read_bytes()
    assert program == (tmp_path / "q.csv").read_bytes()
    assert program.startswith(b"t,phi_ref,omega_ref,torque_ff,k_phi,k_omega\n")


def test_reading_a_normal_log_is_fast(tmp_path):
    # 30,000 rows (30 s at 1 kHz) is an ordinary braking pass; the budget is 0.5 s.
    log = make_log(30_000)
    write_log(tmp_path / "braking.csv", log)
    start = time.perf_counter()
    read_log(tmp_path / "braking.csv", ENCODER, "braking")
    assert time.perf_counter() - start < 0.5


# ---------------------------------------------------------------------------------------------
# The dataclasses


def test_motor_work_is_the_zero_order_hold_sum():
    rng = np.random.default_rng(1)
    n = 500
    log = Log(
        t=np.arange(n) * ENCODER.dt,
        phi=np.cumsum(rng.integers(0, 30, n)) * Q,
        torque=rng.normal(0.0, 0.01, n),
    )
    expected = [0.0]
    for k in range(1, n):
        expected.append(expected[-1] + log.torque[k - 1] * (log.phi[k] - log.phi[k - 1]))
    # Same products summed in the same order: equal up to rounding of the running sum.
    np.testing.assert_allclose(log.motor_work(), expected, rtol=1e-12, atol=1e-15)


def test_constant_torque_does_work_torque_times_angle():
    log = make_log(300)
    constant = Log(t=log.t, phi=log.phi, torque=np.full(len(log), 0.02))
    np.testing.assert_allclose(constant.motor_work(), 0.02 * (log.phi - log.phi[0]), atol=1e-15)


def test_arrays_are_read_only_float64_copies():
    phi = np.arange(3) * Q
    log = Log(t=[0, 1e-3, 2e-3], phi=phi, torque=[1, 2, 3])
    phi[1] = 99.0
    assert log.phi[1] == Q and len(log) == 3
    for array in (log.t, log.phi, log.torque, *vars(make_program()).values()):
        assert array.dtype == np.float64 and not array.flags.writeable
        with pytest.raises(ValueError):
            array[0] = 1.0


def test_unequal_lengths_are_a_programming_error():
    with pytest.raises(ValueError, match="unequal length"):
        Log(t=[0.0, 1e-3], phi=[0.0, Q, 2 * Q], torque=[0.0, 0.0])
    with pytest.raises(ValueError, match="unequal length"):
        Program([0.0, 1e-3], [0.0, 0.0], [0.0, 0.0], [0.0], [0.0, 0.0], [0.0, 0.0])
    with pytest.raises(ValueError):
        read_log("unused.csv", ENCODER, Direction.FORWARD)


def test_writing_non_finite_values_is_refused(tmp_path):
    log = make_log(5)
    bad = Log(t=log.t, phi=log.phi, torque=[0.0, math.nan, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="torque"):
        write_log(tmp_path / "braking.csv", bad)
    assert os.listdir(tmp_path) == []


# ---------------------------------------------------------------------------------------------
# write_atomic


def test_write_atomic_leaves_only_the_target(tmp_path):
    target = tmp_path / "out.csv"
    write_atomic(target, "one\n")
    write_atomic(str(target), "two\r\n")
    assert os.listdir(tmp_path) == ["out.csv"]
    assert target.read_bytes() == b"two\r\n"  # written as given, no newline translation
    write_atomic(target, b"\x89PNG\r\n\x1a\n")  # bytes (a figure) as they are
    assert os.listdir(tmp_path) == ["out.csv"]
    assert target.read_bytes() == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("step", ["replace", "fsync"])
def test_a_failed_write_keeps_the_old_file(tmp_path, monkeypatch, step):
    target = tmp_path / "braking.csv"
    target.write_text("old content\n")

    def fail(*args, **kwargs):
        raise OSError("disk on fire")

    monkeypatch.setattr(os, step, fail)
    with pytest.raises(OSError, match="disk on fire"):
        write_log(target, make_log())
    with pytest.raises(OSError, match="disk on fire"):
        write_atomic(tmp_path / "new.csv", "never\n")
    assert target.read_text() == "old content\n"
    assert os.listdir(tmp_path) == ["braking.csv"]


# ---------------------------------------------------------------------------------------------
# Bad input

LOG_HEADER = "t,phi,torque"
PROGRAM_HEADER = "t,phi_ref,omega_ref,torque_ff,k_phi,k_omega"


def log_rows(n: int = 6, kind: str = "braking") -> list[str]:
    """Data rows of a valid log; rows[i] is line i + 2 of the file."""
    sign = 1 if kind == "braking" else -1
    return [f"{k / 1000!r},{sign * k * k * Q!r},-0.005" for k in range(n)]


def program_rows(n: int = 6) -> list[str]:
    return [f"{k / 1000!r},1.0,-0.5,0.01,2.0,0.3" for k in range(n)]


def text(header: str, rows: list[str], end: str = "\n") -> str:
    """A CSV file's text.

    Parameters
    ----------
    header : str
        The header line.
    rows : list of str
        The data lines.
    end : str
        The line end, after every line.

    Returns
    -------
    str
        The lines joined.
    """
    return end.join([header, *rows]) + end


def log_with(index: int, row: str) -> str:
    """A valid braking log with data row ``index`` (line index + 2) replaced."""
    rows = log_rows()
    rows[index] = row
    return text(LOG_HEADER, rows)


def program_with(index: int, row: str) -> str:
    """A valid program with data row ``index`` (line index + 2) replaced."""
    rows = program_rows()
    rows[index] = row
    return text(PROGRAM_HEADER, rows)


def assert_one_line(error: pytest.ExceptionInfo, path, line: int | None, *words: str) -> None:
    """An error message is one line naming the file, the line and the fault.

    Parameters
    ----------
    error : pytest.ExceptionInfo
        The error raised.
    path : str or path-like
        The file the message must start with.
    line : int or None
        The line it must name (None: no line).
    *words : str
        What else it must say.
    """
    message = str(error.value)
    assert "\n" not in message and "\r" not in message
    assert message.startswith(str(path))
    if line is not None:
        assert re.search(rf"\bline {line}\b", message), message
    for word in words:
        assert word in message, message


BAD_LOGS = {
    # name: (kind, content or None for a missing file, line named, words in the message)
    "missing file": ("braking", None, None, ["no such file"]),
    "empty file": ("braking", "", None, ["empty"]),
    "blank lines only": ("braking", "\n \n\r\n", None, ["empty"]),
    "header with a column missing": (
        "braking", text("t,phi", log_rows()), 1,
        ["column 'torque' not found; the header has 't', 'phi': set [log] torque_column"],
    ),
    "header with other names": ("braking", text("time,phi,torque", log_rows()), 1, ["time"]),
    # columns are found by name: an extra one is read past, but every row must have it
    "header with an extra column": (
        "braking", text("t,phi,torque,x", log_rows()), 2, ["3 fields, expected 4"]
    ),
    "no header": ("braking", "\n".join(log_rows()), 1, ["column 't' not found", "'0.0'"]),
    "too few fields": ("braking", log_with(2, "0.002,0.0"), 4, ["2 fields"]),
    "too many fields": ("braking", log_with(3, "0.003,0,0,0"), 5, ["4 fields"]),
    "blank line inside": ("braking", log_with(1, ""), 3, ["blank"]),
    "phi not a number": ("braking", log_with(2, "0.002,abc,0"), 4, ["phi", "'abc'"]),
    "empty torque": ("braking", log_with(4, "0.004,0.0,"), 6, ["torque", "not a number"]),
    "nan torque": ("braking", log_with(3, "0.003,0.0,nan"), 5, ["torque", "not finite"]),
    "infinite phi": ("braking", log_with(5, "0.005,-inf,0"), 7, ["phi", "not finite"]),
    "header only": ("braking", text(LOG_HEADER, []), None, ["0 data row"]),
    "one row": ("braking", text(LOG_HEADER, log_rows(1)), None, ["1 data row"]),
    "t not from 0": ("braking", log_with(0, "0.5,0.0,0"), 2, ["t = 0.5"]),
    "t repeated": ("braking", log_with(3, f"0.002,{9 * Q!r},0"), 5, ["strictly increasing"]),
    "t going back": ("braking", log_with(2, f"0.0005,{4 * Q!r},0"), 4, ["strictly increasing"]),
    "step under half a period": (
        "braking", log_with(5, f"0.0044,{25 * Q!r},0"), 7, ["0.0004 s", "t = 0.0044 s", "half"]
    ),
    "wrong sample rate": (
        "braking",
        text(LOG_HEADER, [f"{k / 500!r},{k * Q!r},0" for k in range(5)]),
        None,
        ["median time step 0.002 s, expected 0.001 s"],
    ),
    "phi off the grid": (
        "braking",
        log_with(3, "0.003,0.12345,0"),
        5,
        ["phi = 0.12345 is not on the encoder grid (q = 9.587e-05 rad)"],
    ),
    # A backward braking (its torque against its motion) in a forward braking's file.
    "braking going back": (
        "braking",
        text(LOG_HEADER, [row.replace(",-0.005", ",0.005") for row in log_rows(kind="reverse")]),
        7,
        ["a braking log must end at a larger phi than it starts"],
    ),
    # The encoder counting backwards: phi falls where the braking torque, logged with its
    # sign, is negative (it would speed the body up as logged).
    "braking with the encoder counting backwards": (
        "braking",
        text(LOG_HEADER, log_rows(kind="reverse")),
        7,
        ["the encoder counts backwards", "reverse the encoder's counting direction"],
    ),
    "braking standing still": (
        "braking",
        text(LOG_HEADER, [f"{k / 1000!r},0.0,0" for k in range(4)]),
        5,
        ["braking", "larger phi"],
    ),
    "reverse going forward": ("reverse", text(LOG_HEADER, log_rows()), 7, ["reverse", "smaller"]),
}


@pytest.mark.parametrize("case", BAD_LOGS, ids=list(BAD_LOGS))
def test_bad_logs_are_one_line_input_errors(tmp_path, case):
    kind, content, line, words = BAD_LOGS[case]
    path = tmp_path / "stage1" / f"{kind}.csv"
    path.parent.mkdir()
    if content is not None:
        path.write_bytes(content.encode())
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, kind)
    assert_one_line(error, path, line, *words)


BAD_PROGRAMS = {
    # name: (content or None for a missing file, line named, words in the message)
    "missing file": (None, None, ["no such file"]),
    "empty file": ("", None, ["empty"]),
    "log header": (text(LOG_HEADER, log_rows()), 1, [PROGRAM_HEADER]),
    "too few fields": (program_with(1, "0.001,1,2"), 3, ["3 fields"]),
    "gain not a number": (program_with(4, "0.004,1,2,3,x,5"), 6, ["k_phi = 'x'"]),
    "infinite gain": (program_with(2, "0.002,1,2,3,4,inf"), 4, ["k_omega", "not finite"]),
    "one row": (text(PROGRAM_HEADER, program_rows(1)), None, ["1 data row"]),
    "t not from 0": (program_with(0, "0.001,1,1,1,1,1"), 2, ["t = 0.001"]),
    "t going back": (program_with(3, "0.001,1,1,1,1,1"), 5, ["strictly increasing"]),
    "wrong sample rate": (program_with(2, "0.0021,1,1,1,1,1"), 4, ["expected 0.001 s"]),
}


@pytest.mark.parametrize("case", BAD_PROGRAMS, ids=list(BAD_PROGRAMS))
def test_bad_programs_are_one_line_input_errors(tmp_path, case):
    content, line, words = BAD_PROGRAMS[case]
    path = tmp_path / "stage2" / "program.csv"
    path.parent.mkdir()
    if content is not None:
        path.write_bytes(content.encode())
    with pytest.raises(InputError) as error:
        read_program(path, ENCODER)
    assert_one_line(error, path, line, *words)


def test_tolerated_variants_read_like_the_plain_file(tmp_path):
    plain = tmp_path / "plain.csv"
    plain.write_text(text(LOG_HEADER, log_rows()))
    variants = {
        "crlf.csv": text(LOG_HEADER, log_rows(), end="\r\n"),
        "spaces.csv": text("  t , phi ,torque \r", [r.replace(",", " , ") for r in log_rows()]),
        "trailing_blank_lines.csv": text(LOG_HEADER, log_rows()) + "\n  \n\r\n",
        "bom.csv": "\ufeff" + text(LOG_HEADER, log_rows()),
    }
    expected = read_log(plain, ENCODER, "braking")
    for name, content in variants.items():
        (tmp_path / name).write_bytes(content.encode())
        log = read_log(tmp_path / name, ENCODER, "braking")
        for field in ("t", "phi", "torque"):
            np.testing.assert_array_equal(getattr(log, field), getattr(expected, field), name)


@pytest.mark.parametrize(
    "last", ["0.005,0.0001", "0.005,1.2e-", "0.005,3.0e-05,-0.00", log_rows(6)[5]]
)
def test_a_last_line_without_a_line_end_is_left_out(tmp_path, last):
    """A logger stopped while writing its last line (cut mid-field or mid-number, or whole
    but never ended: nothing tells them apart): the row is left out, never read as a number
    cut short, and the reader says so (unterminated_last_line)."""
    rows = log_rows(5)
    plain = tmp_path / "plain.csv"
    plain.write_text(text(LOG_HEADER, rows))
    cut = tmp_path / "cut.csv"
    cut.write_bytes((text(LOG_HEADER, rows) + last).encode())
    assert unterminated_last_line(cut) and not unterminated_last_line(plain)
    expected, log = read_log(plain, ENCODER, "braking"), read_log(cut, ENCODER, "braking")
    for field in ("t", "phi", "torque"):
        np.testing.assert_array_equal(getattr(log, field), getattr(expected, field))


def test_a_header_alone_without_a_line_end_is_no_cut_row(tmp_path):
    path = tmp_path / "header.csv"
    path.write_bytes(LOG_HEADER.encode())
    assert not unterminated_last_line(path)
    with pytest.raises(InputError, match="0 data row"):
        read_log(path, ENCODER, "braking")


# ---------------------------------------------------------------------------------------------
# Backward runs: the braking moves phi down, its reverse up


@pytest.mark.parametrize("kind", ["braking", "reverse"])
def test_backward_logs_run_the_other_way(tmp_path, kind):
    mirror = "reverse" if kind == "braking" else "braking"
    path = tmp_path / f"{kind}_backward.csv"
    path.write_text(text(LOG_HEADER, log_rows(kind=mirror)))
    log = read_log(path, ENCODER, kind, Direction.BACKWARD)
    assert len(log) == 6
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, kind)  # forward, the default: the wrong way
    assert_one_line(error, path, 7, kind)


def test_a_backward_braking_log_that_moves_forward_is_refused(tmp_path):
    path = tmp_path / "braking_backward.csv"
    path.write_text(text(LOG_HEADER, log_rows()))
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", Direction.BACKWARD)
    assert_one_line(
        error,
        path,
        7,
        "a backward braking log must end at a smaller phi than it starts "
        "(phi decreases during a backward braking), but phi goes from 0.0 to ",
    )
    path = tmp_path / "reverse_backward.csv"
    path.write_text(text(LOG_HEADER, log_rows(kind="reverse")))
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "reverse", Direction.BACKWARD)
    assert_one_line(error, path, 7, "a backward reverse log must end at a larger phi", "increases")


def test_pendulum_logs_ignore_the_direction(tmp_path):
    path = tmp_path / "pendulum_k1.csv"
    path.write_text(text(LOG_HEADER, log_rows(kind="reverse")))
    for direction in Direction:
        assert len(read_log(path, ENCODER, "pendulum", direction)) == 6


# ---------------------------------------------------------------------------------------------
# Integer counts from a drive's counter


@dataclass(frozen=True)
class CountingEncoder(Encoder):
    counter_bits: int | None = 16


def _counts_file(path, t, counts, torque):
    rows = [f"{float(a)!r},{int(c)},{float(b)!r}" for a, c, b in zip(t, counts, torque)]
    path.write_text("t,counts,torque\n" + "\n".join(rows) + "\n")
    return path


@settings(max_examples=40, deadline=None)
@given(
    bits_=st.integers(13, 20),
    start=st.integers(0, 2**20),
    steps=st.lists(st.integers(1, 3000), min_size=2, max_size=300),
)
def test_wrapped_counts_read_as_the_unwrapped_angle(tmp_path_factory, bits_, start, steps):
    """A counter of 2^b counts that wraps many times reads back as phi = counts x q of the
    unwrapped counts, up to whole wraps of the start (whole turns: 2^b is a multiple of
    counts_per_rev = 2^13): the angle modulo a turn is exactly the true one."""
    encoder = CountingEncoder(counts_per_rev=2**13, counter_bits=bits_)
    true = start + np.concatenate([[0], np.cumsum(steps)])
    t = np.arange(true.size) * encoder.dt
    path = _counts_file(tmp_path_factory.mktemp("c") / "b.csv", t, true % 2**bits_, 0 * t - 0.01)
    log = read_log(path, encoder, "braking")
    q = encoder.quantum
    turns = (log.phi - true * q) / (2 * math.pi)
    np.testing.assert_allclose(turns, np.round(turns[0]), atol=1e-9)
    np.testing.assert_array_equal(np.diff(np.round(log.phi / q)), np.diff(true))


def test_bad_counts_are_one_line(tmp_path):
    encoder = CountingEncoder(counts_per_rev=2**13, counter_bits=16)
    t = np.arange(5) * encoder.dt
    path = _counts_file(tmp_path / "b.csv", t, [1, 2, 3, 4, 5], -0.01 + 0 * t)
    text = path.read_text().replace("\n0.003,4,", "\n0.003,4.5,")
    path.write_text(text)
    with pytest.raises(InputError, match=r"b\.csv, line 5: counts = 4\.5 is not an integer"):
        read_log(path, encoder, "braking")
    path = _counts_file(tmp_path / "c.csv", t, [1, 2, 3, 70000, 5], -0.01 + 0 * t)
    with pytest.raises(InputError, match=r"c\.csv, line 5: counts = 70000 is outside the 16-bit"):
        read_log(path, encoder, "braking")
    odd = CountingEncoder(counts_per_rev=3600, counter_bits=16)
    path = _counts_file(tmp_path / "d.csv", t, [1, 2, 3, 4, 5], -0.01 + 0 * t)
    with pytest.raises(InputError, match="not a whole number of turns of 3600 counts"):
        read_log(path, odd, "braking")


def test_written_counts_read_back_as_the_angle(tmp_path):
    """write_log with a counter writes the counts a 16-bit drive counter shows (wrapping
    below zero and past 2^16); read_log unwraps them to the same angles up to whole wraps."""
    encoder = CountingEncoder(counts_per_rev=2**13, counter_bits=16)
    q = encoder.quantum
    counts = np.arange(-50, 100) * 700  # the counter wraps below 0 and past 2^16
    log = Log(t=np.arange(counts.size) * encoder.dt, phi=counts * q, torque=-0.01 + 0 * counts)
    write_log(tmp_path / "b.csv", log, counter=encoder)
    header, first = (tmp_path / "b.csv").read_text().splitlines()[:2]
    assert (header, first) == ("t,counts,torque", f"0.0,{-35000 % 2**16},-0.01")
    back = read_log(tmp_path / "b.csv", encoder, "braking")
    wraps = (back.phi - log.phi) / (2**16 * q)
    np.testing.assert_allclose(wraps, np.round(wraps[0]), atol=1e-12)
    np.testing.assert_array_equal(back.t, log.t)
    np.testing.assert_array_equal(back.torque, log.torque)


@settings(max_examples=30, deadline=None)
@given(
    jitter=st.floats(0.0, JITTER_LIMIT * 0.999),
    drops=st.lists(st.integers(1, 40), max_size=5, unique=True),
    gap=st.integers(1, 30),
    seed=st.integers(0, 2**16),
)
def test_jittered_gappy_time_stamps_are_read_and_their_gaps_counted(
    tmp_path_factory, jitter, drops, gap, seed
):
    """Stamps off the grid by up to the jitter limit, single dropped rows and one longer gap
    of ``gap`` samples: the log reads back exactly, and dropped_samples finds every gap."""
    rng = np.random.default_rng(seed)
    k = np.arange(60)
    t = (k + np.concatenate([[0.0], rng.uniform(-jitter, jitter, k.size - 1)])) / 1000
    keep = np.ones(k.size, bool)
    keep[drops] = False
    keep[45 : 45 + gap] = False
    keep[0] = keep[-1] = True
    rows = [f"{a!r},{j * j * Q!r},-0.005" for a, j in zip(t[keep].tolist(), k[keep].tolist())]
    path = tmp_path_factory.mktemp("j") / "braking.csv"
    path.write_text(text(LOG_HEADER, rows))
    log = read_log(path, ENCODER, "braking")
    np.testing.assert_array_equal(log.t, t[keep])
    missing = dropped_samples(log.t, ENCODER.sample_rate)
    np.testing.assert_array_equal(missing, np.diff(k[keep]) - 1)


@pytest.mark.parametrize("value", ["1000.0", "-1e300", "1e300"])
def test_a_torque_no_drive_produces_is_refused_with_its_line(tmp_path, value):
    # A one-row spike or a scale error would pass for real work (Jz 41% off, or a program
    # asking 1.3e297 N m): beyond TORQUE_MARGIN x the motor's limit it is a logging fault.
    rows = log_rows()
    t, phi, _ = rows[3].split(",")
    rows[3] = f"{t},{phi},{value}"
    path = tmp_path / "braking.csv"
    path.write_text(text(LOG_HEADER, rows))
    read_log(path, ENCODER, "braking")  # without the device's limit: not checked
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking", torque_limit=0.5)
    assert_one_line(error, path, 5, "torque", "beyond what the drive can produce", "0.5 N m")


def test_a_torque_within_the_margin_reads(tmp_path):
    # A drive's short overload is a few times its continuous limit: not refused.
    rows = log_rows()
    t, phi, _ = rows[3].split(",")
    rows[3] = f"{t},{phi},{0.9 * TORQUE_MARGIN * 0.5!r}"
    path = tmp_path / "braking.csv"
    path.write_text(text(LOG_HEADER, rows))
    assert read_log(path, ENCODER, "braking", torque_limit=0.5).torque[3] == 0.9 * TORQUE_MARGIN * 0.5


# ---------------------------------------------------------------------------------------------
# Angle steps that no speed explains


def _braking_counts(encoder, speed: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """t and the counts of an incremental encoder over a braking from ``speed`` to rest."""
    t = np.arange(n) * encoder.dt
    duration = t[-1] + encoder.dt
    return t, 1000 + np.floor(speed * (t - t**2 / (2 * duration)) / encoder.quantum)


@pytest.mark.parametrize("column", ["phi", "counts"])
def test_an_angle_jump_no_speed_explains_is_refused_with_its_line(tmp_path, column):
    # A counter that skips from a row on: 3.1 rad in 1 ms is 3100 rad/s on a device launched
    # at 12 rad/s, and would pass for half a turn of the motor's work. (A single row that
    # jumps and comes back is a glitch, left out: plant.log_glitches.)
    encoder = CountingEncoder(counts_per_rev=2**13, counter_bits=16)
    t, counts = _braking_counts(encoder, 12.0, 300)
    jump = round(3.1 / encoder.quantum)
    counts[150:] += jump
    torque = np.full(t.size, -0.005)
    path = tmp_path / "braking.csv"
    if column == "counts":
        _counts_file(path, t, counts % 2**16, torque)
    else:
        write_log(path, Log(t=t, phi=counts * encoder.quantum, torque=torque))
    read_log(path, encoder, "braking")  # without the device's launch speed: not checked
    with pytest.raises(InputError) as error:
        read_log(path, encoder, "braking", launch_speed=12.0)
    assert_one_line(
        error, path, 152, "the angle jumps by 3.11 rad in 0.001 s", f"{SPEED_MARGIN:g} x",
        "fastest stage.launch_speed = 12 rad/s", "a logging fault",
    )


@settings(max_examples=30, deadline=None)
@given(
    rate=st.sampled_from([1000.0, 10000.0]),
    bits_=st.integers(10, 20),
    launch=st.floats(0.5, 50.0),
    seed=st.integers(0, 2**16),
)
def test_genuine_logs_step_well_within_the_speed_bound(
    tmp_path_factory, rate, bits_, launch, seed
):
    """A braking from 1.5 x the launch speed (what a spring or a falling reduced inertia may
    add) to rest, at 1 or 10 kHz, its instants jittered by the reader's limit, 2% of its rows
    and a stretch of 40 dropped, read by an incremental encoder of 10 to 20 bits with +-2
    counts of readhead noise, whose counter wraps every turn: it reads with the speed bound,
    and still would with a launch speed 5 x lower."""
    rng = np.random.default_rng(seed)
    encoder = CountingEncoder(counts_per_rev=2**bits_, sample_rate=rate, counter_bits=bits_)
    n = 3000
    t = np.arange(n) + rng.uniform(-JITTER_LIMIT, JITTER_LIMIT, n)
    t[0] = 0.0
    t /= rate
    keep = rng.uniform(size=n) > 0.02
    keep[1000:1040] = False
    keep[[0, -1]] = True
    t = t[keep]
    duration = n / rate
    angle = 1.5 * launch * (t - t**2 / (2 * duration))
    counts = np.floor(angle / encoder.quantum + rng.uniform(-2.0, 2.0, t.size))
    counts += rng.integers(0, 2**bits_) - counts[0]
    path = tmp_path_factory.mktemp("genuine") / "braking.csv"
    _counts_file(path, t, counts % 2**bits_, np.full(t.size, -0.005))
    for speed in (launch, launch / 5):
        log = read_log(path, encoder, "braking", launch_speed=speed)
        # Near rest the readhead's noise (+-2 counts) hides the last counts of motion: the
        # reader may take the last stay at the furthest reading for the stop and cut it
        # (plant.log_checks.turning_point), only rows within that noise of the rest: the
        # true angle left to go after the last row kept is within the noise's span (4
        # counts) and the floor's count. (The readings cut are noisier still: noise at the
        # furthest reading and at the cut, up to 7 counts apart.)
        np.testing.assert_array_equal(log.t, t[: len(log)])
        assert (angle.max() - angle[len(log) - 1]) / encoder.quantum <= 5.0


def test_a_constant_logged_torque_with_a_known_factor_does_the_factors_work():
    """A braking whose drive holds its logged torque constant while the body receives it
    times a known factor (a warming motor's, compensated): the work is the logged mean times
    the sum of factor x the angle's increments, and its mean the logged one."""
    rng = np.random.default_rng(37)
    phi = np.cumsum(rng.uniform(0.001, 0.002, 500))
    factor = 1.0 - 1e-3 * np.linspace(0.0, 1.0, phi.size)
    logged = np.full(phi.size, -0.12)
    work, back, _, mean = motor_work(logged * factor, phi, constant=True, factor=factor)
    assert mean == pytest.approx(-0.12, rel=1e-12)
    expected = np.concatenate([[0.0], np.cumsum(-0.12 * factor[:-1] * np.diff(phi))])
    np.testing.assert_allclose(work, expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(back, expected, rtol=1e-12, atol=1e-15)  # braking: all back-driven
    # Without the factor the constant work is the mean times the angle, as before.
    plain, *_ = motor_work(logged, phi, constant=True)
    np.testing.assert_allclose(plain, -0.12 * (phi - phi[0]), rtol=1e-12)
