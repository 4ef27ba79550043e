"""Nominal model of a stage from its braking log, for the program's feedforward.

Lagrange's equation (METHOD.md §3, plant.model) is linear in the harmonic coefficients of
M(phi), the gravity terms and the dissipation coefficients (a1, a2, a3); the spring is
known from device.toml. Along the smoothed braking pass (phi, Omega > 0, eps) with the
logged torque u, least squares on

    regressor(phi, Omega, eps) . p = u - (spring's term)

gives the unknowns. It only has to be good enough for feedforward: the regulator absorbs
the rest (and the identification never uses it).

One parameter cannot come from a braking pass: with a constant braking torque, Coulomb
friction a1 is a constant torque too, and only (u - a1) enters; worse, (M, a1 - u, a2, a3,
gravity) then fit equally well at any common scale, so the absolute inertia is lost (that
is what the reverse pass of the RSP method restores). The fit therefore puts a1 = 0: M comes
out too small by the fraction a1 / braking_torque (2% on the default stage 1 at the paper's
friction), well inside what the regulator has to absorb anyway.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import lsq_linear

from estimation.smoothing import Smoothed
from plant.config import Device
from plant.errors import InputError
from plant.logs import Log
from plant.model import (
    PARAMETER_NAMES,
    ModelParameters,
    dissipation_regressor,
    energy_regressor,
    mechanical_energy,
    spring_parameters,
)

__all__ = ["UNKNOWN", "fit_nominal"]

UNKNOWN = ("M0", "Mc2", "Ms2", "Ms1", "Mc1", "Gs", "Gc", "a2", "a3")
"""Parameters fitted; the spring's (c, phi0) come from device.toml, a1 is put to 0."""

_MIN_SPEED_FRACTION = 0.05
"""Samples slower than this fraction of the top speed are left out (static friction,
over-confident smoothing near rest)."""

_WINDOW = 0.25
"""s per energy-balance window. Short windows leave the speed's noise large next to each
window's energy change; on a stage whose friction nearly balances the inertia term (stage 1
of the default experiment) that noise biases the fitted scale: 20 ms windows gave M 14x too
small, 0.1 s 24% too small, 0.25 s within the 2% that a1 = 0 costs."""

_MIN_WINDOWS = 20
"""At least two windows per unknown."""


def fit_nominal(device: Device, stage: int, log: Log, sm: Smoothed) -> ModelParameters:
    """Least-squares nominal model of stage ``stage`` from its smoothed braking pass.

    The equation of motion is fitted in its integrated form, the energy balance over
    consecutive windows [a, b] of the pass (METHOD.md §3):

        E(b) - E(a) + integral_a^b D dphi = motor work from a to b

    which is linear in p like the equation of motion itself, but needs no acceleration: the
    smoothed acceleration is noisy (quantization through a wide-band smoother), and noise in
    a regressor biases least squares toward zero (errors in variables). The regressors are
    the Jacobians of the model's own E and D (plant.model); the integral is a trapezoid sum
    over the samples, the motor work the Stieltjes sum of the log.
    """
    spring = spring_parameters(device.spring.stiffness, device.spring.zero_angle)
    moving = np.nonzero(sm.omega > _MIN_SPEED_FRACTION * sm.omega.max())[0]
    stride = max(round(_WINDOW / (sm.t[1] - sm.t[0])), 1)
    rows = np.arange(moving[0], moving[-1] + 1) if moving.size else moving
    if rows.size < _MIN_WINDOWS * stride:
        raise InputError(
            f"stage {stage}: braking.csv: the body moves for only {rows.size * (sm.t[1] - sm.t[0]):.2f} s;"
            f" fitting a model needs at least {_MIN_WINDOWS * _WINDOW:g} s of braking"
        )
    phi, omega = sm.phi[rows], sm.omega[rows]
    # Cumulative integral of dD/dp dphi (trapezoid over the smoothed angle).
    Dreg = dissipation_regressor(omega, spring, direction=np.ones_like(omega))
    dphi = np.diff(phi)[:, None]
    Dint = np.vstack([np.zeros(Dreg.shape[1]), np.cumsum((Dreg[1:] + Dreg[:-1]) / 2 * dphi, 0)])
    Ereg = energy_regressor(phi, omega, spring)
    work = log.motor_work()[rows]
    ends = np.arange(0, rows.size, stride)
    a, b = ends[:-1], ends[1:]
    A = Ereg[b] - Ereg[a] + Dint[b] - Dint[a]
    # The spring's energy is the model's energy with every unknown at zero.
    spring_energy = mechanical_energy(phi, omega, spring)
    y = work[b] - work[a] - (spring_energy[b] - spring_energy[a])
    cols = [PARAMETER_NAMES.index(name) for name in UNKNOWN]
    # Friction and the mean inertia cannot be negative: bounded least squares keeps the fit
    # physical where the speed noise of a coarse encoder would tip an unbounded one over
    # (seen: M0 < 0 on 12-bit encoders), instead of clipping its estimates afterwards.
    # Columns scaled to unit norm, as their units differ by orders of magnitude.
    lower = np.array([0.0 if name in ("M0", "a2", "a3") else -np.inf for name in UNKNOWN])
    norms = np.linalg.norm(A[:, cols], axis=0)
    norms[norms == 0.0] = 1.0
    fit = lsq_linear(A[:, cols] / norms, y, bounds=(lower * norms, np.inf), method="bvls")
    values = dict(zip(UNKNOWN, fit.x / norms))
    friction = {k: values[k] for k in ("a2", "a3")}
    if values["M0"] <= 0:
        raise InputError(
            f"stage {stage}: braking.csv: the fitted reduced inertia is not positive "
            f"({values['M0']:.3g} kg m^2): is the braking torque logged with its sign?"
        )
    return ModelParameters(
        inertia_harmonics=np.array([values[k] for k in ("M0", "Mc2", "Ms2", "Ms1", "Mc1")]),
        stiffness=device.spring.stiffness,
        zero_angle=device.spring.zero_angle,
        gravity_sin=values["Gs"],
        gravity_cos=values["Gc"],
        coulomb=0.0,
        viscous=friction["a2"],
        quadratic=friction["a3"],
    )
