"""The torque constant's tempco alpha, measured by calibrate (docs/method.md §3, "Temperature").

Every log whose rig logs a temperature is read with the torque at the torque constant's
reference temperature: each row's logged torque times 1 + alpha (T_mag - T_ref)
(rsp_inertia.plant.logs.compensate_temperature, alpha device.toml's). The balances are linear
in alpha: the work sum (rsp_inertia.plant.logs.motor_work) is linear in each row's torque;
the factor is positive, so no row changes its power-flow split; a braking's constant torque
is the mean of the logged torque over the factor, which alpha does not move; the smoother
never sees the torque. So a balance's work parts at alpha + d are its parts at alpha plus
d times their response (:func:`tempco_work_parts`), and calibrate's least squares takes d as
one more unknown (rsp_inertia.estimation.calibration), its column - (h_d dW_d/dalpha + h_b
dW_b/dalpha), the gains those of the fit before (the product h d is linearised there: its
second order, (h - h_0) d, is a 1e-3 part of d).

Only the reference runs fix the torque's scale; alpha then shows in how the scale the runs
need follows their magnets' temperature, across the runs and within them. A temperature
common to every run is confounded with the gains: with T_ref far from the runs' temperature,
alpha's estimate and the gains' are correlated (calibration.toml keeps that covariance), and
reference_temperature at the runs' mean magnet temperature makes them nearly independent.

Whether the runs determine alpha is a matter of information, not of kelvin: the fit carries
the stated alpha as a prior N(alpha_stated, std_stated^2); when its posterior variance falls
below :data:`TEMPCO_INFORMED` of the prior's, the runs measured alpha and calibration.toml
carries it (identify uses it instead of device.toml's); otherwise device.toml's is kept and
calibrate's line says how well the runs would have determined it (the data's own std,
(1 / var_post - 1 / var_prior)^-1/2).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from rsp_inertia.estimation.passes import AngleSample, PassEstimate, gap_work
from rsp_inertia.plant.logs import motor_work
from rsp_inertia.plant.transducers import magnet_temperature

__all__ = [
    "TEMPCO_INFORMED",
    "TEMPCO_NAME",
    "TempcoFit",
    "pass_tempco_work",
]

TEMPCO_NAME = "alpha"
"""The unknown of calibrate's fit: alpha's change from the stated value, 1/K."""

TEMPCO_INFORMED = 0.25
"""The runs measure alpha when its posterior variance is below this fraction of the stated
prior's (their information at least three times the prior's: the std at least halved)."""

TEMPCO_STEP = 1e-4
"""1/K, the change of alpha over which :func:`pass_tempco_work` takes the work's response
(exact for any step: the work is linear in alpha; this keeps every factor positive)."""


def pass_tempco_work(
    motor, est: PassEstimate, at: AngleSample, start_lag: float = 0.0
) -> tuple[np.ndarray, np.ndarray] | None:
    """d/dalpha of a pass's motor work and of its back-driven part at the angles of ``at``:
    the pass's own work sum (rsp_inertia.plant.logs.motor_work, its gaps' correction,
    :meth:`PassEstimate.sample_at`) on the same smoothed angle with the factor 1 + alpha rise
    of every row moved by :data:`TEMPCO_STEP` rise, less the pass's, over the step (module
    docstring: exact, the work being linear in alpha).

    Parameters
    ----------
    motor : device.toml's ``[motor]``
        Its ``temperature_lag`` and ``reference_temperature`` (rsp_inertia.plant.config.Motor).
    est : PassEstimate
        The pass, its log compensated (:attr:`rsp_inertia.plant.logs.Log.torque_factor`).
    at : AngleSample
        ``est.sample_at(phi)``, the balance's angles.
    start_lag : float, optional
        K, the magnets' lag at the pass's first row, as its log was compensated
        (rsp_inertia.plant.logs.reverse_start_lag for a reverse; else 0).

    Returns
    -------
    (numpy.ndarray, numpy.ndarray) or None
        J K, dW/dalpha and its back-driven part at each angle; None for a log without a
        temperature or not compensated.
    """
    log = est.log
    if log.temperature is None or log.torque_factor is None:
        return None
    rise = magnet_temperature(log.temperature, log.t, motor.temperature_lag, start_lag)
    rise -= motor.reference_temperature
    factor = log.torque_factor + TEMPCO_STEP * rise
    torque = log.torque * (factor / log.torque_factor)
    shifted_log = dataclasses.replace(log, torque=torque, torque_factor=factor)
    work, back, _, mean = motor_work(
        torque, est.smoothed.phi, est.torque_mean is not None, factor
    )
    if mean is None:
        correction, correction_back, _ = gap_work(shifted_log, est.smoothed, est.dropped)
        work += correction
        back += correction_back
    shifted = dataclasses.replace(
        est, log=shifted_log, work=work, work_back=back, torque_mean=mean
    ).sample_at(at.phi)
    return (shifted.work - at.work) / TEMPCO_STEP, (shifted.work_back - at.work_back) / TEMPCO_STEP


@dataclass(frozen=True)
class TempcoFit:
    """What calibrate's fit found of alpha (module docstring)."""

    stated: float
    """1/K, device.toml's ``torque_constant_tempco``, with which the logs were compensated."""
    stated_std: float
    """1/K, its ``torque_constant_tempco_std``: the prior's std."""
    estimate: float
    """1/K, alpha's posterior mean."""
    std: float
    """1/K, its posterior std."""
    covariance: tuple[float, ...] = ()
    """1/K times theta's units: alpha's covariance with every calibrated term of theta, in
    theta's order (rsp_inertia.estimation.layout.theta_layout)."""
    reference_temperature: float = math.nan
    """degC, device.toml's ``reference_temperature``: the compensated logs' and the calibrated
    gains' temperature."""
    prior_rejected: bool = False
    """The runs rejected the stated prior (rsp_inertia.estimation.calibration.TEMPCO_REJECTED):
    ``estimate`` and ``std`` are then the runs' alone."""

    @property
    def data_std(self) -> float:
        """1/K, the std to which the runs alone determine alpha: (1 / var_post - 1 /
        var_prior)^-1/2 (inf when they carry no information; the posterior's own when the
        prior was rejected)."""
        if self.prior_rejected:
            return self.std
        information = 1.0 / self.std**2 - 1.0 / self.stated_std**2
        return math.inf if information <= 0.0 else 1.0 / math.sqrt(information)

    @property
    def informed(self) -> bool:
        """Whether the runs measured alpha: var_post below :data:`TEMPCO_INFORMED` var_prior."""
        return self.std**2 < TEMPCO_INFORMED * self.stated_std**2
