"""The loggers' files: a log's columns read from CSV, TDMS or Parquet and written back.

device.toml ``[log]`` (:class:`rsp_inertia.plant.log_layout.LogLayout`) says how the rig's
logger writes a log: its format, a CSV's dialect, a TDMS file's group, the columns' names and
units. :func:`read_log_columns` finds the columns by name, converts them to the package's
units (s from 0, rad on the encoder grid, N m, degrees Celsius) and names every fault in one
:class:`~rsp_inertia.infra.errors.InputError` line with the file, the line or row (or the
channel) and the ``[log]`` key that fixes it; rsp_inertia.plant.logs.read_log checks what
it returns. :func:`write_log_file` writes a log in a layout (the virtual device's logger),
deterministically and atomically.

nptdms and pyarrow are imported by the functions that read or write their formats: a CSV
log, and every command that reads none of those, does not pay for them.
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import write_atomic
from rsp_inertia.plant.log_checks import (
    GRID_TOLERANCE,
    CsvDialect,
    EncoderLike,
    Rows,
    read_columns,
    unwrap_counts,
)
from rsp_inertia.plant.log_layout import (
    AngleUnit,
    LogFormat,
    LogLayout,
    TimeOrigin,
    TimeUnit,
    TorqueUnit,
)

__all__ = [
    "EPOCH",
    "TEMPERATURE",
    "LogColumns",
    "csv_dialect",
    "log_rows",
    "read_log_columns",
    "write_log_file",
]

EPOCH = 1_795_000_000
"""s since 1970 (2026-11-18): the first time stamp :func:`write_log_file` writes with
``time_origin = "first"``, fixed so that the same log gives the same bytes."""

TEMPERATURE = 25.0
"""degrees C, the motor temperature the virtual device's logger writes in a named
``temperature_column`` (it has no thermal model)."""

_GROUP = "Log"
"""The TDMS group :func:`write_log_file` writes when ``[log] tdms_group`` is ''."""

_UNIT_NAMES = {"t": "time_unit", "angle": "angle_unit", "torque": "torque_unit"}


@dataclass(frozen=True, eq=False)
class LogColumns:
    """A log's columns as read, in the package's units, before the checks of
    rsp_inertia.plant.logs.read_log."""

    t: np.ndarray
    """s, from 0 (``time_origin = "first"``: the first stamp subtracted exactly)."""
    phi: np.ndarray
    """rad: as written, deg converted and put on the encoder grid, counts unwrapped."""
    torque: np.ndarray
    """N m: as written, mN m converted, a current times the torque constant."""
    temperature: np.ndarray | None
    """degrees C, or None when ``[log] temperature_column`` is ''."""
    rows: Rows
    """The file and where its data rows are, for messages."""


def csv_dialect(layout: LogLayout) -> CsvDialect:
    """The CSV dialect of ``layout``'s keys."""
    return CsvDialect(
        layout.delimiter, layout.decimal, layout.header_line, layout.skip_after_header
    )


def log_rows(path: str | os.PathLike, layout: LogLayout) -> Rows:
    """Where a log's data rows are in its file: the line of row 0 of a CSV in ``layout``'s
    dialect, rows of a binary file (TDMS, Parquet)."""
    if layout.format is LogFormat.CSV:
        return Rows(str(path), csv_dialect(layout).first_line)
    return Rows(str(path), None)


# ---------------------------------------------------------------------------------------------
# Reading


@dataclass(frozen=True, eq=False)
class _Raw:
    """A log's columns as the file holds them (time as float, int64 or datetime64)."""

    t: np.ndarray | None
    """None: waveform timing, ``step`` and ``start`` give it."""
    angle: np.ndarray
    angle_name: str
    angle_unit: AngleUnit
    torque: np.ndarray
    temperature: np.ndarray | None
    rows: Rows
    step: float = 0.0
    """s, a TDMS waveform's wf_increment (``t`` None)."""
    start: float = 0.0
    """s, its wf_start_offset."""


def read_log_columns(
    path: str | os.PathLike,
    layout: LogLayout,
    encoder: EncoderLike,
    torque_constant: float | None = None,
) -> LogColumns:
    """Read a log's columns in ``layout`` and convert them to s, rad, N m and degrees C.

    Parameters
    ----------
    path : str or path-like
        The log, with ``layout``'s extension.
    layout : LogLayout
        device.toml ``[log]``.
    encoder : encoder-like
        ``quantum`` (rad), and ``counter_bits`` for counts of a wrapping counter.
    torque_constant : float, optional
        N m/A, device.toml ``[motor] torque_constant``: needed for ``torque_unit = "A"``.

    Returns
    -------
    LogColumns
        Time from 0 (the first stamp subtracted exactly with ``time_origin = "first"``:
        integer and date stamps before they become float seconds), the angle in rad (deg
        converted and, within the grid's tolerance, put on the encoder grid exactly; counts
        unwrapped), the torque in N m, the temperature; where the rows are.

    Raises
    ------
    InputError
        One line naming the file, the line or row (or the group, channel) and the fault,
        and the ``[log]`` key that fixes it: a missing file (naming one of another format
        beside it), a column, group or channel not found, a field that is not a number,
        a value that is not finite, date stamps with ``time_origin = "zero"``, channels of
        unequal length, a current without a torque constant.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(_missing(path, layout))
    if layout.torque_unit is TorqueUnit.A and torque_constant is None:
        raise InputError(
            f"{path}: [log] torque_unit = 'A' (a current) needs device.toml's "
            "motor.torque_constant"
        )
    if layout.format is LogFormat.CSV:
        raw = _read_csv(path, layout)
    elif layout.format is LogFormat.TDMS:
        raw = _read_tdms(path, layout)
    else:
        raw = _read_parquet(path, layout)
    return _converted(raw, layout, encoder, torque_constant)


def _missing(path: Path, layout: LogLayout) -> str:
    """The message of a missing log: a file of another format beside it is named."""
    for other in LogFormat:
        sibling = path.with_suffix(f".{other.value}")
        if other is not layout.format and sibling.is_file():
            return (
                f"{path}: no such file, but {sibling.name} is there: its format is "
                f"{other.value!r} and [log] format is {layout.format.value!r} (set [log] format)"
            )
    return f"{path}: no such file"


def _names(layout: LogLayout) -> tuple[list[str], list[str]]:
    """The columns to read (time, angle, torque, temperature; no time for a TDMS waveform),
    with the [log] key naming each; the angle's is filled in by the caller."""
    columns, keys = [], []
    if layout.time_column:
        columns.append(layout.time_column)
        keys.append("time_column")
    columns += ["", layout.torque_column]
    keys += ["angle_column", "torque_column"]
    if layout.temperature_column:
        columns.append(layout.temperature_column)
        keys.append("temperature_column")
    return columns, keys


def _angle(layout: LogLayout, names: list[str] | None) -> tuple[str, AngleUnit]:
    """The angle's column and unit: the first of the layout's candidates the file has (the
    first when it has none: the reader then says it is not found)."""
    candidates = layout.angle_columns()
    for name, unit in candidates:
        if names is not None and name in names:
            return name, unit
    return candidates[0]


def _csv_header(path: Path, dialect: CsvDialect) -> list[str] | None:
    """The column names on the header line of a CSV in ``dialect`` (None if it cannot be
    read: :func:`read_columns` then says why)."""
    try:
        with open(path, encoding="utf-8-sig", newline=None) as file:
            for _ in range(dialect.header_line - 1):
                file.readline()
            line = file.readline()
    except (OSError, UnicodeDecodeError):
        return None
    fields = line.split() if dialect.delimiter == " " else line.split(dialect.delimiter)
    return [name.strip().strip('"').strip() for name in fields]


def _read_csv(path: Path, layout: LogLayout) -> _Raw:
    dialect = csv_dialect(layout)
    columns, keys = _names(layout)
    angle, unit = _angle(layout, _csv_header(path, dialect))
    columns[columns.index("")] = angle
    integer = 0 if layout.time_origin is TimeOrigin.FIRST else None
    table = read_columns(path, columns, dialect, keys, integer)
    values = table.values
    t = table.integers if table.integers is not None else values[:, 0]
    temperature = values[:, 3] if layout.temperature_column else None
    return _Raw(t, values[:, 1], angle, unit, values[:, 2], temperature, table.rows)


def _not_found(path: Path, what: str, name: str, where: str, names: list[str], key: str) -> str:
    shown = ", ".join(repr(n) for n in names[:12]) + (", ..." if len(names) > 12 else "")
    has = shown or "none"
    return f"{path}: {what} {name!r} not found{where}; the file has {has}: set [log] {key}"


def _read_tdms(path: Path, layout: LogLayout) -> _Raw:
    # nptdms only here: reading a TDMS log is the only use of it
    from nptdms import TdmsFile

    try:
        tdms = TdmsFile.read(path, raw_timestamps=True)
    except Exception as exc:  # noqa: BLE001 - any fault of the file's bytes is the file's
        raise InputError(f"{path}: not a TDMS file ({exc})") from None
    groups = [group.name for group in tdms.groups()]
    if layout.tdms_group:
        if layout.tdms_group not in groups:
            raise InputError(
                _not_found(path, "group", layout.tdms_group, "", groups, "tdms_group")
            )
        group = tdms[layout.tdms_group]
    elif len(groups) == 1:
        group = tdms[groups[0]]
    else:
        shown = ", ".join(repr(name) for name in groups) or "none"
        raise InputError(
            f"{path}: the file has {len(groups)} groups ({shown}): set [log] tdms_group"
        )
    names = [channel.name for channel in group.channels()]
    columns, keys = _names(layout)
    angle, unit = _angle(layout, names)
    columns[columns.index("")] = angle
    data = {}
    for column, key in zip(columns, keys, strict=True):
        if column not in names:
            where = f" in group {group.name!r}"
            raise InputError(_not_found(path, "channel", column, where, names, key))
        values = group[column][:]
        if hasattr(values, "as_datetime64"):  # a timestamp channel, read exactly
            values = values.as_datetime64("ns")
        data[column] = np.asarray(values)
    lengths = {column: len(values) for column, values in data.items()}
    if len(set(lengths.values())) > 1:
        shown = ", ".join(f"{column!r} {n}" for column, n in lengths.items())
        raise InputError(f"{path}: channels of unequal length ({shown} values)")
    rows = Rows(str(path), None)
    temperature = data[layout.temperature_column] if layout.temperature_column else None
    if layout.time_column:
        return _Raw(data[layout.time_column], data[angle], angle, unit,
                    data[layout.torque_column], temperature, rows)
    properties = group[angle].properties
    if "wf_increment" not in properties:
        raise InputError(
            f"{path}: channel {angle!r} has no waveform timing (wf_increment): name the time "
            "channel in [log] time_column"
        )
    step = float(properties["wf_increment"])
    if not (math.isfinite(step) and step > 0.0):
        raise InputError(f"{path}: channel {angle!r}: wf_increment = {step!r} s, must be > 0")
    start = float(properties.get("wf_start_offset", 0.0))
    return _Raw(None, data[angle], angle, unit, data[layout.torque_column], temperature, rows,
                step, start)


def _read_parquet(path: Path, layout: LogLayout) -> _Raw:
    # pyarrow only here: reading a Parquet log is the only use of it
    import pyarrow
    import pyarrow.parquet

    try:
        names = list(pyarrow.parquet.read_schema(path).names)
    except (pyarrow.ArrowException, OSError) as exc:
        raise InputError(f"{path}: not a Parquet file ({exc})") from None
    columns, keys = _names(layout)
    angle, unit = _angle(layout, names)
    columns[columns.index("")] = angle
    for column, key in zip(columns, keys, strict=True):
        if column not in names:
            raise InputError(_not_found(path, "column", column, "", names, key))
    try:
        table = pyarrow.parquet.read_table(path, columns=columns)
    except (pyarrow.ArrowException, OSError) as exc:
        raise InputError(f"{path}: not a Parquet file ({exc})") from None
    rows = Rows(str(path), None)
    data = {}
    for column in columns:
        chunked = table.column(column)
        if chunked.null_count:
            k = int(np.flatnonzero(chunked.is_null().to_numpy(zero_copy_only=False))[0])
            raise InputError(f"{rows.at(k)}: {column} is empty (null)")
        values = chunked.to_numpy()
        if values.dtype.kind == "M":
            values = values.astype("datetime64[ns]")
        elif values.dtype.kind not in "iuf":
            raise InputError(f"{path}: column {column!r} holds {chunked.type}, not numbers")
        data[column] = values
    temperature = data[layout.temperature_column] if layout.temperature_column else None
    return _Raw(data[layout.time_column], data[angle], angle, unit,
                data[layout.torque_column], temperature, rows)


def _finite(rows: Rows, name: str, values: np.ndarray) -> np.ndarray:
    """``values`` as float64, refusing the first that is not finite."""
    values = np.asarray(values, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        k = int(bad[0])
        raise InputError(f"{rows.at(k)}: {name} = {float(values[k])!r} is not finite")
    return values


def _seconds(raw: _Raw, layout: LogLayout) -> np.ndarray:
    """The time stamps in s from the origin: integer and date stamps are subtracted as
    integers before they become float seconds; float ones subtract exactly when within a
    factor 2 of each other (epoch stamps are)."""
    rows, name = raw.rows, layout.time_column or "t"
    first = layout.time_origin is TimeOrigin.FIRST
    if raw.t is None:  # waveform timing: k wf_increment from the waveform's start
        t = np.arange(len(raw.angle)) * raw.step
        return t if first or raw.start == 0.0 else t + raw.start
    stamps = raw.t
    if stamps.dtype.kind == "M":
        if not first:
            raise InputError(
                f"{rows.path}: {name} holds dates (time stamps), not times from 0: set [log] "
                "time_origin = 'first'"
            )
        ns = (stamps - stamps[0]).astype("timedelta64[ns]").astype(np.int64)
        return ns / 1e9
    per_second = layout.time_unit.per_second
    if stamps.dtype.kind in "iu":
        stamps = stamps.astype(np.int64)
        return (stamps - stamps[0] if first else stamps) / per_second
    stamps = _finite(rows, name, stamps)
    if first:
        stamps = stamps - stamps[0]
    return stamps if layout.time_unit is TimeUnit.S else stamps / per_second


def _radians(raw: _Raw, layout: LogLayout, encoder: EncoderLike) -> np.ndarray:
    """The angle in rad: counts unwrapped, degrees converted and put on the encoder grid
    (each value within :data:`GRID_TOLERANCE` of a count becomes that count's k q exactly,
    so that a log reads as the same numbers in every unit)."""
    rows = raw.rows
    q = float(encoder.quantum)
    angle = _finite(rows, raw.angle_name, raw.angle)
    if raw.angle_unit is AngleUnit.COUNTS:
        return unwrap_counts(rows, angle, encoder) * q
    if raw.angle_unit is AngleUnit.RAD:
        return angle
    phi = np.radians(angle)
    k = np.rint(phi / q)
    near = np.abs(phi / q - k) <= GRID_TOLERANCE
    return np.where(near, k * q, phi)


def _converted(
    raw: _Raw, layout: LogLayout, encoder: EncoderLike, torque_constant: float | None
) -> LogColumns:
    torque = _finite(raw.rows, "torque", raw.torque)
    if layout.torque_unit is TorqueUnit.MNM:
        torque = torque / 1000.0
    elif layout.torque_unit is TorqueUnit.A:
        torque = torque * float(torque_constant)
    temperature = None
    if raw.temperature is not None:
        temperature = _finite(raw.rows, "temperature", raw.temperature)
    return LogColumns(
        t=_seconds(raw, layout),
        phi=_radians(raw, layout, encoder),
        torque=torque,
        temperature=temperature,
        rows=raw.rows,
    )


# ---------------------------------------------------------------------------------------------
# Writing


def _stamps(t: np.ndarray, layout: LogLayout) -> np.ndarray:
    """The time column as the logger writes it: s or ms as floats, us and ns as integers
    (rounded), from 0 or (``time_origin = "first"``) from :data:`EPOCH`."""
    unit = layout.time_unit
    first = layout.time_origin is TimeOrigin.FIRST
    if unit in (TimeUnit.US, TimeUnit.NS):
        stamps = np.rint(t * unit.per_second).astype(np.int64)
        return stamps + EPOCH * unit.per_second if first else stamps
    stamps = t * unit.per_second if unit is not TimeUnit.S else np.array(t, dtype=float)
    return stamps + EPOCH * unit.per_second if first else stamps


def _angle_values(
    phi: np.ndarray, layout: LogLayout, encoder: EncoderLike, counts: bool
) -> tuple[str, AngleUnit, np.ndarray]:
    """The angle's column, unit and values as the logger writes them: ``counts`` (or
    angle_unit counts) as integers of the counter (modulo 2**counter_bits with it)."""
    if counts and layout.angle_unit is AngleUnit.DEG:
        raise ValueError("a counts logger cannot write [log] angle_unit = 'deg'")
    unit = AngleUnit.COUNTS if counts else layout.angle_unit
    name = layout.angle_column
    if name is None:
        name = "counts" if unit is AngleUnit.COUNTS else "phi"
    if unit is AngleUnit.COUNTS:
        values = np.rint(phi / float(encoder.quantum)).astype(np.int64)
        bits = getattr(encoder, "counter_bits", None)
        return name, unit, values % (2**bits) if bits is not None else values
    return name, unit, np.degrees(phi) if unit is AngleUnit.DEG else np.asarray(phi)


def _torque_values(torque: np.ndarray, layout: LogLayout, torque_constant: float | None):
    if layout.torque_unit is TorqueUnit.MNM:
        return torque * 1000.0
    if layout.torque_unit is TorqueUnit.A:
        if torque_constant is None:
            raise ValueError("[log] torque_unit = 'A' needs a torque constant")
        return torque / torque_constant
    return np.asarray(torque)


def write_log_file(
    path: str | os.PathLike,
    t: np.ndarray,
    phi: np.ndarray,
    torque: np.ndarray,
    layout: LogLayout,
    encoder: EncoderLike,
    *,
    temperature: np.ndarray | None = None,
    torque_constant: float | None = None,
    counts: bool = False,
) -> None:
    """Write a log's columns as a logger of ``layout`` writes them, atomically; the same
    columns always give the same bytes.

    Parameters
    ----------
    path : str or path-like
        Target file (``layout``'s extension); its folder must exist.
    t, phi, torque : np.ndarray, shape (n,)
        s from 0, rad on the encoder grid, N m; finite.
    layout : LogLayout
        The format, dialect, columns and units. Time with ``time_origin = "first"`` is
        written from :data:`EPOCH` (a TDMS or Parquet file: as a timestamp, in us or ns);
        us and ns stamps are rounded to whole units. A TDMS file without ``time_column``
        carries the time as waveform timing (wf_increment = the first step), which only a
        regular log has (ValueError otherwise: jittered stamps or dropped rows).
    encoder : encoder-like
        ``quantum``, and ``counter_bits`` for counts of a wrapping counter.
    temperature : np.ndarray, optional
        degrees C, written in a named ``temperature_column`` (absent: :data:`TEMPERATURE`).
    torque_constant : float, optional
        N m/A, to write a current (``torque_unit = "A"``).
    counts : bool
        Write the angle as the counter's counts whatever ``angle_unit`` says (virtual.toml
        ``[logger] counts``; not with ``deg``).

    Raises
    ------
    ValueError
        A non-finite value, a waveform TDMS of an irregular log, a current without a
        torque constant.
    """
    for name, values in (("t", t), ("phi", phi), ("torque", torque)):
        if not np.all(np.isfinite(values)):
            raise ValueError(f"column {name} holds non-finite values; the file could not be read")
    angle, unit, angle_values = _angle_values(np.asarray(phi), layout, encoder, counts)
    columns = {}
    if layout.time_column:
        columns[layout.time_column] = _stamps(np.asarray(t), layout)
        if layout.format is not LogFormat.CSV and layout.time_origin is TimeOrigin.FIRST:
            columns[layout.time_column] = _dates(np.asarray(t), layout.format)
    columns[angle] = angle_values
    columns[layout.torque_column] = _torque_values(np.asarray(torque), layout, torque_constant)
    if layout.temperature_column:
        columns[layout.temperature_column] = (
            np.full(len(t), TEMPERATURE) if temperature is None else np.asarray(temperature)
        )
    units = {
        layout.time_column: layout.time_unit.value,
        angle: unit.value,
        layout.torque_column: layout.torque_unit.value,
        layout.temperature_column: "C",
    }
    if layout.format is LogFormat.CSV:
        write_atomic(path, _csv_text(columns, units, layout))
    elif layout.format is LogFormat.TDMS:
        write_atomic(path, _tdms_bytes(columns, np.asarray(t), layout))
    else:
        write_atomic(path, _parquet_bytes(columns, layout))


def _csv_text(
    columns: dict[str, np.ndarray], units: dict[str, str], layout: LogLayout
) -> Iterator[str]:
    """CSV text in ``layout``'s dialect, in pieces of :data:`CSV_PIECE` rows (its memory
    does not grow with the log): preamble lines before the header, a units row in the lines
    skipped after it, every float as its shortest exact ``repr`` (a decimal comma for
    ``decimal = ","``), '\\n' line ends."""
    delimiter = layout.delimiter
    lines = [f"rsp-inertia virtual logger, line {k}" for k in range(1, layout.header_line)]
    lines.append(delimiter.join(columns))
    lines += [delimiter.join(units[name] for name in columns)] * layout.skip_after_header
    yield "\n".join(lines) + "\n"
    n = len(next(iter(columns.values())))
    for start in range(0, n, CSV_PIECE):
        texts = [
            list(map(str, piece.tolist())) if piece.dtype.kind in "iu"
            else list(map(repr, piece.tolist()))
            for piece in (values[start : start + CSV_PIECE] for values in columns.values())
        ]
        body = "\n".join(delimiter.join(row) for row in zip(*texts, strict=True)) + "\n"
        yield body.replace(".", ",") if layout.decimal == "," else body


CSV_PIECE = 1 << 16
"""Rows of a CSV log made at a time (:func:`_csv_text`)."""


def _tdms_bytes(columns: dict[str, np.ndarray], t: np.ndarray, layout: LogLayout) -> bytes:
    # nptdms only here: writing a TDMS log is the only use of it
    from nptdms import ChannelObject, GroupObject, TdmsWriter

    group = layout.tdms_group or _GROUP
    properties = {}
    if not layout.time_column:
        step = float(t[1] - t[0]) if len(t) > 1 else 0.0
        if not np.array_equal(np.arange(len(t)) * step, t):
            raise ValueError(
                "a TDMS log without a time channel (waveform timing) needs regular time "
                "stamps k dt: this log's are jittered or have dropped rows (name a "
                "[log] time_column, or turn virtual.toml's [logger] time_jitter and "
                "dropped_fraction off)"
            )
        properties = {"wf_increment": step, "wf_start_offset": 0.0}
    objects = [GroupObject(group)]
    for name, values in columns.items():
        objects.append(ChannelObject(group, name, values, properties=properties))
    buffer = io.BytesIO()
    with TdmsWriter(buffer) as writer:
        writer.write_segment(objects)
    return buffer.getvalue()


def _dates(t: np.ndarray, format: LogFormat) -> np.ndarray:
    """Time stamps from :data:`EPOCH` as dates, TDMS and Parquet's timestamps: whole
    microseconds in TDMS (it keeps no more through nptdms), nanoseconds in Parquet."""
    per_second = 1_000_000 if format is LogFormat.TDMS else 1_000_000_000
    stamps = np.rint(t * per_second).astype(np.int64) + EPOCH * per_second
    return stamps.astype("datetime64[us]" if format is LogFormat.TDMS else "datetime64[ns]")


def _parquet_bytes(columns: dict[str, np.ndarray], layout: LogLayout) -> bytes:
    # pyarrow only here: writing a Parquet log is the only use of it
    import pyarrow
    import pyarrow.parquet

    arrays = {name: pyarrow.array(values) for name, values in columns.items()}
    buffer = io.BytesIO()
    pyarrow.parquet.write_table(pyarrow.table(arrays), buffer)
    return buffer.getvalue()
