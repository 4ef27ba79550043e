"""The end of a braking log: a log that ends at the stop reads as written; a drive's logging
on after the stop (the body held, its reading still, dithering by a count or settling back
through the backlash) is cut at the braking's turning point with one note; a turning point
that is ambiguous is refused naming the file and the lines."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.log_checks import settle_counts, turning_point
from rsp_inertia.plant.logs import Log, mirror_log, read_log, write_log
from rsp_inertia.virtual.device import simulate_braking


@dataclasses.dataclass(frozen=True)
class Encoder:
    counts_per_rev: int = 4096
    sample_rate: float = 1000.0

    @property
    def quantum(self) -> float:
        return 2 * math.pi / self.counts_per_rev


ENCODER = Encoder()
Q = ENCODER.quantum


def braking_to_rest(decel: float = 20.0, speed: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """t and the encoder readings floor(phi / q) q of a braking at a constant deceleration,
    up to the last sample before the stop (the virtual device's log)."""
    rest = speed / decel
    t = np.arange(math.floor(rest * ENCODER.sample_rate) + 1) / ENCODER.sample_rate
    phi = speed * t - decel * t**2 / 2
    return t, np.floor(phi / Q) * Q


def with_tail(t, phi, counts) -> tuple[np.ndarray, np.ndarray]:
    """The log going on at the sample rate with readings ``counts`` off its last."""
    k = np.arange(1, len(counts) + 1)
    return (
        np.concatenate([t, t[-1] + k / ENCODER.sample_rate]),
        np.concatenate([phi, phi[-1] + np.asarray(counts) * Q]),
    )


def test_a_log_that_ends_at_the_stop_is_its_own_turning_point():
    # The last count's stay, however long the constant deceleration makes it, is no stop.
    for decel in (0.5, 5.0, 50.0):
        t, phi = braking_to_rest(decel, speed=1.0)
        assert turning_point("b.csv", t, phi, True, ENCODER) == len(t) - 1
        assert turning_point("b.csv", t, -phi, False, ENCODER) == len(t) - 1


@pytest.mark.parametrize(
    "tail",
    [
        [0] * 500,  # held still
        list(np.random.default_rng(1).integers(-1, 2, 500)),  # dithering by a count
        [-1, -2, -3] + [-3] * 497,  # settling back through the backlash
        [1, 0, 1, 0, -1, 0],  # a short dithering tail: the reading goes back
    ],
    ids=["held", "dithering", "backlash", "short dither"],
)
def test_a_tail_after_the_stop_is_cut_at_the_turning_point(tail):
    t, phi = braking_to_rest()
    first = int(np.flatnonzero(phi == phi[-1])[0])  # the first row at the rest's reading
    long_t, long_phi = with_tail(t, phi, tail)
    m = turning_point("b.csv", long_t, long_phi, True, ENCODER)
    # The first row at the furthest reading of the stop: the rest's, or a count past it
    # that dithering reached while the rest was still possible.
    assert m == first or (long_phi[m] == phi[-1] + Q and m - first < 40), (m, first)
    # The mirror, as a backward run reads it.
    assert turning_point("b.csv", long_t, -long_phi, False, ENCODER) == m


def test_the_reader_cuts_the_tail_and_says_so_in_one_line(tmp_path):
    t, phi = braking_to_rest()
    long_t, long_phi = with_tail(t, phi, [-1, -2] + [-2, -1] * 200)
    path = tmp_path / "braking.csv"
    write_log(path, Log(t=long_t, phi=long_phi, torque=np.full(long_t.size, -0.005)))
    log = read_log(path, ENCODER, "braking")
    m = len(log) - 1
    assert m < len(t) and np.array_equal(log.phi, long_phi[: m + 1])
    (note,) = log.notes
    assert "\n" not in note and note.startswith(f"{path}, lines {m + 3}-{long_t.size + 1}: ")
    assert f"turning point at line {m + 2}" in note and "-2 to +0 counts" in note
    # The mirror of the log keeps its note; a backward run's file reads the same way.
    assert mirror_log(log, Q).notes == log.notes
    back = tmp_path / "braking_backward.csv"
    write_log(back, Log(t=long_t, phi=-long_phi, torque=np.full(long_t.size, 0.005)))
    backward = read_log(back, ENCODER, "braking", Direction.BACKWARD)
    assert len(backward) == len(log) and "-2 to +0 counts" in backward.notes[0]


@pytest.mark.parametrize(
    "tail, words",
    [
        ([0] * 300 + list(range(1, 40)) + [40] * 100, "runs on"),  # moves on after the stop
        ([0] * 20 + [-k for k in range(1, 60)], "goes back"),  # turns back far beyond backlash
    ],
    ids=["moves on", "turns back"],
)
def test_an_ambiguous_turning_point_is_refused_naming_the_lines(tmp_path, tail, words):
    t, phi = braking_to_rest()
    long_t, long_phi = with_tail(t, phi, tail)
    path = tmp_path / "braking.csv"
    write_log(path, Log(t=long_t, phi=long_phi, torque=np.full(long_t.size, -0.005)))
    with pytest.raises(InputError) as error:
        read_log(path, ENCODER, "braking")
    message = str(error.value)
    beyond = len(t) + int(np.flatnonzero(np.abs(tail) > settle_counts(ENCODER))[0])
    assert "\n" not in message
    assert message.startswith(f"{path}, lines ") and f"-{beyond + 2}: " in message, message
    assert "turning point is ambiguous" in message and words in message


def test_the_virtual_drives_hold_is_cut_back_to_about_the_clean_log(
    default_device, virtual, tmp_path
):
    """The virtual device's braking held for 0.3 s after the stop, the reading dithering by
    a count and settling back 3: read, it is the clean log up to the turning point, within
    a count and a few rows of its end (the clean log's last stay is the approach to rest)."""
    logger = dataclasses.replace(
        virtual.logger, hold_after_stop=0.3, hold_dither=1, backlash_counts=3
    )
    held = dataclasses.replace(virtual, logger=logger)
    q = default_device.encoder.quantum
    for direction in Direction:
        clean = simulate_braking(default_device, 1, virtual, direction).log
        long = simulate_braking(default_device, 1, held, direction).log
        assert len(long) == len(clean) + 300
        path = tmp_path / f"braking_{direction}.csv"
        write_log(path, long)
        log = read_log(path, default_device.encoder, "braking", direction)
        assert len(log.notes) == 1 and abs(len(log) - len(clean)) <= 10
        n = min(len(log), len(clean))
        np.testing.assert_array_equal(log.phi[: n - 10], clean.phi[: n - 10])
        assert abs(log.phi[-1] - clean.phi[-1]) <= q * (1 + 1e-9)
