"""What a test report records beside the numbers (ISO/IEC 17025 section 7.8): who measured
which part on which rig, in what environment, with a calibration of which date and due date,
traceable to which reference certificate. result.json's ``record`` (docs/files.md).

Assembled by identify from ``EXP/record.toml`` (rsp_inertia.plant.record_config), device.toml's
``[device] asset_id`` and ``calibration_interval_days``, and calibration.toml's
``[calibration] date`` and ``[certificate]``.
"""

from __future__ import annotations

import datetime
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from rsp_inertia.plant.record_config import RecordFile, load_record

if TYPE_CHECKING:
    from rsp_inertia.estimation.calibration_file import CalibrationFile
    from rsp_inertia.plant.experiment import Experiment

__all__ = [
    "CalibrationDue",
    "Record",
    "calibration_due",
    "experiment_record",
    "overdue_warning",
    "reference_certificate",
]


@dataclass(frozen=True)
class CalibrationDue:
    """A calibration's date and due date, and whether it was overdue when the result was made."""

    date: str | None
    """``YYYY-MM-DD``, calibration.toml ``[calibration] date`` (None: no calibration, or a
    file of an older rsp-inertia)."""
    due: str | None
    """``date`` plus the rig's interval, ``YYYY-MM-DD`` (None without either)."""
    interval_days: int | None
    """device.toml ``[device] calibration_interval_days``."""
    overdue: bool
    """Whether the result was made after ``due``."""

    def to_dict(self) -> dict[str, Any]:
        """result.json's ``record.calibration``."""
        return {
            "date": self.date,
            "due": self.due,
            "interval_days": self.interval_days,
            "overdue": self.overdue,
        }


def calibration_due(date: str | None, interval_days: int | None, made: str) -> CalibrationDue:
    """The due date of a calibration made on ``date`` and valid ``interval_days``, and whether
    a result made on ``made`` came after it.

    Parameters
    ----------
    date : str or None
        The calibration's day, ``YYYY-MM-DD``.
    interval_days : int or None
        How many days it stays valid.
    made : str
        The day the result was made, ``YYYY-MM-DD`` (or an ISO time, whose date counts).

    Returns
    -------
    CalibrationDue
        ``due = date + interval_days``; overdue when ``made`` is after ``due`` (on the due
        day itself the calibration is still valid).

    Examples
    --------
    >>> calibration_due("2026-01-10", 30, "2026-02-10").overdue
    True
    """
    if date is None or interval_days is None:
        return CalibrationDue(date, None, interval_days, False)
    due = datetime.date.fromisoformat(date) + datetime.timedelta(days=interval_days)
    overdue = datetime.date.fromisoformat(made[:10]) > due
    return CalibrationDue(date, due.isoformat(), interval_days, overdue)


def overdue_warning(due: CalibrationDue, source: str) -> str:
    """The warning of a calibration used after its due date (``source``: calibration.toml's
    path)."""
    return (
        f"{source}: the calibration of {due.date} was due on {due.due} (device.toml "
        f"[device] calibration_interval_days = {due.interval_days}): it is overdue; calibrate "
        "the rig again (rsp-inertia calibrate) before the result is used"
    )


def reference_certificate(calibration: CalibrationFile | None) -> dict[str, str] | None:
    """The reference certificate behind a calibration: calibration.toml's ``[certificate]``
    (``id``, ``issuer``, ``date``) as result.json's ``record.reference_certificate``.

    Parameters
    ----------
    calibration : CalibrationFile or None
        calibration.toml as read (rsp_inertia.estimation.reading.read_calibration).

    Returns
    -------
    dict or None
        ``{"id", "issuer", "date"}`` as text (None for a key the table leaves out); None
        without a calibration or a ``[certificate]`` table (calibrate without a reference, or
        a file of an older rsp-inertia).
    """
    certificate = None if calibration is None else calibration.certificate
    if certificate is None:
        return None
    return {
        "id": certificate.id,
        "issuer": certificate.issuer or None,
        "date": certificate.date or None,
    }


@dataclass(frozen=True)
class Record:
    """result.json's ``record``: the record fields of the result (docs/files.md)."""

    operator: str | None = None
    """Who ran the measurement (record.toml)."""
    part_id: str | None = None
    """The part's number."""
    serial: str | None = None
    """The part's serial number."""
    notes: str | None = None
    """Free text."""
    environment: dict[str, float | None] = field(
        default_factory=lambda: dict.fromkeys(
            ("temperature_C", "pressure_hPa", "humidity_percent")
        )
    )
    """temperature_C (deg C), pressure_hPa (hPa), humidity_percent (%), None where not stated."""
    asset_id: str | None = None
    """The rig's asset number (device.toml)."""
    calibration: CalibrationDue = field(
        default_factory=lambda: CalibrationDue(None, None, None, False)
    )
    """The calibration's date, due date and whether it was overdue."""
    reference_certificate: dict[str, str] | None = None
    """The reference's certificate behind the calibration: id, issuer, date."""

    def to_dict(self) -> dict[str, Any]:
        """result.json's ``record``."""
        return {
            "operator": self.operator,
            "part_id": self.part_id,
            "serial": self.serial,
            "notes": self.notes,
            "environment": dict(self.environment),
            "asset_id": self.asset_id,
            "calibration": self.calibration.to_dict(),
            "reference_certificate": self.reference_certificate,
        }


def experiment_record(
    exp: Experiment, calibration: CalibrationFile | None, made: str
) -> tuple[Record, list[str]]:
    """The record of a result made on ``made`` in experiment ``exp``, and its warnings.

    Parameters
    ----------
    exp : Experiment
        The experiment folder: its record.toml (optional) and device.toml.
    calibration : CalibrationFile or None
        Its calibration.toml as read.
    made : str
        When the result is made, ISO 8601 (its date counts).

    Returns
    -------
    Record
        The record fields.
    list of str
        A warning when the calibration is overdue (:func:`overdue_warning`).

    Raises
    ------
    InputError
        A record.toml that breaks a rule of rsp_inertia.plant.record_config.
    """
    path = exp.record_path
    file = load_record(path) if path.is_file() else RecordFile()
    head = None if calibration is None else calibration.calibration
    device = exp.device
    due = calibration_due(
        None if head is None else head.date, device.calibration_interval_days, made
    )
    env = file.environment
    record = Record(
        operator=file.record.operator,
        part_id=file.record.part_id,
        serial=file.record.serial,
        notes=file.record.notes,
        environment={
            "temperature_C": env.temperature_C,
            "pressure_hPa": env.pressure_hPa,
            "humidity_percent": env.humidity_percent,
        },
        asset_id=device.asset_id,
        calibration=due,
        reference_certificate=reference_certificate(calibration),
    )
    warnings = [overdue_warning(due, str(exp.calibration_path))] if due.overdue else []
    return record, warnings
