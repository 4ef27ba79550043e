"""device.toml ``[log]``: how the rig's logger writes its logs (docs/files.md, Logs).

A log (braking, reverse, pendulum, pilot) is a table of time stamps, encoder angles and motor
torques, and optionally the motor's temperature. Loggers write it as CSV in many dialects,
as NI TDMS or as Parquet, with their own column names and units. :class:`LogLayout` states
which: the file's format and extension, the CSV dialect, the TDMS group, the columns' names
and units. Its defaults are the format of older rsp-inertia, ``t,phi,torque`` (or
``t,counts,torque``) in CSV. The readers and writers are rsp_inertia.plant.log_files; program.csv
is always CSV (our own output, read by the drive).
"""

from __future__ import annotations

import enum

from rsp_inertia.infra.toml_schema import Bound, config_class, key

__all__ = [
    "DELIMITERS",
    "AngleUnit",
    "LogFormat",
    "LogLayout",
    "TimeOrigin",
    "TimeUnit",
    "TorqueUnit",
]


class LogFormat(enum.StrEnum):
    """A logger's file format; its value is the files' extension (``braking.<format>``)."""

    CSV = "csv"
    """Text: a header row of column names, one row per sample."""
    TDMS = "tdms"
    """NI TDMS (LabVIEW): one channel per column, in a group."""
    PARQUET = "parquet"
    """Apache Parquet: one column per column."""


class TimeUnit(enum.StrEnum):
    """The unit of the time stamps."""

    S = "s"
    MS = "ms"
    US = "us"
    NS = "ns"

    @property
    def seconds(self) -> float:
        """One stamp unit in seconds."""
        return {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}[self.value]

    @property
    def per_second(self) -> int:
        """Stamp units per second (an exact integer)."""
        return {"s": 1, "ms": 1000, "us": 1_000_000, "ns": 1_000_000_000}[self.value]


class TimeOrigin(enum.StrEnum):
    """Where the time stamps count from."""

    ZERO = "zero"
    """The first row is at t = 0 (the drive's own clock from the pass's start)."""
    FIRST = "first"
    """The first stamp is the origin: t = stamp - first stamp (epoch stamps, a running clock)."""


class AngleUnit(enum.StrEnum):
    """The unit of the encoder angle column."""

    RAD = "rad"
    DEG = "deg"
    COUNTS = "counts"
    """Integer encoder counts (phi = counts x 2 pi / counts_per_rev), unwrapped with
    ``[encoder] counter_bits``."""


class TorqueUnit(enum.StrEnum):
    """The unit of the torque column."""

    NM = "N m"
    MNM = "mN m"
    A = "A"
    """The motor's current: torque = current x ``[motor] torque_constant``."""


DELIMITERS = (",", ";", "\t", " ")
"""The CSV delimiters; ``" "`` is any run of blanks (spaces, tabs)."""


def _delimiter(value: str) -> bool:
    return value in DELIMITERS


@config_class
class LogLayout:
    """How the rig's logger writes its logs (``[log]``): format, dialect, columns and units.

    The defaults read the CSV logs of older rsp-inertia: header ``t,phi,torque`` in s, rad,
    N m, or ``t,counts,torque`` (:attr:`angle_column` not set)."""

    format: LogFormat = key(
        LogFormat.CSV,
        doc="The files' format; the logs are stageN/braking.<format> etc. (.csv, .tdms, "
        ".parquet). program.csv is always CSV.",
    )
    delimiter: str = key(
        ",",
        bound=Bound("one of ',', ';', '\\t', ' '", _delimiter),
        doc="CSV: the field delimiter; ' ' is any run of blanks.",
    )
    decimal: str = key(
        ".",
        bound=Bound("one of '.', ','", lambda value: value in (".", ",")),
        doc="CSV: the decimal mark of the numbers.",
    )
    header_line: int = key(
        1,
        bound=">= 1",
        doc="CSV: the (1-based) line holding the column names; the lines before it are skipped.",
    )
    skip_after_header: int = key(
        0,
        bound=">= 0",
        doc="CSV: rows between the header and the data, skipped (a units row: 1).",
    )
    tdms_group: str = key(
        "",
        doc="TDMS: the group holding the channels; '' : the file's only group.",
    )
    time_column: str = key(
        "t",
        doc="The time stamps' column (channel); '' in TDMS: the channels' waveform timing "
        "(wf_increment).",
    )
    time_unit: TimeUnit = key(TimeUnit.S, doc="The time stamps' unit.")
    time_origin: TimeOrigin = key(
        TimeOrigin.ZERO,
        doc="'zero': the stamps start at 0; 'first': the first stamp is the origin (epoch "
        "stamps, timestamp channels).",
    )
    angle_column: str | None = key(
        None,
        doc="The encoder angle's column; None (not set): 'phi', 'counts' with angle_unit "
        "'counts', and with angle_unit 'rad' a file without 'phi' but with 'counts' is read "
        "as counts (the two headers of older rsp-inertia).",
    )
    angle_unit: AngleUnit = key(AngleUnit.RAD, doc="The encoder angle's unit.")
    torque_column: str = key("torque", doc="The motor torque's (or current's) column.")
    torque_unit: TorqueUnit = key(
        TorqueUnit.NM,
        doc="The torque's unit, reduced to phi; 'A': the motor current, times "
        "[motor] torque_constant.",
    )
    temperature_column: str = key(
        "",
        doc="The motor temperature's column, degrees Celsius; '' : not logged.",
    )

    def __post_init__(self) -> None:
        # A layout built in Python may name its choices as strings: they become the enums'
        # members (a value no enum has is a ValueError), as reading device.toml makes them.
        for name, kind in _CHOICES.items():
            object.__setattr__(self, name, kind(getattr(self, name)))

    @property
    def extension(self) -> str:
        """The logs' file extension, with its dot: ``.csv``, ``.tdms`` or ``.parquet``."""
        return f".{self.format.value}"

    def angle_columns(self) -> tuple[tuple[str, AngleUnit], ...]:
        """The angle's column and unit, in the order the readers look for them: the named
        column, or the default ``phi`` (``counts`` for counts) and, for a default layout in
        rad, ``counts`` in counts (older rsp-inertia's second header)."""
        if self.angle_column is not None:
            return ((self.angle_column, self.angle_unit),)
        if self.angle_unit is AngleUnit.COUNTS:
            return (("counts", AngleUnit.COUNTS),)
        if self.angle_unit is AngleUnit.RAD:
            return (("phi", AngleUnit.RAD), ("counts", AngleUnit.COUNTS))
        return (("phi", self.angle_unit),)


_CHOICES = {
    "format": LogFormat,
    "time_unit": TimeUnit,
    "time_origin": TimeOrigin,
    "angle_unit": AngleUnit,
    "torque_unit": TorqueUnit,
}
"""The keys of :class:`LogLayout` whose value is one of an enum's."""
