"""Nominal model of a stage from its braking log, for the program's feedforward.

Lagrange's equation (docs/method.md §3, rsp_inertia.plant.model) is linear in the harmonic coefficients of
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

Coarse encoders: errors in the regressors. The windows' energy columns are made of the
smoothed speeds at their ends, and a coarse encoder's speed noise in a regressor biases least
squares toward zero (errors in variables, attenuation): on a 10-bit default stage 1 the
plain fit put M0 85-90% low and the friction 10 times low, so the program's feedforward
left the whole mirror to a feedback loop that the encoder keeps slow (62-67% low at 12 bits,
6-8% at 16). Three corrections, each with the smoothed speed's error variance var(Omega) at
the row (the quantization lines, rsp_inertia.estimation.smoothing.quantization_error_variance):

- each column's mean shift from the speed noise is taken off: for columns up to quadratic in
  Omega, E[f(Omega + e)] = f(Omega) + f'' var / 2 (the dissipation's, :func:`_unbiased`; the
  energy's kinetic part 1/2 Omega^2 dM/dp in closed form);
- each window is weighted by the inverse of its equation's noise, (Omega_b^2 var_b +
  Omega_a^2 var_a) (M^2 common): the slow windows, whose deceleration holds the scale of M
  against the braking torque, count as much as they know;
- the normal equations lose the noise's share of the Gram matrix, A^T W A - E[N^T W N] with
  N the columns' noise from the ends' speed errors (the corrected least squares for
  regressors with known error covariance), kept positive definite (:func:`_corrected_gram`).

Measured on the virtual device (default stages, seeds 0-1): M0 within 3% at 16 bits, 7-12%
(stage 1) and 1% (stage 2) at 12 bits, 0-2% (stage 2) at 10 bits; the 10-bit stage 1, whose
braking torque is 5% of its friction, still comes out 36-70% low (its slowest windows are
a few counts per window: the log hardly holds the scale).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.optimize import lsq_linear

from rsp_inertia.estimation.smoothing import Smoothed
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.errors import InputError
from rsp_inertia.plant.logs import Log
from rsp_inertia.plant.model import (
    PARAMETER_NAMES,
    ModelParameters,
    dissipation_regressor,
    energy_regressor,
    mechanical_energy,
    spring_parameters,
)

__all__ = ["UNKNOWN", "fit_energy_windows", "fit_nominal", "fit_nominal_with_covariance"]

UNKNOWN = ("M0", "a2", "a3", "Mc2", "Ms2", "Gs", "Gc", "Ms1", "Mc1")
"""Parameters fitted, most important first: a short pass fits only the first ones (the others
stay 0: the regulator absorbs what the feedforward lacks). The spring's (c, phi0) come from
device.toml, a1 is put to 0 (module docstring)."""

_MIN_SPEED_FRACTION = 0.05
"""Samples slower than this fraction of the top speed are left out (static friction,
over-confident smoothing near rest)."""

_WINDOW = 0.25
"""s per energy-balance window on a long pass. Short windows leave the speed's noise large next
to each window's energy change; on a stage whose friction nearly balances the inertia term
that noise biases the fitted scale."""

_MIN_WINDOWS = 30
"""Windows a pass is cut into at least: on a pass shorter than _MIN_WINDOWS x _WINDOW
(7.5 s) the windows shorten to pass / _MIN_WINDOWS. Such a pass brakes hard, so each
window's energy change stands far above the speed noise that biases short windows on a
slow pass."""

_SHORTEST_WINDOW = 0.02
"""s: below this a window spans too few samples for the smoother's bandwidth (~1/w_c)."""

_NON_NEGATIVE = ("M0", "a1", "a2", "a3")
"""Parameters bounded below by 0 in the fits: the mean inertia and the friction."""

_WINDOWS_PER_UNKNOWN = 2
"""Unknowns fitted: at most one per this many windows, in the order of :data:`UNKNOWN`
(only a pass shorter than 2 x 9 x _SHORTEST_WINDOW = 0.36 s fits fewer than all)."""


def fit_energy_windows(
    device: Device, log: Log, sm: Smoothed, unknowns: Sequence[str], source: str
) -> tuple[dict[str, float], np.ndarray]:
    """Least squares of the energy balance over consecutive windows of a smoothed pass.

    Over each window [a, b] of the pass (the rows faster than _MIN_SPEED_FRACTION of the top
    speed, cut into windows of _WINDOW s, shorter on a short pass: _MIN_WINDOWS)

        E(b) - E(a) + integral_a^b D dphi = motor work from a to b

    is linear in the model's parameters (:func:`fit_nominal`); the spring's (c, phi0) come
    from device.toml, every parameter not in ``unknowns`` is 0. The motion is taken forward
    (Omega > 0, the friction's sign). M0, a1, a2 and a3 are bounded below by 0 (bounded
    least squares, columns scaled to unit norm).

    Parameters
    ----------
    device : Device
        The gimbal (its spring).
    log, sm : Log, Smoothed
        The pass's log (motor work: Stieltjes sum of its torque) and its smoothed states.
    unknowns : sequence of str
        Names of rsp_inertia.plant.model.PARAMETER_NAMES to fit, most important first: a pass with fewer
        than _WINDOWS_PER_UNKNOWN windows per unknown fits only the first ones.
    source : str
        The log's name in messages (e.g. "stage 1: braking.csv").

    Returns
    -------
    values : dict
        Every name of ``unknowns`` with its estimate, in its SI unit (0 if not fitted).
    covariance : numpy.ndarray, shape (len(unknowns), len(unknowns))
        The estimates' covariance in the order of ``unknowns``: residual variance (residual
        sum of squares over windows minus fitted unknowns) times (A^T A)^-1, A the windows'
        regressors, as for independent windows; NaN for unknowns not fitted. It ignores the
        bounds (an estimate held at its bound has a smaller spread than it says).

    Raises
    ------
    InputError
        If the pass moves for less than _WINDOWS_PER_UNKNOWN windows.
    """
    unknowns = tuple(unknowns)
    spring = spring_parameters(device.spring.stiffness, device.spring.zero_angle)
    dt = float(np.median(np.diff(sm.t)))  # the sample period (time stamps may jitter)
    moving = np.nonzero(sm.omega > _MIN_SPEED_FRACTION * sm.omega.max())[0]
    rows = np.arange(moving[0], moving[-1] + 1) if moving.size else moving
    duration = rows.size * dt
    window = max(min(_WINDOW, duration / _MIN_WINDOWS), _SHORTEST_WINDOW)
    if duration < _WINDOWS_PER_UNKNOWN * window:
        raise InputError(
            f"{source}: the body moves for only {duration:.3f} s; a nominal model needs "
            f"at least {_WINDOWS_PER_UNKNOWN * window:g} s of motion"
        )
    stride = max(round(window / dt), 1)
    phi, omega = sm.phi[rows], sm.omega[rows]
    var = sm.speed_error_variance()[rows]
    # Cumulative integral of dD/dp dphi (trapezoid over the smoothed angle), each row's
    # speed-noise bias taken off (errors in variables, module docstring).
    Dreg = _unbiased(
        lambda w: dissipation_regressor(w, spring, direction=np.ones_like(w)), omega, var
    )
    dphi = np.diff(phi)[:, None]
    Dint = np.vstack([np.zeros(Dreg.shape[1]), np.cumsum((Dreg[1:] + Dreg[:-1]) / 2 * dphi, 0)])
    work = log.motor_work()[rows]
    ends = np.arange(0, rows.size, stride)
    a, b = ends[:-1], ends[1:]
    # The energy columns at the windows' ends only. Their kinetic part, 1/2 Omega^2 dM/dp, is
    # quadratic in Omega: its speed-noise mean is kinetic var / Omega^2, its slope
    # 2 kinetic / Omega (how one speed error moves a window's energy columns).
    at_phi, at_omega = phi[ends], omega[ends]
    E = energy_regressor(at_phi, at_omega, spring)
    kinetic = E - energy_regressor(at_phi, np.zeros(ends.size), spring)
    E = E - kinetic * (var[ends] / at_omega**2)[:, None]
    slope = 2 * kinetic / at_omega[:, None]
    A = E[1:] - E[:-1] + Dint[b] - Dint[a]
    # The spring's energy is the model's energy with every unknown at zero.
    spring_energy = mechanical_energy(at_phi, at_omega, spring)
    y = work[b] - work[a] - (spring_energy[1:] - spring_energy[:-1])
    fitted = unknowns[: max(1, min(len(unknowns), a.size // _WINDOWS_PER_UNKNOWN))]
    cols = [PARAMETER_NAMES.index(name) for name in fitted]
    # Friction and the mean inertia cannot be negative: bounded least squares keeps the fit
    # physical where the speed noise of a coarse encoder would tip an unbounded one over
    # (seen: M0 < 0 on 12-bit encoders), instead of clipping its estimates afterwards.
    # Columns scaled to unit norm, as their units differ by orders of magnitude.
    lower = np.array([0.0 if name in _NON_NEGATIVE else -np.inf for name in fitted])
    # Each window weighted by the inverse of its equation's noise from the speed errors at its
    # ends, (Omega_b^2 var_b + Omega_a^2 var_a) M^2 (M common to all, left out): the slow
    # windows, which carry the scale of M against the braking torque, count as they should.
    spread = omega[b] ** 2 * var[b] + omega[a] ** 2 * var[a]
    weight = 1.0 / np.sqrt(spread) if np.all(spread > 0.0) else np.ones(a.size)  # exact states
    A = A * weight[:, None]
    y = y * weight
    norms = np.linalg.norm(A[:, cols], axis=0)
    norms[norms == 0.0] = 1.0
    scaled = A[:, cols] / norms
    # The speed errors at the windows' ends, E[N^T N] of the columns' noise N (the ends are
    # a window apart, far beyond the smoother's correlation time: independent).
    Gb = slope[1:, cols] * weight[:, None] / norms
    Ga = slope[:-1, cols] * weight[:, None] / norms
    noise = Gb.T @ (var[b, None] * Gb) + Ga.T @ (var[a, None] * Ga)
    gram = scaled.T @ scaled
    corrected = _corrected_gram(gram, noise)
    # Least squares with the corrected normal equations: R^T R = A^T A - E[N^T N] and
    # R x = R^-T A^T y have them as their own, and keep the bounds.
    R = np.linalg.cholesky(corrected).T
    target = np.linalg.solve(R.T, scaled.T @ y)
    fit = lsq_linear(R, target, bounds=(lower * norms, np.inf), method="bvls")
    values = dict.fromkeys(unknowns, 0.0) | dict(zip(fitted, fit.x / norms))
    # Covariance of the unbounded corrected least squares at the solution: residual
    # variance times H^-1 A^T A H^-1 (H the corrected Gram matrix), in the scaled columns,
    # then back to the parameters' units.
    dof = a.size - len(fitted)
    residual = y - scaled @ fit.x
    variance = residual @ residual / dof if dof > 0 else np.nan
    inverse = np.linalg.pinv(corrected)
    cov_fitted = variance * (inverse @ gram @ inverse) / np.outer(norms, norms)
    index = [unknowns.index(name) for name in fitted]
    covariance = np.full((len(unknowns), len(unknowns)), np.nan)
    covariance[np.ix_(index, index)] = cov_fitted
    return values, covariance


def _unbiased(regressor, omega: np.ndarray, var: np.ndarray) -> np.ndarray:
    """``regressor(omega)`` less the mean that a speed error of variance ``var`` adds to it:
    for columns up to quadratic in Omega, E[f(Omega + e)] = f(Omega) + f''(Omega) var / 2,
    f'' by a central second difference (exact for quadratics)."""
    h = np.maximum(1e-3 * np.abs(omega), 1e-9)
    f0 = regressor(omega)
    curvature = (regressor(omega + h) + regressor(omega - h) - 2 * f0) / (h * h)[:, None]
    return f0 - curvature * (var / 2)[:, None]


_MIN_SIGNAL = 0.05
"""Least fraction of each direction of the windows' Gram matrix that must remain after the
speed noise's share is taken off (:func:`_corrected_gram`)."""


def _corrected_gram(gram: np.ndarray, noise: np.ndarray) -> np.ndarray:
    """A^T A - E[N^T N], the Gram matrix of the noise-free columns (module docstring), kept
    positive definite: in the directions where the noise takes more than 1 - _MIN_SIGNAL of
    the Gram matrix (too coarse a log to tell the parameter), only that much is taken off."""
    L = np.linalg.cholesky(gram + 1e-12 * np.trace(gram) * np.eye(len(gram)))
    Li = np.linalg.inv(L)
    share, vectors = np.linalg.eigh(Li @ noise @ Li.T)
    share = np.minimum(share, 1.0 - _MIN_SIGNAL)
    whitened = (vectors * (1.0 - share)) @ vectors.T
    return L @ whitened @ L.T


def fit_nominal(device: Device, stage: int, log: Log, sm: Smoothed) -> ModelParameters:
    """Least-squares nominal model of stage ``stage`` from its smoothed braking pass
    (:func:`fit_nominal_with_covariance`, without the covariance)."""
    return fit_nominal_with_covariance(device, stage, log, sm)[0]


def fit_nominal_with_covariance(
    device: Device, stage: int, log: Log, sm: Smoothed
) -> tuple[ModelParameters, np.ndarray]:
    """Least-squares nominal model of stage ``stage`` from its smoothed braking pass, and the
    (2, 2) covariance of its friction slopes [a2, a3] (zero where not fitted; an estimate held
    at its bound 0 keeps the unbounded fit's spread, fit_energy_windows).

    The equation of motion is fitted in its integrated form, the energy balance over
    consecutive windows [a, b] of the pass (docs/method.md §3):

        E(b) - E(a) + integral_a^b D dphi = motor work from a to b

    which is linear in p like the equation of motion itself, but needs no acceleration: the
    smoothed acceleration is noisy (quantization through a wide-band smoother), and noise in
    a regressor biases least squares toward zero (errors in variables). The regressors are
    the Jacobians of the model's own E and D (rsp_inertia.plant.model); the integral is a trapezoid sum
    over the samples, the motor work the Stieltjes sum of the log.
    """
    values, cov = fit_energy_windows(device, log, sm, UNKNOWN, f"stage {stage}: braking.csv")
    friction = {k: values[k] for k in ("a2", "a3")}
    slopes = [UNKNOWN.index(k) for k in ("a2", "a3")]
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
        coulomb=0.0,
        viscous=friction["a2"],
        quadratic=friction["a3"],
    )
    return model, friction_cov
