"""Encoder logs and torque programs: the CSV files of INTERFACES.md ("Logs", "program.csv").

A braking or reverse pass is logged as ``t,phi,torque`` (a :class:`Log`); the torque program of
a reverse pass is ``t,phi_ref,omega_ref,torque_ff,k_phi,k_omega`` (a :class:`Program`).
Reading checks everything the rest of the package relies on (finite numbers, t from 0 at the
encoder's sample rate, phi on the encoder grid, the direction of the pass) and turns every
fault into one :class:`~rsp_inertia.plant.errors.InputError` line naming the file and the line.
Writing is exact (``repr`` round-trips every float64), deterministic and atomic.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Protocol

import numpy as np

from rsp_inertia.plant.config import DIRECTIONS
from rsp_inertia.plant.errors import InputError

LOG_COLUMNS = ("t", "phi", "torque")
"""Header of braking.csv and reverse.csv."""

COUNT_COLUMNS = ("t", "counts", "torque")
"""A drive logger's alternative header: integer encoder counts instead of phi in rad."""

PROGRAM_COLUMNS = ("t", "phi_ref", "omega_ref", "torque_ff", "k_phi", "k_omega")
"""Header of program.csv."""

LOG_KINDS = ("braking", "reverse", "pendulum", "pilot")
"""The two passes of a stage (METHOD.md §4), and the torsion-pendulum baseline runs."""

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
n - 1 samples the logger dropped (:func:`dropped_samples`). A step shorter than half a
period is refused (a repeated row, or a sample rate that is not device.toml's)."""

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


def _frozen_array(value: object, name: str) -> np.ndarray:
    array = np.array(value, dtype=np.float64, copy=True)
    if array.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {array.shape}")
    array.flags.writeable = False
    return array


def _freeze_columns(obj: object) -> None:
    """Store every field of a frozen dataclass as a read-only float64 copy; equal lengths."""
    names = [f.name for f in fields(obj)]
    for name in names:
        object.__setattr__(obj, name, _frozen_array(getattr(obj, name), name))
    lengths = {name: len(getattr(obj, name)) for name in names}
    if len(set(lengths.values())) != 1:
        raise ValueError(f"columns of unequal length: {lengths}")


@dataclass(frozen=True, eq=False)
class Log:
    """Encoder/torque log of one pass (braking.csv or reverse.csv).

    Row k pairs the encoder reading at ``t[k]`` with the torque held over ``[t[k], t[k+1])``
    (zero-order hold, METHOD.md §4). Arrays are read-only float64 copies. Compare logs with
    ``np.array_equal`` on the fields: ``==`` is identity.
    """

    t: np.ndarray  # s, shape (n,)
    """Time from 0, strictly increasing: the drive's sampling instants, about one per period
    of the encoder's sample rate (jitter and dropped samples: :data:`JITTER_LIMIT`)."""
    phi: np.ndarray  # rad, shape (n,)
    """Encoder angle, unwrapped, a whole multiple of q = 2 pi / counts_per_rev."""
    torque: np.ndarray  # N m, shape (n,)
    """Motor torque reduced to phi as logged; row k acts over [t_k, t_k+1)."""

    def __post_init__(self) -> None:
        _freeze_columns(self)

    def __len__(self) -> int:
        return len(self.t)

    def motor_work(self) -> np.ndarray:
        """Cumulative motor work along the log, the Stieltjes sum of u over phi (METHOD.md §3-4).

        Returns
        -------
        W : np.ndarray, shape (n,), J
            ``W[0] = 0`` and ``W[k] = sum_{j<k} torque[j] (phi[j+1] - phi[j])``; the work
            between rows a and b is ``W[b] - W[a]``. The last row's torque acts after the
            last encoder reading and so adds nothing.

        Examples
        --------
        >>> Log(t=[0.0, 0.001, 0.002], phi=[0.0, 0.5, 1.5], torque=[2.0, -1.0, 7.0]).motor_work()
        array([0., 1., 0.])
        """
        work = np.zeros(len(self))
        np.cumsum(self.torque[:-1] * np.diff(self.phi), out=work[1:])
        return work


@dataclass(frozen=True, eq=False)
class Program:
    """Torque program of a reverse pass (program.csv).

    Every sample the device applies ``u = torque_ff - k_phi (phi - phi_ref)
    - k_omega (omega - omega_ref)``, clipped to its torque limit and held over
    ``[t[k], t[k+1])`` (INTERFACES.md, "program.csv"). Arrays are read-only float64 copies.
    """

    t: np.ndarray  # s, shape (n,)
    """Time from 0 at the start of the reverse motion, at the encoder's sample rate."""
    phi_ref: np.ndarray  # rad, shape (n,)
    """Reference angle."""
    omega_ref: np.ndarray  # rad/s, shape (n,)
    """Reference speed."""
    torque_ff: np.ndarray  # N m, shape (n,)
    """Feed-forward torque."""
    k_phi: np.ndarray  # N m/rad, shape (n,)
    """Angle gain of the regulator."""
    k_omega: np.ndarray  # N m s/rad, shape (n,)
    """Speed gain of the regulator."""

    def __post_init__(self) -> None:
        _freeze_columns(self)


# ---------------------------------------------------------------------------------------------
# Reading


def _read_table(path: str | os.PathLike, columns: Sequence[str]) -> np.ndarray:
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


def _check_time(
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


def dropped_samples(t: np.ndarray, sample_rate: float) -> np.ndarray:
    """Samples missing after each row of a log: round(step x sample_rate) - 1 (see
    :data:`JITTER_LIMIT`), 0 where the step is a single jittered period.

    Parameters
    ----------
    t : np.ndarray, shape (n,), s
        The log's time stamps, strictly increasing.
    sample_rate : float
        Hz, the encoder's.

    Returns
    -------
    np.ndarray, shape (n - 1,), int
        Entry k counts the samples dropped between rows k and k + 1.

    Examples
    --------
    >>> dropped_samples(np.array([0.0, 0.0011, 0.0019, 0.0041]), 1000.0)
    array([0, 0, 1])
    """
    return np.maximum(np.rint(np.diff(t) * sample_rate).astype(np.int64) - 1, 0)


def _header(path: str | os.PathLike) -> list[str] | None:
    """The first line's column names, or None if the file cannot be read (the full reader
    then says why)."""
    try:
        with open(path, encoding="utf-8-sig") as file:
            return [name.strip() for name in file.readline().split(",")]
    except (OSError, UnicodeDecodeError):
        return None


def _unwrap_counts(path: str | os.PathLike, counts: np.ndarray, encoder: EncoderLike):
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


def align_counter(log: Log, phi: float, encoder: EncoderLike) -> Log:
    """``log`` moved by whole ranges of a wrapping counter (``encoder.counter_bits``) so that
    it starts nearest ``phi``: two logs of one counter (a braking and its reverse, which
    starts where the braking stopped) then share one angle. Unchanged without a counter."""
    bits = getattr(encoder, "counter_bits", None)
    if bits is None:
        return log
    span = 2**bits * float(encoder.quantum)
    wraps = round((phi - float(log.phi[0])) / span)
    if wraps == 0:
        return log
    return Log(t=log.t, phi=log.phi + wraps * span, torque=log.torque)


def _check_grid(path: str | os.PathLike, phi: np.ndarray, encoder: EncoderLike) -> None:
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


def _check_direction(path: str | os.PathLike, phi: np.ndarray, kind: str, direction: str) -> None:
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


def read_log(
    path: str | os.PathLike, encoder: EncoderLike, kind: str, direction: str = "forward"
) -> Log:
    """Read and check braking.csv or reverse.csv.

    Parameters
    ----------
    path : str or path-like
        The CSV file, header ``t,phi,torque``, or ``t,counts,torque`` with integer encoder
        counts (phi = counts x quantum), unwrapped when the encoder has ``counter_bits`` (a
        counter that wraps at 2**counter_bits). A counter's position before the log began is
        known only modulo its range: with a torsion spring, whose potential depends on the
        absolute angle, its zero must be the spring's reference.
    encoder : encoder-like
        Anything with ``quantum`` (rad, 2 pi / counts_per_rev) and ``sample_rate`` (Hz), such
        as ``rsp_inertia.plant.config.Encoder``; ``counts_per_rev`` and ``counter_bits`` for counts.
    kind : {"braking", "reverse", "pendulum"}
        Which pass: a forward braking must end at a larger phi than it starts, its reverse at
        a smaller one; a pendulum run may go either way.
    direction : {"forward", "backward"}
        The direction of the stage's run (``rsp_inertia.plant.config.DIRECTIONS``): a backward braking
        must end at a smaller phi than it starts, its reverse at a larger one. Pendulum runs
        ignore it.

    Returns
    -------
    Log
        The values exactly as written in the file.

    Raises
    ------
    InputError
        One line naming the file, the line and the fault: a missing or empty file, a wrong
        header, a malformed or non-finite number, fewer than 2 rows, t not from 0, not strictly
        increasing, a step shorter than half a sample period, a median or mean step off the
        sample rate (:data:`JITTER_LIMIT`), phi off the encoder grid, the wrong direction.
    """
    if kind not in LOG_KINDS:
        raise ValueError(f"kind must be one of {LOG_KINDS}, got {kind!r}")
    if direction not in DIRECTIONS:
        raise ValueError(f"direction must be one of {DIRECTIONS}, got {direction!r}")
    if _header(path) == list(COUNT_COLUMNS):
        t, counts, torque = _read_table(path, COUNT_COLUMNS).T
        phi = _unwrap_counts(path, counts, encoder) * float(encoder.quantum)
    else:
        t, phi, torque = _read_table(path, LOG_COLUMNS).T
    _check_time(path, t, encoder, regular=False)
    _check_grid(path, phi, encoder)
    _check_direction(path, phi, kind, direction)
    return Log(t=t, phi=phi, torque=torque)


def read_program(path: str | os.PathLike, encoder: EncoderLike) -> Program:
    """Read and check program.csv.

    Parameters
    ----------
    path : str or path-like
        The CSV file, header ``t,phi_ref,omega_ref,torque_ff,k_phi,k_omega``.
    encoder : encoder-like
        Anything with ``sample_rate`` (Hz) and ``quantum`` (rad), such as
        ``rsp_inertia.plant.config.Encoder``; the program runs at the encoder's sample rate.

    Returns
    -------
    Program
        The values exactly as written in the file.

    Raises
    ------
    InputError
        One line naming the file, the line and the fault: a missing or empty file, a wrong
        header, a malformed or non-finite number, fewer than 2 rows, t not from 0, not strictly
        increasing or not at the sample rate.
    """
    values = _read_table(path, PROGRAM_COLUMNS)
    _check_time(path, values[:, 0], encoder)
    return Program(*values.T)


# ---------------------------------------------------------------------------------------------
# Writing


def _format_table(columns: Sequence[str], arrays: Sequence[np.ndarray]) -> str:
    """CSV text, every number as its shortest exact ``repr``; '\\n' line endings."""
    for name, array in zip(columns, arrays, strict=True):
        if not np.all(np.isfinite(array)):
            raise ValueError(f"column {name} holds non-finite values; the file could not be read")
    rows = zip(*(array.tolist() for array in arrays), strict=True)
    lines = [",".join(columns)]
    lines.extend(",".join(map(repr, row)) for row in rows)
    return "\n".join(lines) + "\n"


def write_log(path: str | os.PathLike, log: Log, counter: EncoderLike | None = None) -> None:
    """Write a log as braking.csv / reverse.csv (header ``t,phi,torque``), atomically.

    Numbers are written as Python ``repr``, so :func:`read_log` returns exactly these values
    and the same log always gives a byte-identical file.

    Parameters
    ----------
    path : str or path-like
        Target file; its folder must exist.
    log : Log
        Finite values (else ValueError).
    counter : encoder-like, optional
        Write ``t,counts,torque`` instead, as a drive's position counter of
        ``counter.counter_bits`` bits gives them: counts = phi / quantum modulo
        2**counter_bits (phi must be on the encoder grid). :func:`read_log` unwraps them to
        phi up to whole ranges of the counter.
    """
    if counter is None:
        write_atomic(path, _format_table(LOG_COLUMNS, [log.t, log.phi, log.torque]))
        return
    bits = getattr(counter, "counter_bits", None)
    if bits is None:
        raise ValueError("a counts log needs an encoder with counter_bits")
    counts = np.rint(log.phi / float(counter.quantum)).astype(np.int64) % (2**bits)
    rows = zip(log.t.tolist(), counts.tolist(), log.torque.tolist(), strict=True)
    lines = [",".join(COUNT_COLUMNS)]
    lines.extend(f"{t!r},{c},{u!r}" for t, c, u in rows)
    write_atomic(path, "\n".join(lines) + "\n")


def write_program(path: str | os.PathLike, program: Program) -> None:
    """Write a torque program as program.csv, atomically, exactly and deterministically.

    Parameters
    ----------
    path : str or path-like
        Target file; its folder must exist.
    program : Program
        Finite values (else ValueError).
    """
    arrays = [getattr(program, name) for name in PROGRAM_COLUMNS]
    write_atomic(path, _format_table(PROGRAM_COLUMNS, arrays))


def write_atomic(path: str | os.PathLike, text: str) -> None:
    """Replace ``path`` by a file holding ``text`` (UTF-8, newlines as given), all or nothing.

    The text goes to a temporary file in the same folder, is flushed to disk and renamed over
    ``path`` with ``os.replace``; a reader sees the old file or the new one, never a part. If
    anything fails, the temporary file is removed and ``path`` is left as it was.

    Parameters
    ----------
    path : str or path-like
        Target file; its folder must exist.
    text : str
        The whole content.
    """
    target = Path(path)
    temp = target.with_name(f".{target.name}.{secrets.token_hex(6)}.tmp")
    # os.open with mode 0o666 lets the umask decide the permissions, as for a plain open().
    fd = os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as file:
            file.write(text)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temp, target)
    except BaseException:
        temp.unlink(missing_ok=True)
        raise
