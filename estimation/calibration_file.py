"""``calibration.toml``: the rig's calibration, read and written (docs/files.md).

``rsp-inertia calibrate`` writes it into the experiment it calibrates and identify applies it
(rsp_inertia.estimation.calibration). The config classes below declare its keys
(rsp_inertia.infra.toml_schema), as rsp_inertia.plant.device_config does for device.toml:
each field's name is its key, with its unit, bounds and doc. The rules that join tables
(array lengths, the covariance's parameters) are :func:`_calibration`'s.

The calibrated parameters are theta = [h_d, h_b, the empty system's harmonics of stage
1..n, Gs, Gc, c1, s1, c2, s2, ...] (rsp_inertia.estimation.layout.theta_layout); the
file holds each one with its std, and their covariance. A file of an older rsp-inertia has
no ``[drive]`` and no ``[encoder]``: one ``calibration.torque_gain`` and a covariance over
theta = [h = 1 / torque_gain, harmonics, Gs, Gc]; it is read as a lossless drive and an
exact encoder (:meth:`CalibrationFile.known_terms`).
"""

from __future__ import annotations

import os
import re
from typing import TYPE_CHECKING, Any

import numpy as np

from rsp_inertia.estimation.known_terms import KnownTerms
from rsp_inertia.estimation.layout import ZERO_NAME, theta_layout
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.toml_schema import (
    Bound,
    ContentError,
    config_class,
    iso_date,
    key,
    read_file,
    read_table,
)
from rsp_inertia.infra.toml_writer import checked_text, write_file
from rsp_inertia.plant.config import Certificate
from rsp_inertia.plant.experiment import CALIBRATION_FILE
from rsp_inertia.plant.geometry import HARMONIC_NAMES

if TYPE_CHECKING:
    from rsp_inertia.estimation.calibration import Calibration

__all__ = [
    "CalibrationFile",
    "Covariance",
    "Drive",
    "EmptyStage",
    "EncoderError",
    "Fixture",
    "Head",
    "MotorTempco",
    "PendulumStiffness",
    "calibration_file",
    "calibration_text",
    "read_calibration_file",
    "write_calibration_file",
]

HEADER = """\
calibration.toml: the rig's calibration, written by rsp-inertia calibrate; identify applies it
(docs/files.md). theta = [h_d, h_b, the empty system's harmonics [M0, Mc2, Ms2, Ms1, Mc1] of
each stage, the fixture's gravity [Gs, Gc], the encoder's zero offset, its error c1, s1,
c2, s2, ...]:
h_d, h_b = torque the body receives per unit of logged torque, motor driving / back-driven;
Gs, Gc = m g x_c, m g y_c of the fixture; the encoder reads phi + zero + e(phi),
e(phi) = sum_n c_n cos(n phi) + s_n sin(n phi). Each *_std is the square root of the
[covariance] matrix's diagonal entry. [pendulum]: the torsion element's stiffness from the
calibration folders' pendulum runs; [motor]: the torque constant's tempco (1/K), when the
runs measured it, and its covariance with theta; [inputs]: the sha256 of every file used."""

SHA256 = Bound(
    "a sha256 digest (64 hex digits)", lambda digest: re.fullmatch("[0-9a-f]{64}", digest)
)


@config_class
class Head:
    """What the calibration was made for and how well its fit went (``[calibration]``)."""

    device: str = key(doc="``[device] name`` of the experiment it was made for.")
    counts_per_rev: int = key(bound="> 0", doc="The encoder's, to recognise the device.")
    reference: bool = key(
        doc="Whether a reference experiment fixed the drive's gains and the encoder's error "
        "(false: gains 1, exact, and device.toml's stated encoder error)."
    )
    chi2_dof: float = key(
        nan=True,
        bound=">= 0",
        doc="Residual chi^2 per degree of freedom of the calibration fit; nan when it has no "
        "degrees of freedom.",
    )
    conventions: str = key(
        "",
        doc="One line on the rig's conventions (the gear's sense, phi's handedness, the "
        "encoder's zero, docs/method.md §1): verified by the reference, or not and how to "
        "verify them. Empty in files of older rsp-inertia.",
    )
    date: str | None = key(
        None,
        check=iso_date,
        doc="The day of the calibration (UTC), ISO 8601 ``YYYY-MM-DD``, as calibrate wrote "
        "the file; with device.toml's ``[device] calibration_interval_days`` it gives the "
        "calibration's due date (result.json ``record.calibration``). Absent in files of "
        "older rsp-inertia (no due date).",
    )
    torque_gain: float | None = key(
        None,
        bound="> 0",
        doc="Older files only (without ``[drive]``): logged torque / applied torque, read as "
        "both gains h_d = h_b = 1 / torque_gain.",
    )
    torque_gain_std: float | None = key(
        None, bound=">= 0", doc="Older files only: the std of ``torque_gain``."
    )


@config_class
class Drive:
    """The drive's gains by direction of power flow: the torque the body receives per unit
    of logged torque (``[drive]``; rsp_inertia.plant.transducers.drive_gains)."""

    gain_driving: float = key(
        bound="> 0", doc="h_d = eta_d / torque gain, while the motor drives the body."
    )
    gain_driving_std: float = key(bound=">= 0", doc="Std of ``gain_driving``.")
    gain_backdriven: float = key(
        bound="> 0", doc="h_b = 1 / (eta_b torque gain), while the body drives the motor back."
    )
    gain_backdriven_std: float = key(bound=">= 0", doc="Std of ``gain_backdriven``.")


@config_class
class EncoderError:
    """The encoder's reading error e(phi) = sum_n c_n cos(n phi) + s_n sin(n phi), orders
    n = 1, 2, ... (``[encoder]``; empty arrays: an exact encoder)."""

    error_cos: tuple[float, ...] = key(unit="rad", doc="c_n, one per order.")
    error_sin: tuple[float, ...] = key(unit="rad", doc="s_n, one per order.")
    error_cos_std: tuple[float, ...] = key(unit="rad", bound=">= 0", doc="Stds of c_n.")
    error_sin_std: tuple[float, ...] = key(unit="rad", bound=">= 0", doc="Stds of s_n.")
    zero: float | None = key(
        None,
        unit="rad",
        doc="z, the encoder's zero offset: it reads phi + z + e(phi), phi = 0 where the body "
        "frame's y points up (docs/method.md §1); measured with a reference that shows the "
        "rig's orientation, else 0 and exact. Absent in files of older rsp-inertia (read as 0, "
        "exact, and no ``zero`` among the covariance's parameters).",
    )
    zero_std: float | None = key(None, unit="rad", bound=">= 0", doc="Std of ``zero``.")


@config_class
class Fixture:
    """The fixture's gravity terms (``[fixture]``; docs/method.md §3)."""

    gravity: tuple[float, float] = key(
        unit="N m", names=("Gs", "Gc"), doc="[m g x_c, m g y_c] of the fixture."
    )
    gravity_std: tuple[float, float] = key(
        unit="N m", bound=">= 0", names=("Gs", "Gc"), doc="Their stds."
    )


@config_class
class EmptyStage:
    """One stage's empty system: tare and fixture (``[[stage]]``, in device.toml's order)."""

    gear_ratio: float = key(bound=">= 0", doc="The stage's gear ratio (device.toml's).")
    nodes_deg: tuple[float, ...] = key(unit="deg", doc="The stage's nodes (device.toml's).")
    empty_inertia: tuple[float, float, float, float, float] = key(
        unit="kg m^2",
        names=HARMONIC_NAMES,
        doc="The empty system's reduced inertia M_empty(phi) in harmonic form "
        "[M0, Mc2, Ms2, Ms1, Mc1] (docs/method.md §2).",
    )
    empty_inertia_std: tuple[float, float, float, float, float] = key(
        unit="kg m^2", bound=">= 0", names=HARMONIC_NAMES, doc="Their stds."
    )


@config_class
class PendulumStiffness:
    """The torsion element's stiffness from the calibration folders' pendulum runs
    (``[pendulum]``; rsp_inertia.estimation.stiffness)."""

    stiffness: float = key(unit="N m/rad", bound="> 0", doc="c, reduced to phi.")
    stiffness_std: float = key(unit="N m/rad", bound=">= 0", doc="Std of c.")
    nodes: int = key(bound="> 0", doc="Nodes with an empty and a reference run behind c.")


@config_class
class MotorTempco:
    """The torque constant's tempco as the calibration runs measured it (``[motor]``; absent
    when they did not: identify then takes device.toml's; rsp_inertia.estimation.tempco)."""

    torque_constant_tempco: float = key(
        unit="1/K",
        doc="alpha, measured: identify compensates the logs with it instead of device.toml's "
        "(docs/method.md §3, \"Temperature\").",
    )
    torque_constant_tempco_std: float = key(
        unit="1/K", bound=">= 0", doc="Its std: identify's budget line 'torque constant vs "
        "temperature'.",
    )
    reference_temperature: float = key(
        unit="degC",
        doc="device.toml's ``[motor] reference_temperature`` at calibration: the temperature "
        "at which the calibrated gains hold.",
    )
    covariance: tuple[float, ...] = key(
        doc="alpha's covariance with each parameter of ``[covariance]``, in its order "
        "(1/K times the parameter's unit).",
    )


@config_class
class Covariance:
    """The covariance of theta (``[covariance]``); identify propagates it."""

    parameters: tuple[str, ...] = key(
        doc="The names of theta in order (rsp_inertia.estimation.layout.theta_layout): "
        "h_d, h_b, M0[s], Mc2[s], Ms2[s], Ms1[s], Mc1[s] per stage s, Gs, Gc, c1, s1, ... "
        "(older files: h, the harmonics, Gs, Gc)."
    )
    matrix: tuple[tuple[float, ...], ...] = key(
        doc="One row per parameter, one entry per parameter, in theta's units."
    )
    certificate: tuple[tuple[float, ...], ...] | None = key(
        None,
        doc="The reference certificate's share of ``matrix`` (what the reference body's "
        "stated uncertainty adds through the calibration fit; identify's budget line "
        "'reference certificate'), the same shape; absent: a reference without stds, or a "
        "file of an older rsp-inertia.",
    )


@config_class
class CalibrationFile:
    """The rig's calibration as ``calibration.toml`` holds it."""

    calibration: Head = key(doc="What it was made for, and its fit's chi^2.")
    drive: Drive | None = key(doc="The drive's gains (none in older files).")
    encoder: EncoderError | None = key(doc="The encoder's error (none in older files).")
    fixture: Fixture = key(doc="The fixture's gravity terms.")
    stages: tuple[EmptyStage, ...] = key(name="stage", doc="The ``[[stage]]`` tables in order.")
    pendulum: PendulumStiffness | None = key(
        doc="The stiffness, when both calibration folders have pendulum runs at a node."
    )
    covariance: Covariance = key(doc="The covariance of theta.")
    motor: MotorTempco | None = key(
        doc="The torque constant's tempco, when the calibration runs measured it."
    )
    certificate: Certificate | None = key(
        doc="The reference body's certificate (reference.toml's ``[certificate]``): id, "
        "issuer, date; absent without a reference or when reference.toml names none."
    )
    inputs: dict[str, str] = key(
        absent={},
        bound=SHA256,
        free_key="file",
        doc="Input file (path as given on the command line) -> sha256 of its bytes.",
    )

    @property
    def legacy(self) -> bool:
        """Whether an older rsp-inertia wrote it (no ``[drive]``, no ``[encoder]``)."""
        return self.drive is None

    @property
    def orders(self) -> int:
        """Orders of the encoder's error (0 in older files)."""
        return 0 if self.encoder is None else len(self.encoder.error_cos)

    @property
    def has_zero(self) -> bool:
        """Whether the file states the encoder's zero offset (older files do not)."""
        return self.encoder is not None and self.encoder.zero is not None

    def parameters(self) -> list[str]:
        """The names of theta that the file's tables imply (:class:`Covariance`): without a
        stated zero offset (older files), theta's names but ``zero``."""
        names = theta_layout(len(self.stages), self.orders).names()
        if not self.has_zero:
            names.remove(ZERO_NAME)
        return ["h", *names[2:]] if self.legacy else names

    def pendulum_stiffness(self) -> tuple[float, float] | None:
        """(c, std), N m/rad, of ``[pendulum]``: the torsion element's calibrated stiffness;
        None without the table."""
        if self.pendulum is None:
            return None
        return self.pendulum.stiffness, self.pendulum.stiffness_std

    def known_terms(self) -> KnownTerms:
        """The calibrated terms and their covariance; an older file's as a lossless drive
        (its torque_gain for both gains) and an exact encoder. Whether the file was made for
        the experiment's device is rsp_inertia.estimation.calibration.calibrated_known_terms's
        check."""
        inertia = np.array([stage.empty_inertia for stage in self.stages], dtype=float)
        gravity = np.array(self.fixture.gravity, dtype=float)
        size = len(self.covariance.parameters)
        cov = np.array(self.covariance.matrix, dtype=float).reshape(size, size)
        share = self.covariance.certificate
        certificate = None if share is None else np.array(share, dtype=float)
        zero = 0.0
        if self.drive is None:
            gain = self.calibration.torque_gain
            gains = (1.0 / gain, 1.0 / gain)
            encoder = np.zeros(0)
            # theta = [h, ...]: h's row and column become both gains', fully correlated.
            cov = cov[np.ix_([0, *range(size)], [0, *range(size)])]
        else:
            gains = (self.drive.gain_driving, self.drive.gain_backdriven)
            encoder = np.empty(2 * self.orders)
            encoder[0::2], encoder[1::2] = self.encoder.error_cos, self.encoder.error_sin
            if self.has_zero:
                zero = self.encoder.zero
        if not self.has_zero:  # an older file: the zero 0 and exact, its row and column zero
            at = theta_layout(len(self.stages), encoder.size // 2).slice("zero").start
            cov = np.insert(np.insert(cov, at, 0.0, axis=0), at, 0.0, axis=1)
        return KnownTerms(
            gains, inertia, gravity, cov, calibrated=True, encoder=encoder, zero=zero,
            certificate_cov=certificate,
        )


def calibration_file(calibration: Calibration) -> CalibrationFile:
    """What ``rsp-inertia calibrate`` found, as the file holds it.

    Parameters
    ----------
    calibration : rsp_inertia.estimation.calibration.Calibration
        The calibrated terms with their covariance, what they were made for, the pendulum's
        stiffness and the input files' sha256.

    Returns
    -------
    CalibrationFile
        Every number a Python float; each std the square root of the covariance's diagonal
        entry; the covariance's parameters ``calibration.known.names()``.
    """
    k = calibration.known
    std = k.std
    gains_std = std[k.gains_slice]
    encoder_std = std[k.encoder_slice]
    c = calibration.stiffness
    return CalibrationFile(
        calibration=Head(
            device=calibration.device_name,
            counts_per_rev=int(calibration.counts_per_rev),
            reference=bool(calibration.reference),
            chi2_dof=float(calibration.chi2_dof),
            conventions=calibration.conventions,
            date=calibration.date,
        ),
        drive=Drive(
            gain_driving=k.gains[0],
            gain_driving_std=float(gains_std[0]),
            gain_backdriven=k.gains[1],
            gain_backdriven_std=float(gains_std[1]),
        ),
        encoder=EncoderError(
            error_cos=_floats(k.encoder[0::2]),
            error_sin=_floats(k.encoder[1::2]),
            error_cos_std=_floats(encoder_std[0::2]),
            error_sin_std=_floats(encoder_std[1::2]),
            zero=k.zero,
            zero_std=float(std[k.zero_slice][0]),
        ),
        fixture=Fixture(gravity=_floats(k.gravity), gravity_std=_floats(std[k.gravity_slice])),
        stages=tuple(
            EmptyStage(
                gear_ratio=float(gear_ratio),
                nodes_deg=_floats(nodes),
                empty_inertia=_floats(k.inertia[s - 1]),
                empty_inertia_std=_floats(std[k.harmonics_slice(s)]),
            )
            for s, (gear_ratio, nodes) in enumerate(
                zip(calibration.gear_ratios, calibration.nodes_deg, strict=True), 1
            )
        ),
        pendulum=None
        if c is None
        else PendulumStiffness(float(c.stiffness), float(c.stiffness_std), len(c.per_node)),
        covariance=Covariance(
            parameters=tuple(k.names()),
            matrix=tuple(_floats(row) for row in k.cov),
            certificate=None
            if k.certificate_cov is None
            else tuple(_floats(row) for row in k.certificate_cov),
        ),
        motor=_motor_tempco(calibration),
        certificate=calibration.certificate,
        inputs={str(path): str(digest) for path, digest in calibration.inputs.items()},
    )


def _motor_tempco(calibration: Calibration) -> MotorTempco | None:
    """``[motor]``: the tempco when the runs measured it
    (rsp_inertia.estimation.tempco.TempcoFit.informed), else None."""
    found = calibration.tempco_fit
    if found is None or not found.informed:
        return None
    return MotorTempco(
        torque_constant_tempco=float(found.estimate),
        torque_constant_tempco_std=float(found.std),
        reference_temperature=float(found.reference_temperature),
        covariance=_floats(found.covariance),
    )


def _floats(values: Any) -> tuple[float, ...]:
    return tuple(float(v) for v in values)


def read_calibration_file(
    path_or_doc: str | os.PathLike | dict[str, Any], source: str | None = None
) -> CalibrationFile:
    """Read a ``calibration.toml``.

    Parameters
    ----------
    path_or_doc : str, os.PathLike or dict
        The file, or its parsed TOML document.
    source : str, optional
        The file's name in messages (default: the path; 'calibration.toml' for a document).

    Returns
    -------
    CalibrationFile
        Its tables; :meth:`CalibrationFile.known_terms` gives what identify applies.

    Raises
    ------
    InputError
        ``{source}: {dotted key}: {fault}``: the file is missing or not TOML; a key is
        missing, unknown, of the wrong type or out of its bounds; an array's length differs
        from what its table implies (the encoder's orders, five harmonics, one covariance
        row and column per parameter); the parameters are not theta's names.

    Examples
    --------
    >>> read_calibration_file("EXP/calibration.toml").drive.gain_driving  # doctest: +SKIP
    0.94713...
    """
    if isinstance(path_or_doc, dict):
        doc, name = path_or_doc, CALIBRATION_FILE
    else:
        doc, name = read_file(path_or_doc), str(path_or_doc)
    try:
        return _calibration(doc)
    except ContentError as error:
        raise InputError(f"{source or name}: {error}") from None


def write_calibration_file(path: str | os.PathLike, value: CalibrationFile) -> None:
    """Write ``value`` to ``path`` as the ``calibration.toml`` text :func:`calibration_text`
    gives, atomically, once :func:`read_calibration_file` reads it back equal.

    Parameters
    ----------
    path : str or os.PathLike
        The file; its folder must exist.
    value : CalibrationFile
        The calibration, e.g. :func:`calibration_file` of what calibrate found.

    Raises
    ------
    ValueError
        ``value`` breaks a rule of calibration.toml (the reader's message, ``path`` in
        front); nothing is written.
    """
    write_file(path, value, HEADER, _calibration)


def calibration_text(value: CalibrationFile, source: str = CALIBRATION_FILE) -> str:
    """The ``calibration.toml`` text of ``value``: a header on theta, then every table in
    the order of :class:`CalibrationFile` with each key's unit as a comment; the same value
    gives the same bytes.

    Raises
    ------
    ValueError
        ``value`` breaks a rule of calibration.toml or would not read back equal (the
        message begins with ``source``).
    """
    return checked_text(value, HEADER, _calibration, source)


def _calibration(doc: dict[str, Any]) -> CalibrationFile:
    """The CalibrationFile of a parsed calibration.toml, with the rules that join its tables."""
    value = read_table(CalibrationFile, doc)
    head = value.calibration
    if value.drive is None:
        if value.encoder is not None or head.torque_gain is None:
            raise ContentError("drive", "missing required table [drive]")
    else:
        if value.encoder is None:
            raise ContentError("encoder", "missing required table [encoder]")
        for name in ("torque_gain", "torque_gain_std"):
            if getattr(head, name) is not None:
                raise ContentError(f"calibration.{name}", "only in older files, without [drive]")
    if value.encoder is not None:
        if (value.encoder.zero is None) != (value.encoder.zero_std is None):
            given, missing = ("zero", "zero_std") if value.encoder.zero_std is None else (
                "zero_std", "zero")
            raise ContentError(f"encoder.{missing}", f"missing: encoder.{given} is given")
        orders = value.orders
        for name in ("error_sin", "error_cos_std", "error_sin_std"):
            got = len(getattr(value.encoder, name))
            if got != orders:
                raise ContentError(
                    f"encoder.{name}",
                    f"must have one entry per order of encoder.error_cos ({orders}), got {got}",
                )
    names, cov = value.parameters(), value.covariance
    if len(cov.parameters) != len(names):
        raise ContentError(
            "covariance.parameters",
            f"must name the {len(names)} parameters of {len(value.stages)} stage(s) and "
            f"{value.orders} encoder order(s), got {len(cov.parameters)}",
        )
    for k, (name, got) in enumerate(zip(names, cov.parameters, strict=True), 1):
        if got != name:
            raise ContentError(f"covariance.parameters[{k}]", f"must be {name!r}, got {got!r}")
    if len(cov.matrix) != len(names):
        raise ContentError(
            "covariance.matrix",
            f"must have one row per parameter ({len(names)}), got {len(cov.matrix)}",
        )
    if len(cov.matrix[0]) != len(names):
        raise ContentError(
            "covariance.matrix[1]",
            f"must have one entry per parameter ({len(names)}), got {len(cov.matrix[0])}",
        )
    if value.motor is not None and len(value.motor.covariance) != len(names):
        raise ContentError(
            "motor.covariance",
            f"must have one entry per parameter of covariance.parameters ({len(names)}), got "
            f"{len(value.motor.covariance)}",
        )
    if cov.certificate is not None:
        if value.legacy or not value.has_zero:
            raise ContentError("covariance.certificate", "not in files without encoder.zero")
        if len(cov.certificate) != len(names) or len(cov.certificate[0]) != len(names):
            raise ContentError(
                "covariance.certificate",
                f"must be {len(names)} x {len(names)}, as covariance.matrix",
            )
    return value
