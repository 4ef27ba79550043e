"""Parsing and checking the CSV files of logs and programs (docs/files.md).

:mod:`rsp_inertia.plant.logs` reads through these functions: a table with exactly the
expected header and finite numbers, time stamps from 0 at the encoder's sample rate (a log's
within :data:`JITTER_LIMIT` of its grid, a program's regular), angles on the encoder grid, the
direction of a pass, integer counts of a wrapping counter unwrapped. Every fault is one
:class:`~rsp_inertia.plant.errors.InputError` line naming the file and the line (1-based
lines of the file, the header being line 1).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Protocol

import numpy as np

from rsp_inertia.plant.errors import InputError

__all__ = [
    "GRID_TOLERANCE",
    "JITTER_LIMIT",
    "MEAN_RATE_TOLERANCE",
    "RATE_TOLERANCE",
    "T0_TOLERANCE",
    "EncoderLike",
    "check_direction",
    "check_grid",
    "check_time",
    "read_header",
    "read_table",
    "unwrap_counts",
]

T0_TOLERANCE = 1e-9
"""s, how far from 0 the first time stamp may be."""

RATE_TOLERANCE = 1e-3
"""Relative tolerance on every time step of a program against 1 / sample_rate."""

JITTER_LIMIT = 0.25
"""Fraction of a sample period by which a log's time stamp may be off the regular grid.

A log's time stamps are the instants at which the drive read the encoder and set the torque
(the torque of row k acts over [t_k, t_k+1)); they need not be regular. With every stamp
within +-JITTER_LIMIT of a period of its grid instant, a step of one sample lies between
1 - 2 JITTER_LIMIT = 0.5 and 1.5 periods, and a step of about n periods (n >= 2) is a gap of
n - 1 samples the logger dropped (:func:`rsp_inertia.plant.logs.dropped_samples`). A step
shorter than half a period is refused (a repeated row, or a sample rate that is not
device.toml's)."""

MEAN_RATE_TOLERANCE = 0.01
"""Relative tolerance on a log's mean sample period (its duration over the periods its steps
count, dropped samples included) against 1 / sample_rate; jitter moves it by at most
2 JITTER_LIMIT / periods."""

GRID_TOLERANCE = 1e-3
"""Counts, how far phi / q may be from a whole number."""


class EncoderLike(Protocol):
    """What the readers need of an encoder (``rsp_inertia.plant.config.Encoder`` has it)."""

    @property
    def quantum(self) -> float:
        """rad, q = 2 pi / counts_per_rev."""
        ...

    @property
    def sample_rate(self) -> float:
        """Hz."""
        ...


def read_table(path: str | os.PathLike, columns: Sequence[str]) -> np.ndarray:
    """Parse a CSV with exactly ``columns`` as header into an (n, len(columns)) float array.

    Line numbers in messages are 1-based lines of the file (the header is line 1).
    """
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not a UTF-8 text file (byte {exc.start})") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror or exc})") from None

    lines = text.split("\n")
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines:
        raise InputError(f"{path}: the file is empty, expected a header {','.join(columns)!r}")

    header = [name.strip() for name in lines[0].split(",")]
    if header != list(columns):
        found = lines[0].strip()
        shown = repr(found) if len(found) <= 80 else repr(found[:77]) + "..."
        raise InputError(f"{path}, line 1: header is {shown}, expected {','.join(columns)!r}")

    ncol = len(columns)
    fields_flat: list[str] = []
    for number, line in enumerate(lines[1:], start=2):
        row = line.split(",")
        if len(row) != ncol:
            if not line.strip():
                raise InputError(f"{path}, line {number}: blank line inside the data")
            raise InputError(
                f"{path}, line {number}: {len(row)} fields, expected {ncol} ({','.join(columns)})"
            )
        fields_flat.extend(row)
    try:
        values = np.array([float(field) for field in fields_flat], dtype=np.float64)
    except ValueError:
        for index, field in enumerate(fields_flat):
            try:
                float(field)
            except ValueError:
                row_index, col = divmod(index, ncol)
                shown = repr(field.strip())
                raise InputError(
                    f"{path}, line {row_index + 2}: {columns[col]} = {shown} is not a number"
                ) from None
        raise  # float() failed once but not on any single field: cannot happen
    values = values.reshape(-1, ncol)

    bad = ~np.isfinite(values)
    if bad.any():
        row_index, col = np.argwhere(bad)[0]
        raise InputError(
            f"{path}, line {row_index + 2}: {columns[col]} = {float(values[row_index, col])!r} "
            "is not finite"
        )
    if len(values) < 2:
        raise InputError(f"{path}: {len(values)} data row(s), at least 2 are needed")
    return values


def check_time(
    path: str | os.PathLike, t: np.ndarray, encoder: EncoderLike, regular: bool = True
) -> None:
    """t from 0, strictly increasing; ``regular``: one step per encoder sample (a program),
    else a log's sampling instants (:data:`JITTER_LIMIT`: jitter and dropped samples)."""
    if abs(t[0]) > T0_TOLERANCE:
        raise InputError(f"{path}, line 2: t = {float(t[0])!r} s, the first row must be at t = 0")
    steps = np.diff(t)
    not_increasing = np.flatnonzero(steps <= 0.0)
    if not_increasing.size:
        k = not_increasing[0]
        now, before = float(t[k + 1]), float(t[k])
        raise InputError(
            f"{path}, line {k + 3}: t = {now!r} s is not after t = {before!r} s of the row before; "
            "t must be strictly increasing"
        )
    rate = float(encoder.sample_rate)
    if not regular:
        median = float(np.median(steps))
        if median * rate >= 1.0 + 2 * JITTER_LIMIT:
            raise InputError(
                f"{path}: median time step {median:.6g} s, expected {1.0 / rate:.6g} s "
                f"(encoder sample rate {rate:g} Hz)"
            )
        short = np.flatnonzero(steps * rate < 1.0 - 2 * JITTER_LIMIT)
        if short.size:
            k = short[0]
            raise InputError(
                f"{path}, line {k + 3}: time step {steps[k]:.6g} s at t = {float(t[k + 1])!r} s "
                f"is less than half the sample period {1.0 / rate:.6g} s (time stamps may be "
                f"off the sampling grid by at most {JITTER_LIMIT:g} of a period)"
            )
        periods = int(np.rint(steps * rate).sum())
        mean = float(t[-1] - t[0]) / periods
        if abs(mean * rate - 1.0) > MEAN_RATE_TOLERANCE:
            raise InputError(
                f"{path}: mean sample period {mean:.6g} s over {periods} periods, expected "
                f"{1.0 / rate:.6g} s (encoder sample rate {rate:g} Hz)"
            )
        return
    off_rate = np.flatnonzero(np.abs(steps * rate - 1.0) > RATE_TOLERANCE)
    if off_rate.size:
        k = off_rate[0]
        raise InputError(
            f"{path}, line {k + 3}: time step {steps[k]:.6g} s, expected {1.0 / rate:.6g} s "
            f"(encoder sample rate {rate:g} Hz)"
        )


def read_header(path: str | os.PathLike) -> list[str] | None:
    """The first line's column names, or None if the file cannot be read (the full reader
    then says why)."""
    try:
        with open(path, encoding="utf-8-sig") as file:
            return [name.strip() for name in file.readline().split(",")]
    except (OSError, UnicodeDecodeError):
        return None


def unwrap_counts(path: str | os.PathLike, counts: np.ndarray, encoder: EncoderLike):
    """Integer counts, a counter of ``encoder.counter_bits`` unwrapped (float array).

    A step between two samples is taken modulo 2**bits into [-2**(bits-1), 2**(bits-1)): a
    counter wraps, the body does not turn half a counter's range in one sample. Where the
    counter stood before the log began is unknown by whole wraps, so counts_per_rev must
    divide 2**bits for the angle modulo a turn (the nodes) to be defined.
    """
    bad = np.flatnonzero(counts != np.round(counts))
    if bad.size:
        k = int(bad[0])
        raise InputError(f"{path}, line {k + 2}: counts = {float(counts[k])!r} is not an integer")
    bits = getattr(encoder, "counter_bits", None)
    if bits is None:
        return counts
    span = 2**bits
    if span % int(encoder.counts_per_rev):
        raise InputError(
            f"{path}: counts wrap at 2^{bits} (device.toml encoder.counter_bits), which is not "
            f"a whole number of turns of {encoder.counts_per_rev} counts: the angle is undefined"
        )
    out_of_range = np.flatnonzero((counts < 0) | (counts >= span))
    if out_of_range.size:
        k = int(out_of_range[0])
        raise InputError(
            f"{path}, line {k + 2}: counts = {counts[k]:.0f} is outside the {bits}-bit counter "
            f"(0 to {span - 1})"
        )
    step = np.mod(np.diff(counts) + span // 2, span) - span // 2
    return counts[0] + np.concatenate([[0.0], np.cumsum(step)])


def check_grid(path: str | os.PathLike, phi: np.ndarray, encoder: EncoderLike) -> None:
    """phi a whole number of encoder counts."""
    q = float(encoder.quantum)
    counts = phi / q
    off_grid = np.flatnonzero(np.abs(counts - np.round(counts)) > GRID_TOLERANCE)
    if off_grid.size:
        k = off_grid[0]
        value = float(phi[k])
        raise InputError(
            f"{path}, line {k + 2}: phi = {value!r} is not on the encoder grid (q = {q:.4g} rad)"
        )


def check_direction(path: str | os.PathLike, phi: np.ndarray, kind: str, direction: str) -> None:
    """A forward braking runs up from the release to rest and its reverse pass back down; a
    backward run is the other way round."""
    if kind not in ("braking", "reverse"):
        return
    last_line = len(phi) + 1
    increases = (kind == "braking") == (direction == "forward")
    if (phi[-1] > phi[0]) if increases else (phi[-1] < phi[0]):
        return
    run = "a braking" if kind == "braking" else "a reverse"
    if direction == "backward":
        run = f"a backward {kind}"
    end = "larger" if increases else "smaller"
    why = ""
    if direction == "backward":
        moves = "increases" if increases else "decreases"
        why = f" (phi {moves} during a backward {kind})"
    raise InputError(
        f"{path}, line {last_line}: {run} log must end at a {end} phi than it starts{why}, "
        f"but phi goes from {float(phi[0])!r} to {float(phi[-1])!r} rad"
    )
