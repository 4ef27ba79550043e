"""Glitches: an isolated row whose angle or torque disagrees with its neighbours is found,
named by its file's line and left out by the reader; genuine logs (quantized, noisy,
jittered, with gaps, steps of torque and a held body's dither) have none."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.log_checks import JITTER_LIMIT, Rows
from rsp_inertia.plant.log_glitches import (
    ANGLE_THRESHOLD,
    MAX_GLITCHES,
    MIN_ROWS,
    angle_residuals,
    find_glitches,
)
from rsp_inertia.plant.logs import Log, check_braking_monotone, read_log, write_log


@dataclass(frozen=True)
class Encoder:
    counts_per_rev: int = 2**16
    sample_rate: float = 1000.0

    @property
    def quantum(self) -> float:
        return 2 * np.pi / self.counts_per_rev


def braking(
    encoder: Encoder,
    n: int = 3000,
    speed: float = 12.0,
    noise: float = 1e-4,
    seed: int = 0,
    jitter: float = 0.0,
    dropped: float = 0.0,
    readhead: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """t, phi, torque of a braking from ``speed`` to rest at a constant deceleration, with a
    ripple of the reduced inertia (the speed's harmonic at 2 phi): instants jittered by up to
    ``jitter`` of a period, a fraction ``dropped`` of the rows lost, the encoder's readings
    floor(phi / q) q off by a uniform +-``readhead`` counts, the torque -0.005 N m plus
    white noise."""
    rng = np.random.default_rng(seed)
    k = np.arange(n) + np.concatenate([[0.0], rng.uniform(-jitter, jitter, n - 1)])
    keep = rng.uniform(size=n) >= dropped
    keep[[0, -1]] = True
    t = k[keep] / encoder.sample_rate
    duration = n / encoder.sample_rate
    angle = speed * (t - t**2 / (2 * duration))
    angle += 0.002 * np.sin(2 * angle)
    counts = np.floor(angle / encoder.quantum + rng.uniform(-readhead, readhead, t.size))
    torque = -0.005 + noise * rng.standard_normal(t.size)
    return t, counts * encoder.quantum, torque


def test_a_torque_glitch_is_found_and_named():
    encoder = Encoder()
    t, phi, torque = braking(encoder)
    torque[1234] *= 20
    glitches = find_glitches(Rows("stage1/braking.csv"), t, phi, torque, encoder)
    assert glitches.rows.tolist() == [1234]
    (warning,) = glitches.warnings
    assert warning.startswith("stage1/braking.csv, line 1236: a glitch, torque -0.1")
    assert "N m where its neighbours give -0.00" in warning and "left out" in warning
    np.testing.assert_array_equal(np.flatnonzero(~glitches.keep(t.size)), [1234])


def test_an_angle_glitch_is_found_and_named():
    encoder = Encoder()
    t, phi, torque = braking(encoder)
    phi[2345] += 40 * encoder.quantum
    glitches = find_glitches(Rows("stage1/braking.csv"), t, phi, torque, encoder)
    assert glitches.rows.tolist() == [2345]
    (warning,) = glitches.warnings
    assert warning.startswith("stage1/braking.csv, line 2347: a glitch, phi ")
    assert "(+40 counts)" in warning


def test_an_angle_and_a_torque_off_in_one_row_are_one_glitch():
    encoder = Encoder()
    t, phi, torque = braking(encoder)
    phi[999] -= 40 * encoder.quantum
    torque[999] = 0.3
    (warning,) = find_glitches(Rows("b.csv"), t, phi, torque, encoder).warnings
    assert "phi " in warning and " and torque 0.3 N m" in warning and "(-40 counts)" in warning


@settings(max_examples=25, deadline=None)
@given(
    bits=st.integers(10, 20),
    rate=st.sampled_from([1000.0, 10000.0]),
    speed=st.floats(0.5, 30.0),
    readhead=st.sampled_from([0.0, 2.0]),
    seed=st.integers(0, 2**16),
)
def test_genuine_brakings_have_no_glitch(bits, rate, speed, readhead, seed):
    """Quantized at 10 to 20 bits, at 1 or 10 kHz, jittered by the reader's limit, 2% of the
    rows dropped, with or without +-2 counts of readhead noise: no glitch; the angle's
    statistic, whose errors are bounded (quantization, a uniform readhead noise), stays below
    half its threshold (the torque's Gaussian noise reaches 5 sigma in one row of 10^4 now
    and then, 2 Q(5 / sqrt 2): its threshold is 10)."""
    encoder = Encoder(2**bits, rate)
    t, phi, torque = braking(
        encoder, 4000, speed, seed=seed, jitter=JITTER_LIMIT, dropped=0.02, readhead=readhead
    )
    r, scale = angle_residuals(t, phi, encoder.quantum, rate)
    assert np.max(np.abs(r) / scale) < ANGLE_THRESHOLD / 2
    assert find_glitches(Rows("b.csv"), t, phi, torque, encoder).rows.size == 0


def test_a_torque_step_and_a_held_body_are_no_glitch():
    """A pilot's switch-off (a step of the torque), a hold's own torque, and a held body's
    reading that dithers by up to 30 counts and settles back: no row is isolated."""
    encoder = Encoder()
    t, phi, torque = braking(encoder, n=3000)
    rng = np.random.default_rng(1)
    torque[2000:] = rng.normal(0.0, 1e-4, 1000)  # the motor off
    held = np.arange(2600, 3000)
    phi[held] = phi[2599] + encoder.quantum * (
        rng.integers(-30, 31, held.size) - np.minimum(held - 2599, 5)
    )
    torque[held] = 0.2 + rng.normal(0.0, 1e-4, held.size)  # the drive holding it
    assert find_glitches(Rows("b.csv"), t, phi, torque, encoder).rows.size == 0


def test_a_few_glitches_are_left_out_and_many_refused_naming_the_first_lines():
    encoder = Encoder()
    t, phi, torque = braking(encoder)
    rows = [300, 900, 1500, 2100, 2400, 2700]
    for k in rows[:MAX_GLITCHES]:
        torque[k] = 0.5
    found = find_glitches(Rows("b.csv"), t, phi, torque, encoder)
    assert found.rows.tolist() == rows[:MAX_GLITCHES]
    phi[rows[-1]] += 40 * encoder.quantum
    with pytest.raises(InputError) as error:
        find_glitches(Rows("b.csv"), t, phi, torque, encoder)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(
        f"b.csv, line 302: {len(rows)} rows whose angle or torque disagrees with their "
        "neighbours (line 302, line 902, line 1502, ...): more than 5 glitches"
    )


def test_a_short_log_is_not_searched():
    encoder = Encoder()
    t, phi, torque = braking(encoder, n=MIN_ROWS - 1)
    torque[100] = 1.0
    assert find_glitches(Rows("b.csv"), t, phi, torque, encoder).rows.size == 0


def test_the_reader_leaves_a_glitch_out_and_names_the_file_lines_after_it(tmp_path):
    """The glitch's row is a dropped sample of the log read, its warning in Log.warnings; the
    lines named after it (a braking's rows after its turning point) are the file's."""
    encoder = Encoder()
    t, phi, torque = braking(encoder, n=2000, speed=6.0)
    hold = 200
    t = np.concatenate([t, t[-1] + np.arange(1, hold + 1) / encoder.sample_rate])
    phi = np.concatenate([phi, np.full(hold, phi[-1])])
    torque = np.concatenate([torque, np.full(hold, -0.005)])
    path = tmp_path / "braking.csv"
    write_log(path, Log(t=t, phi=phi, torque=torque))
    clean = read_log(path, encoder, "braking", torque_limit=0.5)
    torque[500] = -0.1
    write_log(path, Log(t=t, phi=phi, torque=torque))
    log = read_log(path, encoder, "braking", torque_limit=0.5)
    assert len(log) == len(clean) - 1 and not np.any(log.torque == -0.1)
    np.testing.assert_array_equal(log.t, np.delete(clean.t, 500))
    (warning,) = log.warnings
    assert warning.startswith(f"{path}, line 502: a glitch, torque -0.1 N m")
    assert log.notes == clean.notes and f"turning point at line {len(clean) + 1} " in log.notes[0]
    # The log knows where its rows are: later messages (a speed that reverses, a gap near a
    # node) name the file's lines past the glitch through Log.where.
    assert log.where.at(499) == f"{path}, line 501" and log.where.at(500) == f"{path}, line 503"
    assert clean.where.at(500) == f"{path}, line 502"
    phi = log.phi.copy()
    phi[1200:] -= 100 * encoder.quantum  # the reading goes back at array row 1200
    back = dataclasses.replace(log, phi=phi)
    with pytest.raises(InputError, match=rf"line {1200 + 3}: the angle decreases"):
        check_braking_monotone(back, str(path))


@pytest.mark.parametrize("column", ["phi", "torque"])
def test_an_isolated_row_no_drive_makes_is_a_glitch_left_out(tmp_path, column):
    """A single row 3.1 rad off its neighbours (3100 rad/s), or of 1000 N m on a 0.5 N m
    motor, is a corrupted row: left out like any glitch, whatever the device's bounds (a
    counter that skips from a row on, a torque's scale error, are still refused)."""
    encoder = Encoder(2**13)
    t, phi, torque = braking(encoder, n=600)
    if column == "phi":
        phi[300] += round(3.1 / encoder.quantum) * encoder.quantum
    else:
        torque[300] = 1000.0
    path = tmp_path / "braking.csv"
    write_log(path, Log(t=t, phi=phi, torque=torque))
    log = read_log(path, encoder, "braking", torque_limit=0.5, launch_speed=12.0)
    assert len(log) == 599
    (warning,) = log.warnings
    assert warning.startswith(f"{path}, line 302: a glitch, {column} ")
    write_log(path, Log(t=t, phi=phi, torque=1000 * torque))
    with pytest.raises(InputError, match="beyond what the drive can produce"):
        read_log(path, encoder, "braking", torque_limit=0.5)
