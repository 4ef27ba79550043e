"""``calibrate``'s result: a view of the library's record
(rsp_inertia.estimation.calibration.Calibration) in the terms of the file written."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rsp_inertia.figure_files import save_figures
from rsp_inertia.infra.frozen import read_only
from rsp_inertia.infra.toml_writer import document
from rsp_inertia.plant.experiment import ENCODER_FIGURE
from rsp_inertia.results.common import Drawer, Drawn, json_text

if TYPE_CHECKING:
    from rsp_inertia.estimation.calibration import Calibration
    from rsp_inertia.estimation.calibration_file import CalibrationFile

__all__ = ["CalibrateResult"]


def _interleaved(cos, sin) -> np.ndarray:
    """``[c_1, s_1, c_2, s_2, ...]`` from the cosine and sine coefficients."""
    out = np.empty(2 * len(cos))
    out[0::2], out[1::2] = cos, sin
    return out


@dataclass(frozen=True, eq=False)
class CalibrateResult(Drawn):
    """The rig's calibration, as written to ``EXP/calibration.toml``.

    Returned by :func:`rsp_inertia.calibrate`; identify applies the file from then on. A
    view of the library's record ``calibration``: its values are read from the file it
    makes (``calibration.to_file()``, what calibrate writes), so they are exactly what
    identify will use.

    Attributes
    ----------
    drive_gains : numpy.ndarray, shape (2,)
        ``[h_d, h_b]``: the torque the body receives per unit of logged torque while the
        motor drives it (eta_d / torque gain) and while the body drives the motor back
        (1 / (eta_b torque gain)); ``[1, 1]`` without a reference experiment.
    drive_gains_std : numpy.ndarray, shape (2,)
        Their standard deviations (0 without a reference experiment: taken as exact).
    round_trip_efficiency, round_trip_efficiency_std : float
        h_d / h_b = eta_d eta_b, the drive's round-trip efficiency, and its std.
    encoder_error : numpy.ndarray, shape (2 orders,)
        rad, ``[c_1, s_1, c_2, s_2, ...]`` of the encoder's reading error
        e(phi) = sum c_n cos(n phi) + s_n sin(n phi).
    encoder_error_std : numpy.ndarray, shape (2 orders,)
        rad.
    encoder_zero, encoder_zero_std : float
        rad, the encoder's zero offset (it reads phi + zero + e(phi)) and its std: measured
        with a reference that shows the rig's orientation, else 0 and 0.
    conventions : str
        One line on the rig's conventions (the gear's sense, phi's handedness, the encoder's
        zero): verified by the reference, or not and how to verify them.
    reference : bool
        Whether a reference experiment fixed the drive's gains and the encoder's error.
    empty_inertia : numpy.ndarray, shape (stages, 5)
        kg m^2, per stage the empty system's reduced inertia in harmonic form
        ``[M0, Mc2, Ms2, Ms1, Mc1]`` (tare and fixture).
    empty_inertia_std : numpy.ndarray, shape (stages, 5)
        kg m^2.
    fixture_gravity : numpy.ndarray, shape (2,)
        N m, ``[m g x_c, m g y_c]`` of the fixture.
    fixture_gravity_std : numpy.ndarray, shape (2,)
        N m.
    stiffness, stiffness_std : float or None
        N m/rad, the torsion pendulum's stiffness, when both folders have pendulum runs.
    tempco, tempco_std : float or None
        1/K, the torque constant's tempco alpha and its std, when the calibration runs
        measured it (calibration.toml ``[motor]``; docs/method.md §3, "Temperature"); None:
        identify takes device.toml's.
    chi2_dof : float
        Residual chi^2 per degree of freedom of the calibration fit.
    warnings : tuple of str
        What the calibration's own checks found.
    path : pathlib.Path
        The calibration.toml written.
    figure : pathlib.Path or None
        The encoder's error curve drawn (``EXP/encoder_error.png``: e(phi) and e'(phi) over a
        turn with their 1-std band), when the calibration has encoder terms.
    calibration : rsp_inertia.estimation.calibration.Calibration
        The full record (the calibrated terms with their covariance, the input files'
        sha256, the model tests).
    drawer : callable or None
        What draws the figures (:meth:`draw`): the function of rsp_inertia.plots its command
        handed it; None for a result made without one.

    Examples
    --------
    >>> cal = rsp_inertia.calibrate("bench-A", "empty", "reference")    # doctest: +SKIP
    >>> cal.drive_gains, cal.round_trip_efficiency                      # doctest: +SKIP
    (array([0.94713..., 1.08697...]), 0.87135...)
    """

    calibration: Calibration = field(repr=False)
    path: Path
    drawer: Drawer | None = field(default=None, repr=False, compare=False)

    @cached_property
    def _file(self) -> CalibrationFile:
        """The calibration as calibration.toml holds it (what calibrate wrote)."""
        return self.calibration.to_file()

    @property
    def drive_gains(self) -> np.ndarray:
        """``[h_d, h_b]`` (see the class's Attributes)."""
        drive = self._file.drive
        return read_only(np.array([drive.gain_driving, drive.gain_backdriven]))

    @property
    def drive_gains_std(self) -> np.ndarray:
        """Standard deviations of ``drive_gains``."""
        drive = self._file.drive
        return read_only(np.array([drive.gain_driving_std, drive.gain_backdriven_std]))

    @property
    def round_trip_efficiency(self) -> float:
        """h_d / h_b = eta_d eta_b."""
        drive = self._file.drive
        return drive.gain_driving / drive.gain_backdriven

    @property
    def round_trip_efficiency_std(self) -> float:
        """Its standard deviation."""
        return self._file.known_terms().round_trip_std()

    @property
    def encoder_error(self) -> np.ndarray:
        """rad, ``[c_1, s_1, c_2, s_2, ...]``."""
        encoder = self._file.encoder
        return read_only(_interleaved(encoder.error_cos, encoder.error_sin))

    @property
    def encoder_error_std(self) -> np.ndarray:
        """rad."""
        encoder = self._file.encoder
        return read_only(_interleaved(encoder.error_cos_std, encoder.error_sin_std))

    @property
    def encoder_zero(self) -> float:
        """rad, the encoder's zero offset."""
        return float(self._file.encoder.zero or 0.0)

    @property
    def encoder_zero_std(self) -> float:
        """rad, its std."""
        return float(self._file.encoder.zero_std or 0.0)

    @property
    def conventions(self) -> str:
        """The calibration's one line on the rig's conventions."""
        return self._file.calibration.conventions

    @property
    def reference(self) -> bool:
        """Whether a reference experiment fixed the drive's gains and the encoder's error."""
        return self._file.calibration.reference

    @property
    def empty_inertia(self) -> np.ndarray:
        """kg m^2, (stages, 5)."""
        return read_only(np.array([s.empty_inertia for s in self._file.stages]))

    @property
    def empty_inertia_std(self) -> np.ndarray:
        """kg m^2, (stages, 5)."""
        return read_only(np.array([s.empty_inertia_std for s in self._file.stages]))

    @property
    def fixture_gravity(self) -> np.ndarray:
        """N m, ``[m g x_c, m g y_c]``."""
        return read_only(np.array(self._file.fixture.gravity))

    @property
    def fixture_gravity_std(self) -> np.ndarray:
        """N m."""
        return read_only(np.array(self._file.fixture.gravity_std))

    @property
    def stiffness(self) -> float | None:
        """N m/rad, the torsion pendulum's stiffness (None: not calibrated)."""
        pendulum = self._file.pendulum
        return None if pendulum is None else pendulum.stiffness

    @property
    def stiffness_std(self) -> float | None:
        """N m/rad."""
        pendulum = self._file.pendulum
        return None if pendulum is None else pendulum.stiffness_std

    @property
    def tempco(self) -> float | None:
        """1/K, the tempco the runs measured (None: device.toml's is kept)."""
        motor = self._file.motor
        return None if motor is None else motor.torque_constant_tempco

    @property
    def tempco_std(self) -> float | None:
        """1/K, its std."""
        motor = self._file.motor
        return None if motor is None else motor.torque_constant_tempco_std

    @property
    def chi2_dof(self) -> float:
        """Residual chi^2 per degree of freedom of the calibration fit."""
        return self._file.calibration.chi2_dof

    @property
    def warnings(self) -> tuple[str, ...]:
        """What the calibration's own checks found."""
        return tuple(self.calibration.warnings)

    @property
    def figure(self) -> Path | None:
        """The encoder's error curve drawn, when the calibration has encoder terms."""
        return self.path.parent / ENCODER_FIGURE if self.calibration.known.orders else None

    def __str__(self) -> str:
        lines = [str(self.calibration), f"calibration -> {self.path}"]
        if self.figure is not None:
            lines.append(f"encoder error curve -> {self.figure}")
        return "\n".join(lines)

    def to_json(self) -> str:
        """The calibration as JSON: calibration.toml's tables and keys, plus ``warnings``.

        Returns
        -------
        str
            ``{"calibration": {"device", "counts_per_rev", "reference", "chi2_dof"},
            "drive": {...}, "encoder": {...}, "fixture": {...}, "stage": [...], "pendulum":
            {...} (when calibrated), "covariance": {...}, "motor": {...} (when the tempco was
            measured), "inputs": {...}, "warnings": [...]}``
            (NaN written as null).
        """
        doc = document(self._file)
        doc["warnings"] = list(self.calibration.warnings)
        return json_text(doc)

    def figures(self, folder: str | Path | None = None) -> list[Path]:
        """Draw the encoder's error curve ``encoder_error.png`` (calibrate has drawn it into
        EXP already), when the calibration has encoder terms.

        Parameters
        ----------
        folder : str or pathlib.Path, optional
            Where to write it (created if needed). Default: the experiment folder.

        Returns
        -------
        list of pathlib.Path
            ``[folder / "encoder_error.png"]``, or ``[]`` without encoder terms.
        """
        return save_figures(self.draw(), self.path.parent if folder is None else folder)
