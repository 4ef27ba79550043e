"""Nominal model of a stage from its braking log, for the program's feedforward.

Lagrange's equation (docs/method.md §3, rsp_inertia.plant.model) is linear in the harmonic
coefficients of M(phi), the gravity terms and the dissipation coefficients (a1, a2, a3); the
spring is known from device.toml. It is fitted to the smoothed braking pass by modulating
functions (rsp_inertia.estimation.modulated: the momentum form over overlapping 1 s windows,
integrated by parts, so that neither the acceleration nor a speed at one instant enters a
regressor). It only has to be good enough for feedforward: the regulator absorbs the rest
(and the identification never uses it).

One parameter cannot come from a braking pass: with a constant braking torque, Coulomb
friction a1 is a constant torque too, and only (u - a1) enters; worse, (M, a1 - u, a2, a3,
gravity) then fit equally well at any common scale, so the absolute inertia is lost (that
is what the reverse pass of the RSP method restores). The fit therefore puts a1 = 0: M comes
out too small by the fraction a1 / braking_torque (2% on the default stage 1 at the paper's
friction), well inside what the regulator has to absorb anyway.
"""

from __future__ import annotations

import numpy as np

from rsp_inertia.estimation.modulated import MODEL_UNKNOWNS, fit_modulated
from rsp_inertia.estimation.smoothing import Smoothed
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.logs import Log, torque_noise
from rsp_inertia.plant.model import ModelParameters

__all__ = ["UNKNOWN", "fit_nominal", "fit_nominal_with_covariance"]

UNKNOWN = tuple(name for name in MODEL_UNKNOWNS if name != FRICTION.static)
"""Parameters fitted, most important first: a short pass fits only the first ones (the others
stay 0: the regulator absorbs what the feedforward lacks). The spring's (c, phi0) come from
device.toml, a1 is put to 0 (module docstring)."""


def fit_nominal(device: Device, stage: int, log: Log, sm: Smoothed) -> ModelParameters:
    """Least-squares nominal model of stage ``stage`` from its smoothed braking pass
    (:func:`fit_nominal_with_covariance`, without the covariance).

    Parameters
    ----------
    device : Device
        The gimbal (its spring is known).
    stage : int
        The stage number, from 1 (for messages).
    log : Log
        The stage's braking log.
    sm : Smoothed
        The smoothed braking pass.

    Returns
    -------
    ModelParameters
        The nominal model, a1 = 0 (module docstring).
    """
    return fit_nominal_with_covariance(device, stage, log, sm)[0]


def fit_nominal_with_covariance(
    device: Device, stage: int, log: Log, sm: Smoothed
) -> tuple[ModelParameters, np.ndarray]:
    """Least-squares nominal model of stage ``stage`` from its smoothed braking pass, and the
    covariance of its friction slopes.

    The equation of motion is fitted in its momentum form, modulated over overlapping
    windows of the pass (rsp_inertia.estimation.modulated.fit_modulated): linear in p like
    the equation itself, but with neither the acceleration nor a speed at one instant,
    whose noise in a regressor would bias the least squares toward zero (errors in
    variables).

    Parameters
    ----------
    device : Device
        The gimbal (its spring is known).
    stage : int
        The stage number, from 1 (for messages).
    log : Log
        The stage's braking log (its torque noise weighs the fit).
    sm : Smoothed
        The smoothed braking pass.

    Returns
    -------
    model : ModelParameters
        The nominal model, a1 = 0 (module docstring).
    friction_cov : numpy.ndarray, shape (2, 2)
        The covariance of the friction slopes [a2, a3] (zero where not fitted; an estimate
        held at its bound 0 keeps the unbounded fit's spread).

    Raises
    ------
    InputError
        The fitted reduced inertia is not positive.
    """
    values, cov = fit_modulated(
        device, [(log, sm)], UNKNOWN, f"stage {stage}: braking.csv",
        torque_noise=[torque_noise(log)],
    )
    friction = {k: values[k] for k in FRICTION.sloped}
    slopes = [UNKNOWN.index(k) for k in FRICTION.sloped]
    friction_cov = np.nan_to_num(cov[np.ix_(slopes, slopes)])
    if values["M0"] <= 0:
        raise InputError(
            f"stage {stage}: braking.csv: the fitted reduced inertia is not positive "
            f"({values['M0']:.3g} kg m^2): is the braking torque logged with its sign?"
        )
    model = ModelParameters(
        inertia_harmonics=np.array([values[k] for k in ("M0", "Mc2", "Ms2", "Ms1", "Mc1")]),
        stiffness=device.spring.stiffness,
        zero_angle=device.spring.zero_angle,
        gravity_sin=values["Gs"],
        gravity_cos=values["Gc"],
        **FRICTION.model_fields({FRICTION.static: 0.0, **friction}),
    )
    return model, friction_cov
