"""What identify took from calibration.toml: result.json's ``calibration`` (docs/files.md).

:class:`CalibrationSummary` is ``Identification.calibration``; the known terms make it
(rsp_inertia.estimation.known_terms.KnownTerms.summary). Plain floats in tuples, so that
:meth:`CalibrationSummary.to_dict` is result.json's section as it is written.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["CalibrationSummary", "RefinedCalibration"]


@dataclass(frozen=True)
class RefinedCalibration:
    """The drive's gains and the encoder's error as identify's runs left them: the calibrated
    terms after the least squares refined them with the runs' information."""

    drive_gains: tuple[float, float]
    """``(h_d, h_b)``: body torque per logged torque while driving and while back-driven."""
    drive_gains_std: tuple[float, float]
    """Their standard deviations."""
    round_trip_efficiency: float
    """h_d / h_b = eta_d eta_b."""
    round_trip_efficiency_std: float
    """Its standard deviation (first order)."""
    encoder_error: tuple[float, ...]
    """rad, ``(c_1, s_1, c_2, s_2, ...)`` of the encoder's reading error (empty: none)."""
    encoder_error_std: tuple[float, ...]
    """rad."""
    encoder_zero: float = 0.0
    """rad, the encoder's zero offset (it reads phi + zero + e(phi))."""
    encoder_zero_std: float = 0.0
    """rad."""

    def to_dict(self) -> dict:
        """result.json's ``calibration.refined``."""
        return {
            "drive_gains": list(self.drive_gains),
            "drive_gains_std": list(self.drive_gains_std),
            "round_trip_efficiency": self.round_trip_efficiency,
            "round_trip_efficiency_std": self.round_trip_efficiency_std,
            "encoder_error": list(self.encoder_error),
            "encoder_error_std": list(self.encoder_error_std),
            "encoder_zero": self.encoder_zero,
            "encoder_zero_std": self.encoder_zero_std,
        }


@dataclass(frozen=True)
class CalibrationSummary:
    """The calibrated terms identify applied, each with its standard deviation, and how the
    runs refined the drive's gains and the encoder's error."""

    drive_gains: tuple[float, float]
    """``(h_d, h_b)``: body torque per logged torque while driving and while back-driven."""
    drive_gains_std: tuple[float, float]
    """Their standard deviations."""
    round_trip_efficiency: float
    """h_d / h_b = eta_d eta_b."""
    round_trip_efficiency_std: float
    """Its standard deviation (first order)."""
    empty_inertia: tuple[tuple[float, ...], ...]
    """kg m^2, per stage the empty system's reduced inertia ``(M0, Mc2, Ms2, Ms1, Mc1)``."""
    empty_inertia_std: tuple[tuple[float, ...], ...]
    """kg m^2."""
    fixture_gravity: tuple[float, float]
    """N m, ``(m g x_c, m g y_c)`` of the fixture."""
    fixture_gravity_std: tuple[float, float]
    """N m."""
    encoder_error: tuple[float, ...]
    """rad, ``(c_1, s_1, c_2, s_2, ...)`` of the encoder's reading error (empty: none)."""
    encoder_error_std: tuple[float, ...]
    """rad."""
    encoder_zero: float = 0.0
    """rad, the encoder's zero offset (it reads phi + zero + e(phi); 0 and exact unless a
    reference measured it)."""
    encoder_zero_std: float = 0.0
    """rad."""
    conventions: str = ""
    """The calibration's one line on the rig's conventions (gear sense, phi's handedness,
    the encoder's zero): verified by the reference, or not, and how to verify them."""
    refined: RefinedCalibration | None = None
    """The drive's gains and the encoder's error after the runs (None: not computed)."""

    def to_dict(self) -> dict:
        """result.json's ``calibration`` (``refined`` only when computed)."""
        out = {
            "drive_gains": list(self.drive_gains),
            "drive_gains_std": list(self.drive_gains_std),
            "round_trip_efficiency": self.round_trip_efficiency,
            "round_trip_efficiency_std": self.round_trip_efficiency_std,
            "empty_inertia": [list(row) for row in self.empty_inertia],
            "empty_inertia_std": [list(row) for row in self.empty_inertia_std],
            "fixture_gravity": list(self.fixture_gravity),
            "fixture_gravity_std": list(self.fixture_gravity_std),
            "encoder_error": list(self.encoder_error),
            "encoder_error_std": list(self.encoder_error_std),
            "encoder_zero": self.encoder_zero,
            "encoder_zero_std": self.encoder_zero_std,
            "conventions": self.conventions,
        }
        if self.refined is not None:
            out["refined"] = self.refined.to_dict()
        return out

    def refinable(self) -> RefinedCalibration:
        """The terms the runs refine (the drive's gains and the encoder's error), as here."""
        return RefinedCalibration(
            drive_gains=self.drive_gains,
            drive_gains_std=self.drive_gains_std,
            round_trip_efficiency=self.round_trip_efficiency,
            round_trip_efficiency_std=self.round_trip_efficiency_std,
            encoder_error=self.encoder_error,
            encoder_error_std=self.encoder_error_std,
            encoder_zero=self.encoder_zero,
            encoder_zero_std=self.encoder_zero_std,
        )
