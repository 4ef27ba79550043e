"""Encoder logs and torque programs: the CSV files of docs/files.md (logs, program.csv).

A pass is logged as ``t,phi,torque`` (a :class:`Log`), or ``t,counts,torque`` by a drive that
logs its position counter; the torque program of a reverse pass is
``t,phi_ref,omega_ref,torque_ff,k_phi,k_omega`` (a :class:`Program`). Reading checks
everything the rest of the package relies on (:mod:`rsp_inertia.plant.log_checks`: finite
numbers, t from 0 at the encoder's sample rate, phi on the encoder grid, the direction of the
pass), leaves out isolated corrupted rows (:mod:`rsp_inertia.plant.log_glitches`) and turns
every fault into one :class:`~rsp_inertia.infra.errors.InputError` line naming the file and
the line. Writing is exact (``repr`` round-trips every float64),
deterministic and atomic.

``JITTER_LIMIT`` and ``EncoderLike`` are defined in :mod:`rsp_inertia.plant.log_checks` and
exposed here too: they describe the logs this module reads.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import write_atomic
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.log_checks import (
    JITTER_LIMIT,
    EncoderLike,
    Rows,
    as_rows,
    check_direction,
    check_grid,
    check_speed,
    check_time,
    check_torque,
    read_table,
    turning_point,
)
from rsp_inertia.plant.log_files import read_log_columns, write_log_file
from rsp_inertia.plant.log_glitches import find_glitches
from rsp_inertia.plant.log_layout import LogLayout
from rsp_inertia.plant.transducers import (
    magnet_temperature,
    power_flow_split,
    thermal_torque_factor,
)

__all__ = [
    "COUNT_COLUMNS",
    "JITTER_LIMIT",
    "LOG_COLUMNS",
    "LOG_KINDS",
    "PROGRAM_COLUMNS",
    "EncoderLike",
    "Log",
    "Program",
    "align_counter",
    "check_braking_monotone",
    "compensate_temperature",
    "dropped_samples",
    "mirror_log",
    "mirrored_device",
    "motor_work",
    "read_device_log",
    "read_log",
    "read_program",
    "reverse_start_lag",
    "switch_row",
    "torque_noise",
    "write_log",
    "write_program",
]

LOG_COLUMNS = ("t", "phi", "torque")
"""Header of braking.csv and reverse.csv."""

COUNT_COLUMNS = ("t", "counts", "torque")
"""A drive logger's alternative header: integer encoder counts instead of phi in rad."""

PROGRAM_COLUMNS = ("t", "phi_ref", "omega_ref", "torque_ff", "k_phi", "k_omega")
"""Header of program.csv."""

LOG_KINDS = ("braking", "reverse", "pendulum", "pilot")
"""The two passes of a stage (docs/method.md §4), the torsion-pendulum runs and the pilot run."""


def _frozen_array(value: object, name: str) -> np.ndarray:
    array = np.array(value, dtype=np.float64, copy=True)
    if array.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {array.shape}")
    array.flags.writeable = False
    return array


def _freeze_columns(obj: object, names: Sequence[str]) -> None:
    """Store the fields ``names`` of a frozen dataclass as read-only float64 copies; equal
    lengths."""
    for name in names:
        object.__setattr__(obj, name, _frozen_array(getattr(obj, name), name))
    lengths = {name: len(getattr(obj, name)) for name in names}
    if len(set(lengths.values())) != 1:
        raise ValueError(f"columns of unequal length: {lengths}")


@dataclass(frozen=True, eq=False)
class Log:
    """Encoder/torque log of one pass (braking.csv or reverse.csv).

    Row k pairs the encoder reading at ``t[k]`` with the torque held over ``[t[k], t[k+1])``
    (zero-order hold, docs/method.md §4). Arrays are read-only float64 copies. Compare logs with
    ``np.array_equal`` on the fields: ``==`` is identity.
    """

    t: np.ndarray  # s, shape (n,)
    """Time from 0, strictly increasing: the drive's sampling instants, about one per period
    of the encoder's sample rate (jitter and dropped samples: :data:`JITTER_LIMIT`)."""
    phi: np.ndarray  # rad, shape (n,)
    """Encoder angle, unwrapped, a whole multiple of q = 2 pi / counts_per_rev."""
    torque: np.ndarray  # N m, shape (n,)
    """Motor torque reduced to phi as logged; row k acts over [t_k, t_k+1)."""
    notes: tuple[str, ...] = ()
    """What the reader did to the file's rows, one line each naming the file and the lines:
    a braking's rows after its turning point left out (:func:`read_log`). The commands that
    read the log say them (program, identify and calibrate as warnings, check as ok lines);
    :func:`mirror_log` and :func:`align_counter` keep them."""
    temperature: np.ndarray | None = None  # degrees C, shape (n,)
    """The motor's temperature at each row, when the logger logs it (device.toml ``[log]
    temperature_column``); None when it does not. ``dataclasses.replace`` keeps it; code that
    takes some rows of a log takes the same rows of it."""
    warnings: tuple[str, ...] = ()
    """What the reader left out because it looked wrong, one line each naming the file and
    the line: a glitch, a row whose angle or torque disagrees with its neighbours
    (rsp_inertia.plant.log_glitches), left out as a dropped sample. The commands that read
    the log say them as warnings (check: suspicious); :func:`mirror_log` and
    :func:`align_counter` keep them."""
    torque_factor: np.ndarray | None = None  # shape (n,)
    """The factor :func:`compensate_temperature` multiplied each row's logged torque by (the
    torque constant's at the magnets' temperature over its reference's); None: the torque as
    logged. A braking's protocol holds its logged torque constant: its constancy test and
    mean take the torque over this factor (rsp_inertia.estimation.passes.estimate_pass)."""
    where: Rows | None = None
    """Where its rows are in its file, for messages: the file, the line (or row) of row 0 and
    the rows the reader left out (glitches), so that ``where.at(k)`` names row k's line
    (:func:`read_log`); None for a log not read from a file. Taking rows off its end keeps it
    right; a message about a log made otherwise names its file alone."""

    def __post_init__(self) -> None:
        names = LOG_COLUMNS if self.temperature is None else (*LOG_COLUMNS, "temperature")
        if self.torque_factor is not None:
            names = (*names, "torque_factor")
        _freeze_columns(self, names)
        object.__setattr__(self, "notes", tuple(self.notes))
        object.__setattr__(self, "warnings", tuple(self.warnings))

    def rows(self, keep: slice | np.ndarray) -> Log:
        """The log's rows ``keep`` (a slice, a boolean mask or indices) of every column, the
        temperature's too; the notes kept."""
        temperature = None if self.temperature is None else self.temperature[keep]
        factor = None if self.torque_factor is None else self.torque_factor[keep]
        return dataclasses.replace(
            self,
            t=self.t[keep],
            phi=self.phi[keep],
            torque=self.torque[keep],
            temperature=temperature,
            torque_factor=factor,
        )

    def __len__(self) -> int:
        return len(self.t)

    def motor_work(self) -> np.ndarray:
        """Cumulative motor work along the log, the Stieltjes sum of u over the logged phi
        (docs/method.md §3-4): :func:`motor_work` of this log's torque and angle.

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
        return motor_work(self.torque, self.phi)[0]


@dataclass(frozen=True, eq=False)
class Program:
    """Torque program of a reverse pass (program.csv).

    Every sample the device applies ``u = torque_ff - k_phi (phi - phi_ref)
    - k_omega (omega - omega_ref)``, clipped to its torque limit and held over
    ``[t[k], t[k+1])`` (docs/files.md, program.csv). Arrays are read-only float64 copies.
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
        _freeze_columns(self, PROGRAM_COLUMNS)


# ---------------------------------------------------------------------------------------------
# Reading


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
    periods = np.diff(t)
    periods *= sample_rate  # in place: a log's length of floats and of integers, no more
    np.rint(periods, out=periods)
    missing = periods.astype(np.int64)
    del periods
    missing -= 1
    return np.maximum(missing, 0, out=missing)


def align_counter(log: Log, phi: float, encoder: EncoderLike) -> Log:
    """``log`` moved by whole ranges of a wrapping counter so that it starts nearest ``phi``:
    two logs of one counter (a braking and its reverse, which starts where the braking
    stopped) then share one angle.

    Parameters
    ----------
    log : Log
        A log read from counts (:func:`read_log`).
    phi : float
        rad, the angle it should start nearest (the braking's last, for its reverse).
    encoder : encoder-like
        Its ``counter_bits`` (the counter wraps at 2**counter_bits) and ``quantum``.

    Returns
    -------
    Log
        The log moved by whole ranges; ``log`` itself without a counter or when no move is
        needed.
    """
    bits = getattr(encoder, "counter_bits", None)
    if bits is None:
        return log
    span = 2**bits * float(encoder.quantum)
    wraps = round((phi - float(log.phi[0])) / span)
    if wraps == 0:
        return log
    return dataclasses.replace(log, phi=log.phi + wraps * span)


def read_log(
    path: str | os.PathLike,
    encoder: EncoderLike,
    kind: str,
    direction: Direction = Direction.FORWARD,
    torque_limit: float | None = None,
    launch_speed: float | None = None,
    layout: LogLayout | None = None,
    torque_constant: float | None = None,
) -> Log:
    """Read and check a log: braking, reverse, a pendulum run's or a pilot's.

    Parameters
    ----------
    path : str or path-like
        The file, in ``layout`` (docs/files.md, Logs). By default a CSV with header
        ``t,phi,torque``, or ``t,counts,torque`` with integer encoder counts (phi = counts x
        quantum), unwrapped when the encoder has ``counter_bits`` (a counter that wraps at
        2**counter_bits). A counter's position before the log began is known only modulo
        its range: with a torsion spring, whose potential depends on the absolute angle, its
        zero must be the spring's reference.
    encoder : encoder-like
        Anything with ``quantum`` (rad, 2 pi / counts_per_rev) and ``sample_rate`` (Hz), such
        as ``rsp_inertia.plant.config.Encoder``; ``counts_per_rev`` and ``counter_bits`` for
        counts.
    kind : {"braking", "reverse", "pendulum", "pilot"}
        Which run (``LOG_KINDS``): a forward braking must end at a larger phi than it starts,
        its reverse at a smaller one; a pendulum or pilot run may go either way. A braking
        is cut at its turning point when the drive logged on after the stop
        (rsp_inertia.plant.log_checks.turning_point), which its ``notes`` say.
    direction : Direction
        The direction of the stage's run: a backward braking must end at a smaller phi than
        it starts, its reverse at a larger one. Pendulum and pilot runs ignore it.
    torque_limit : float, optional
        N m, device.toml's ``motor.torque_limit``: a torque beyond
        rsp_inertia.plant.log_checks.TORQUE_MARGIN times it is refused (physically
        impossible); None: not checked.
    launch_speed : float, optional
        rad/s, the fastest ``stage.launch_speed`` of device.toml: a step of the angle faster
        than rsp_inertia.plant.log_checks.SPEED_MARGIN times it (over the step's time, plus
        a few counts) is refused (physically impossible: a corrupted row); None: not checked.
    layout : LogLayout, optional
        device.toml ``[log]``: the file's format, columns and units
        (rsp_inertia.plant.log_files.read_log_columns); None: the default, CSV
        ``t,phi,torque`` or ``t,counts,torque``.
    torque_constant : float, optional
        N m/A, device.toml ``motor.torque_constant``, for a layout that logs the current.

    Returns
    -------
    Log
        The values as written in the file, in s, rad and N m (units converted; an angle in
        degrees put on the encoder grid); a braking's only up to its turning point, with a
        note naming the rows left out (:attr:`Log.notes`); without its glitches, rows whose
        angle or torque disagrees with their neighbours
        (rsp_inertia.plant.log_glitches.find_glitches, after the time stamps, the grid and the
        counter are checked and before anything reads the motion), each left out as a
        dropped sample with a warning naming its line (:attr:`Log.warnings`).

    Raises
    ------
    InputError
        One line naming the file, the line (or row) and the fault: a missing or empty file,
        a column not found (naming the [log] key), a malformed or non-finite number, fewer
        than 2 rows, t not from 0, not strictly increasing, a step shorter than half a
        sample period, a median or mean step off the sample rate (:data:`JITTER_LIMIT`), phi
        off the encoder grid, more than rsp_inertia.plant.log_glitches.MAX_GLITCHES
        glitches, an angle step or a torque beyond what the device can do (with
        ``launch_speed``, ``torque_limit``), the wrong direction (with its likely cause: an
        encoder counting backwards), a braking whose turning point is ambiguous (naming the
        lines).

    See Also
    --------
    read_device_log : with the device's layout, torque limit and launch speeds.
    """
    if kind not in LOG_KINDS:
        raise ValueError(f"kind must be one of {LOG_KINDS}, got {kind!r}")
    layout = LogLayout() if layout is None else layout
    columns = read_log_columns(path, layout, encoder, torque_constant)
    rows = columns.rows
    t, phi, torque, temperature = columns.t, columns.phi, columns.torque, columns.temperature
    check_time(rows, t, encoder, regular=False)
    check_grid(rows, phi, encoder)
    # Isolated corrupted rows left out (dropped samples) before anything reads the motion,
    # of every column alike; the checks after this name the file's lines through ``rows``.
    glitches = find_glitches(rows, t, phi, torque, encoder)
    if glitches.rows.size:
        keep = glitches.keep(len(t))
        t, phi, torque = t[keep], phi[keep], torque[keep]
        temperature = None if temperature is None else temperature[keep]
        rows = rows.without(glitches.rows)
    if launch_speed is not None:
        check_speed(rows, t, phi, launch_speed, encoder)
    check_direction(rows, phi, kind, direction, torque)
    if torque_limit is not None:
        check_torque(rows, torque, torque_limit)
    log = Log(
        t=t, phi=phi, torque=torque, temperature=temperature, warnings=glitches.warnings,
        where=rows,
    )
    if kind == "braking":
        increases = direction is Direction.FORWARD
        end = turning_point(rows, t, phi, increases, encoder) + 1
        if end < len(t):
            note = _held_note(rows, t, (phi if increases else -phi), end, encoder)
            return dataclasses.replace(log.rows(slice(0, end)), notes=(note,))
    return log


def _held_note(rows: Rows, t: np.ndarray, phi: np.ndarray, end: int, encoder: EncoderLike) -> str:
    """The one line that says a braking was cut at its turning point (row ``end - 1``),
    ``phi`` in the pass's direction (minus the angle of a backward run)."""
    off = np.rint((phi[end:] - phi[end - 1]) / float(encoder.quantum))
    low, high = int(off.min()), int(off.max())
    reading = "stays put" if low == high == 0 else f"keeps within {low:+d} to {high:+d} counts"
    return (
        f"{rows.span(end, len(t) - 1)}: the drive logged on {t[-1] - t[end - 1]:.3g} s "
        f"after the braking's turning point at {rows.line(end - 1)} (the reading {reading} "
        f"there): {len(t) - end} row(s) left out"
    )


def read_device_log(
    path: str | os.PathLike,
    device: Device,
    kind: str,
    direction: Direction = Direction.FORWARD,
) -> Log:
    """:func:`read_log` with every check the device allows, in its ``[log]`` layout: its
    encoder, its motor's ``torque_limit`` (and ``torque_constant`` for a logged current) and
    the fastest ``launch_speed`` of its stages (what no run of it can
    exceed: rsp_inertia.plant.log_checks.TORQUE_MARGIN and SPEED_MARGIN). While a stage has
    no launch speed (``plan`` has not chosen it), the device's fastest run is unknown and
    the angle's steps are not checked.

    Parameters
    ----------
    path : str or path-like
        The log, in device.toml's ``[log]`` layout (``device.log``).
    device : Device
        device.toml's gimbal (rsp_inertia.plant.config.Device).
    kind : str
        As for :func:`read_log`.
    direction : Direction
        As for :func:`read_log`.

    Returns
    -------
    Log
        The values exactly as written in the file.

    Raises
    ------
    InputError
        As :func:`read_log`, one line naming the file, the line and the fault.
    """
    speeds = [st.launch_speed for st in device.stages]
    return read_log(
        path,
        device.encoder,
        kind,
        direction,
        torque_limit=device.motor.torque_limit,
        launch_speed=None if None in speeds else max(speeds),
        layout=device.log,
        torque_constant=device.motor.torque_constant,
    )


def reverse_start_lag(braking: Log, motor) -> float:
    """K, T_mag - T where a reverse pass starts: the magnets' lag behind the logged
    temperature at its braking's last row (rsp_inertia.plant.transducers.magnet_temperature,
    from none at the braking's first row), decayed over device.toml's ``[motor]
    reverse_delay`` (not set: 0, the reverse follows at once; the logged temperature taken as
    held meanwhile). 0 without a lag or a logged temperature.

    Parameters
    ----------
    braking : Log
        The run's braking log, with its :attr:`Log.temperature`.
    motor : device.toml's ``[motor]``
        Its ``temperature_lag`` (s) and ``reverse_delay`` (s).

    Returns
    -------
    float
        K.
    """
    lag = motor.temperature_lag
    if lag is None or braking.temperature is None or braking.temperature.size == 0:
        return 0.0
    end = magnet_temperature(braking.temperature, braking.t, lag)[-1] - braking.temperature[-1]
    return float(end * math.exp(-(motor.reverse_delay or 0.0) / lag))


def compensate_temperature(
    log: Log, motor, tempco: float | None = None, start_lag: float = 0.0
) -> Log:
    """``log`` with the torque the body receives at the torque constant's reference
    temperature: every row's torque times 1 + alpha (T_mag - T_ref)
    (rsp_inertia.plant.transducers.thermal_torque_factor; docs/method.md §3, "Temperature").

    Parameters
    ----------
    log : Log
        A log as read, with its :attr:`Log.temperature` when the logger logs it.
    motor : device.toml's ``[motor]``
        Its ``torque_constant_tempco`` (alpha, 1/K), ``temperature_lag`` (s) and
        ``reference_temperature`` (degrees C; rsp_inertia.plant.config.Motor).
    tempco : float, optional
        1/K, alpha to apply instead of the motor's (the uncertainty's propagation moves it).
    start_lag : float, optional
        K, T_mag - T at the first row: a reverse's :func:`reverse_start_lag`, else 0.

    Returns
    -------
    Log
        The compensated log; ``log`` itself (the same object, bit for bit) when the motor
        states no tempco or the log holds no temperature.
    """
    alpha = motor.torque_constant_tempco if tempco is None else tempco
    if alpha is None or log.temperature is None:
        return log
    factor = thermal_torque_factor(
        log.temperature, log.t, alpha, motor.temperature_lag, motor.reference_temperature,
        start_lag,
    )
    return dataclasses.replace(log, torque=log.torque * factor, torque_factor=factor)


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
    values = read_table(path, PROGRAM_COLUMNS)
    check_time(path, values[:, 0], encoder)
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


def write_log(
    path: str | os.PathLike,
    log: Log,
    counter: EncoderLike | None = None,
    *,
    layout: LogLayout | None = None,
    encoder: EncoderLike | None = None,
    torque_constant: float | None = None,
) -> None:
    """Write a log as braking.csv / reverse.csv (header ``t,phi,torque``), or in a logger's
    ``layout``, atomically.

    Numbers are written as Python ``repr``, so :func:`read_log` returns exactly these values
    and the same log always gives a byte-identical file (in another layout the units'
    conversions round within an ulp or two, time stamps in us or ns to whole units).

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
        phi up to whole ranges of the counter. With a ``layout``: the angle in counts, in
        its angle column.
    layout : LogLayout, optional
        device.toml ``[log]``: format, dialect, columns, units
        (rsp_inertia.plant.log_files.write_log_file); the log's temperature, if any, in a
        named temperature column. None: CSV ``t,phi,torque``.
    encoder : encoder-like, optional
        The encoder (``quantum``, ``counter_bits``): needed by a layout in counts.
    torque_constant : float, optional
        N m/A, for a layout that logs the current.
    """
    if layout is not None:
        write_log_file(
            path,
            log.t,
            log.phi,
            log.torque,
            layout,
            counter if counter is not None else encoder,
            temperature=log.temperature,
            torque_constant=torque_constant,
            counts=counter is not None,
        )
        return
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



def motor_work(
    torque: np.ndarray, phi: np.ndarray, constant: bool = False, factor: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float | None]:
    """Motor work from a pass's first row to each row, and its noise factors: the one
    zero-order-hold Stieltjes sum of the package (docs/method.md §3-4).

    Row k's torque is held over [t_k, t_k+1) (:class:`Log`), so the work up to row K is
    W_K = sum_{k<K} u_k (phi_{k+1} - phi_k). A pass's balances take it over the smoothed
    angle, not the readings (rsp_inertia.estimation.passes says why); :meth:`Log.motor_work`
    takes it over the log's own angle.

    Parameters
    ----------
    torque : np.ndarray, shape (n,), N m
        The logged torque; row k acts over the increment phi_{k+1} - phi_k.
    phi : np.ndarray, shape (n,), rad
        The angle at each row.
    constant : bool
        The applied torque is constant (a braking pass whose log passed the constancy
        test): the work is then the log's mean torque times (phi - phi_0) instead of the
        sum of the logged torques.
    factor : np.ndarray, shape (n,), optional
        With ``constant``: the known factor each row's torque carries (:attr:`Log.torque_factor`,
        a temperature's compensation): the logged torque over it is the constant, and the
        work is that mean times the sum of factor x the angle's increments.

    Returns
    -------
    work : np.ndarray, shape (n,), J
        W from the first row to each row (``work[0] = 0``).
    back : np.ndarray, shape (n,), J
        Its back-driven part: the sum over the increments where the held torque opposes the
        motion (rsp_inertia.plant.transducers.power_flow_split); a drive with losses
        delivers h_d x the rest and h_b x this (docs/method.md §3).
    steps : np.ndarray, shape (n,), rad^2
        The cumulative sum of squared angle increments: the work's noise variance per unit
        sigma^2 of the sample-by-sample sum.
    mean : float or None
        N m, the log's mean torque for a ``constant`` torque, else None.
    """
    dphi = np.diff(phi)
    steps = _running_sum(dphi * dphi)
    scaled = constant and factor is not None
    mean = float(np.mean(torque / factor if scaled else torque)) if constant else None
    if scaled:
        held = mean * np.asarray(factor[:-1], dtype=float)
    else:
        held = mean if constant else np.asarray(torque[:-1], dtype=float)  # a number: no array
    back = power_flow_split(held, dphi)[1]
    back *= dphi
    back = _running_sum(back)
    if scaled:
        return _running_sum(held * dphi), back, steps, mean
    if constant:
        work = phi - phi[0]
        work *= mean
        return work, back, steps, mean
    return _running_sum(held * dphi), back, steps, None


def _running_sum(increments: np.ndarray) -> np.ndarray:
    """[0, x_0, x_0 + x_1, ...]: the sum of ``increments`` before each row (n + 1 values),
    summed into place (no concatenated copy)."""
    out = np.empty(increments.size + 1)
    out[0] = 0.0
    np.cumsum(increments, out=out[1:])
    return out


def switch_row(torque: np.ndarray) -> int:
    """The row where a two-level braking's logged torque switches: the first row of the
    second level, the split of the rows into two runs whose means leave the least sum of
    squares (the likelihood's change point of a step in white noise).

    Parameters
    ----------
    torque : numpy.ndarray, shape (n,), n >= 2
        N m, the logged torque (over its known factor, if any).

    Returns
    -------
    int
        In [1, n - 1].

    Examples
    --------
    >>> switch_row(np.array([0.0, 0.01, -0.01, 1.0, 1.02, 0.98]))
    3
    """
    u = np.asarray(torque, dtype=float)
    n = u.size
    k = np.arange(1, n)
    head = np.cumsum(u)[:-1]
    # The between-levels sum of squares of a split after k rows: (S_k - k S_n / n)^2 n / (k (n - k)).
    gain = (head - k * (head[-1] + u[-1]) / n) ** 2 / (k * (n - k))
    return int(np.argmax(gain)) + 1


def torque_noise(log: Log) -> float:
    """Standard deviation of the torque log's noise, N m, from its sample-to-sample changes.

    Meant for the braking log, whose applied torque is constant by protocol: white logging
    noise of std sigma makes the differences' std sigma sqrt(2); a robust scale (median
    absolute deviation) keeps the odd genuine step out. Not for a closed-loop log: there the
    regulator's response to each encoder count (k_phi q, ~0.02 N m on the default stage 2)
    is real torque, doing real work, and would pass for noise 200 times the logging noise.
    The logging noise belongs to the rig's torque channel, shared by both passes.
    """
    d = np.diff(log.torque)
    if d.size < 2:
        return 0.0
    mad = np.median(np.abs(d - np.median(d)))
    return float(1.4826 * mad / np.sqrt(2.0))


def check_braking_monotone(log: Log, source: str | Rows) -> None:
    """The braking speed never reverses: encoder readings never decrease (docs/files.md).
    The message names the line through the log's own :attr:`Log.where`, else ``source`` (a
    path: a CSV whose data start on line 2; rsp_inertia.plant.log_files.log_rows of a
    layout)."""
    back = np.nonzero(np.diff(log.phi) < 0)[0]
    if back.size:
        rows = log.where or as_rows(source)
        raise InputError(
            f"{rows.at(int(back[0]) + 1)}: the angle decreases: the speed reverses "
            "inside the braking"
        )


def mirror_log(log: Log, quantum: float) -> Log:
    """A backward run's log in the mirrored coordinate phi_m = -phi, torque u_m = -u.

    The motor work sum u dphi is unchanged, so every balance reads the same. The encoder
    reading y = floor(phi / q) q of the mirrored angle -phi is -y - q (for -phi off the grid),
    so the mirrored log keeps the floor convention that the smoother assumes
    (rsp_inertia.estimation.smoothing: true angle in [y, y + q)).
    """
    return dataclasses.replace(
        log, phi=-np.asarray(log.phi) - quantum, torque=-np.asarray(log.torque)
    )


def mirrored_device(device: Device) -> Device:
    """The device seen in the mirrored coordinate phi_m = -phi of :func:`mirror_log`: the
    spring c/2 (phi - phi0)^2 = c/2 (phi_m + phi0)^2 has its zero angle at -phi0 (the gravity
    terms and M's odd harmonics, which change sign too, are fitted, never given)."""
    spring = dataclasses.replace(device.spring, zero_angle=-device.spring.zero_angle)
    return dataclasses.replace(device, spring=spring)
