"""Nominal model of a stage from its braking log, for the program's feedforward.

Lagrange's equation (docs/method.md §3, rsp_inertia.plant.model) is linear in the harmonic
coefficients of M(phi), the gravity terms and the dissipation coefficients (a1, a2, a3); the
spring is known from device.toml. It only has to be good enough for feedforward: the
regulator absorbs the rest (and the identification never uses it).

**Modulating functions.** The equation is fitted in its momentum form,
d(M Omega)/dt = u + F with F = 1/2 M' Omega^2 - D - S (rsp_inertia.plant.model), multiplied
by a weight w(t) that vanishes at both ends of a window [a, b] and integrated; by parts,

    - integral w' M Omega dt - integral w F dt = integral w u dt

(Shinbrot's method of modulating functions), one linear equation in p per window. No
acceleration and no speed at a single instant enters: the speed only under integrals, against
the smooth weight w(t) = sin^2(pi (t - a) / (b - a)) or its derivative, where the smoothed
speed's error, which has no low-frequency content, averages out. The regressors are the
Jacobians of the model's own M Omega and F (:func:`rsp_inertia.plant.model.momentum_regressor`,
:func:`rsp_inertia.plant.model.force_regressor`); the integrals are trapezoid sums over the
samples.

Why: errors in a regressor bias least squares toward zero (errors in variables), most of all
along the one direction a braking determines weakly, the common scale of M and friction
against the known braking torque. The energy balance over windows that this replaces took
the speed at the windows' ends, and on a 10-bit default stage 1 (braking torque 5% of the
friction) it put M0 36-70% low even with an errors-in-variables correction. Each modulated
equation's signal grows with the window's length T and its speed-noise term falls with it
(as T^-1.5: the smoothed angle's error, twice differentiated by parts), so long windows,
overlapping to keep their number up, remove the bias: 1 s windows every 0.25 s put M0
within 0.3% on the 10-bit default stage 2 and 2.2-2.8% low on stage 1 (2.0% of it the
Coulomb degeneracy below), seeds 0-2. Columns with Omega^2 (M' and a3) have the speed noise's
mean taken off (E[f(Omega + e)] = f + f'' var / 2, :func:`_unbiased`).

One parameter cannot come from a braking pass: with a constant braking torque, Coulomb
friction a1 is a constant torque too, and only (u - a1) enters; worse, (M, a1 - u, a2, a3,
gravity) then fit equally well at any common scale, so the absolute inertia is lost (that
is what the reverse pass of the RSP method restores). The fit therefore puts a1 = 0: M comes
out too small by the fraction a1 / braking_torque (2% on the default stage 1 at the paper's
friction), well inside what the regulator has to absorb anyway.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.integrate import simpson
from scipy.optimize import lsq_linear

from rsp_inertia.estimation.smoothing import Smoothed
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.errors import InputError
from rsp_inertia.plant.logs import Log
from rsp_inertia.plant.model import (
    PARAMETER_NAMES,
    ModelParameters,
    force_regressor,
    momentum_regressor,
    spring_parameters,
    static_torque,
)

__all__ = ["UNKNOWN", "fit_modulated_windows", "fit_nominal", "fit_nominal_with_covariance"]

UNKNOWN = ("M0", "a2", "a3", "Mc2", "Ms2", "Gs", "Gc", "Ms1", "Mc1")
"""Parameters fitted, most important first: a short pass fits only the first ones (the others
stay 0: the regulator absorbs what the feedforward lacks). The spring's (c, phi0) come from
device.toml, a1 is put to 0 (module docstring)."""

_MIN_SPEED_FRACTION = 0.05
"""Samples slower than this fraction of the top speed are left out (static friction,
over-confident smoothing near rest)."""

_WINDOW = 1.0
"""s, the modulating windows' length on a long pass (module docstring: 0.25 s windows left
M0 6% low on the 10-bit default stage 1, 0.5 s 6%, 1 s 2.5%, 2 s 2.2%, of which 2.0% is the
Coulomb degeneracy; a longer window averages M's harmonics within it)."""

_OVERLAP = 4
"""Windows start every _WINDOW / _OVERLAP: overlapping, so that a pass gives enough of them
(their errors correlate: :func:`_overlap_covariance`)."""

_MIN_SPANS = 8
"""A pass shorter than _MIN_SPANS x _WINDOW has its windows shortened to pass / _MIN_SPANS,
which still gives 4 (_MIN_SPANS - 1) + 1 = 29 windows."""

_SHORTEST_WINDOW = 0.02
"""s: below this a window spans too few samples for the smoother's bandwidth (~1/w_c)."""

_NON_NEGATIVE = ("M0", "a1", "a2", "a3")
"""Parameters bounded below by 0 in the fits: the mean inertia and the friction."""

_WINDOWS_PER_UNKNOWN = 2
"""Unknowns fitted: at most one per this many windows, in the order of :data:`UNKNOWN`
(only a pass shorter than about 0.16 s, whose windows are the shortest, fits fewer than all)."""


def fit_modulated_windows(
    device: Device, log: Log, sm: Smoothed, unknowns: Sequence[str], source: str
) -> tuple[dict[str, float], np.ndarray]:
    """Least squares of the modulated momentum equation over overlapping windows of a pass.

    Over each window [a, b] of the pass (the rows faster than _MIN_SPEED_FRACTION of the top
    speed; windows of _WINDOW s starting every _WINDOW / _OVERLAP, shorter on a short pass:
    _MIN_SPANS), with w(t) = sin^2(pi (t - a) / (b - a)),

        - integral w' M Omega dt - integral w F dt = integral w u dt

    is linear in the model's parameters (module docstring); the spring's (c, phi0) come from
    device.toml, every parameter not in ``unknowns`` is 0. The motion is taken forward
    (Omega > 0, the friction's sign). M0, a1, a2 and a3 are bounded below by 0 (bounded
    least squares, columns scaled to unit norm).

    Parameters
    ----------
    device : Device
        The gimbal (its spring).
    log, sm : Log, Smoothed
        The pass's log (its torque u) and its smoothed states.
    unknowns : sequence of str
        Names of rsp_inertia.plant.model.PARAMETER_NAMES to fit, most important first: a
        pass with fewer than _WINDOWS_PER_UNKNOWN windows per unknown fits only the first
        ones.
    source : str
        The log's name in messages (e.g. "stage 1: braking.csv").

    Returns
    -------
    values : dict
        Every name of ``unknowns`` with its estimate, in its SI unit (0 if not fitted).
    covariance : numpy.ndarray, shape (len(unknowns), len(unknowns))
        The estimates' covariance in the order of ``unknowns``, from the residuals with the
        overlapping windows' correlation (:func:`_overlap_covariance`); NaN for unknowns not
        fitted. It ignores the bounds (an estimate held at its bound has a smaller spread
        than it says).

    Raises
    ------
    InputError
        If the pass moves for less than _WINDOWS_PER_UNKNOWN shortest windows.
    """
    unknowns = tuple(unknowns)
    spring = spring_parameters(device.spring.stiffness, device.spring.zero_angle)
    dt = float(np.median(np.diff(sm.t)))  # the sample period (time stamps may jitter)
    moving = np.nonzero(sm.omega > _MIN_SPEED_FRACTION * sm.omega.max())[0]
    rows = np.arange(moving[0], moving[-1] + 1) if moving.size else moving
    duration = rows.size * dt
    window = max(min(_WINDOW, duration / _MIN_SPANS), _SHORTEST_WINDOW)
    span = max(round(window / dt), 1)
    starts = np.arange(0, rows.size - span, max(span // _OVERLAP, 1))
    if starts.size < _WINDOWS_PER_UNKNOWN:
        raise InputError(
            f"{source}: the body moves for only {duration:.3f} s; a nominal model needs "
            f"at least {_WINDOWS_PER_UNKNOWN * _SHORTEST_WINDOW:g} s of motion"
        )
    t, phi, omega = sm.t[rows], sm.phi[rows], sm.omega[rows]
    var = sm.speed_error_variance()[rows]
    forward = np.ones(rows.size)
    momentum = momentum_regressor(phi, omega, spring)  # linear in Omega: no noise mean
    force = _unbiased(lambda w: force_regressor(phi, w, spring, direction=forward), omega, var)
    # The spring's part of F is known: -S_spring (its regressor is not linear in (c, phi0)).
    known = np.asarray(log.torque, dtype=float)[rows] - static_torque(phi, spring)
    A = np.empty((starts.size, len(PARAMETER_NAMES)))
    y = np.empty(starts.size)
    for j, a in enumerate(starts):
        s = slice(a, a + span + 1)
        tt = t[s]
        T = tt[-1] - tt[0]
        w = np.sin(np.pi * (tt - tt[0]) / T) ** 2
        w_dot = np.pi / T * np.sin(2 * np.pi * (tt - tt[0]) / T)
        A[j] = -simpson(w_dot[:, None] * momentum[s] + w[:, None] * force[s], x=tt, axis=0)
        y[j] = simpson(w * known[s], x=tt)
    fitted = unknowns[: max(1, min(len(unknowns), starts.size // _WINDOWS_PER_UNKNOWN))]
    cols = [PARAMETER_NAMES.index(name) for name in fitted]
    # Friction and the mean inertia cannot be negative: bounded least squares keeps the fit
    # physical where the speed noise of a coarse encoder would tip an unbounded one over,
    # instead of clipping its estimates afterwards. Columns scaled to unit norm, as their
    # units differ by orders of magnitude.
    lower = np.array([0.0 if name in _NON_NEGATIVE else -np.inf for name in fitted])
    norms = np.linalg.norm(A[:, cols], axis=0)
    norms[norms == 0.0] = 1.0
    scaled = A[:, cols] / norms
    fit = lsq_linear(scaled, y, bounds=(lower * norms, np.inf), method="bvls")
    values = dict.fromkeys(unknowns, 0.0) | dict(zip(fitted, fit.x / norms))
    cov_fitted = _overlap_covariance(scaled, y - scaled @ fit.x) / np.outer(norms, norms)
    index = [unknowns.index(name) for name in fitted]
    covariance = np.full((len(unknowns), len(unknowns)), np.nan)
    covariance[np.ix_(index, index)] = cov_fitted
    return values, covariance


def _overlap_covariance(A: np.ndarray, residual: np.ndarray) -> np.ndarray:
    """Covariance of the least squares A x = y from its residuals, the windows' errors
    correlated over the _OVERLAP - 1 neighbours each shares samples with: the sandwich
    (A^T A)^-1 S (A^T A)^-1, S the residual-weighted outer products of the rows summed
    over lags below _OVERLAP with Bartlett weights 1 - lag / _OVERLAP (Newey and West's
    estimator, positive semi-definite), times n / (n - unknowns); NaN without a degree of
    freedom."""
    n, k = A.shape
    if n <= k:
        return np.full((k, k), np.nan)
    scores = A * residual[:, None]
    meat = scores.T @ scores
    for lag in range(1, _OVERLAP):
        cross = scores[:-lag].T @ scores[lag:]
        meat += (1.0 - lag / _OVERLAP) * (cross + cross.T)
    bread = np.linalg.pinv(A.T @ A)
    return bread @ meat @ bread * n / (n - k)


def _unbiased(regressor, omega: np.ndarray, var: np.ndarray) -> np.ndarray:
    """``regressor(omega)`` less the mean that a speed error of variance ``var`` adds to it:
    for columns up to quadratic in Omega, E[f(Omega + e)] = f(Omega) + f''(Omega) var / 2,
    f'' by a central second difference (exact for quadratics)."""
    h = np.maximum(1e-3 * np.abs(omega), 1e-9)
    f0 = regressor(omega)
    curvature = (regressor(omega + h) + regressor(omega - h) - 2 * f0) / (h * h)[:, None]
    return f0 - curvature * (var / 2)[:, None]


def fit_nominal(device: Device, stage: int, log: Log, sm: Smoothed) -> ModelParameters:
    """Least-squares nominal model of stage ``stage`` from its smoothed braking pass
    (:func:`fit_nominal_with_covariance`, without the covariance)."""
    return fit_nominal_with_covariance(device, stage, log, sm)[0]


def fit_nominal_with_covariance(
    device: Device, stage: int, log: Log, sm: Smoothed
) -> tuple[ModelParameters, np.ndarray]:
    """Least-squares nominal model of stage ``stage`` from its smoothed braking pass, and the
    (2, 2) covariance of its friction slopes [a2, a3] (zero where not fitted; an estimate held
    at its bound 0 keeps the unbounded fit's spread, fit_modulated_windows).

    The equation of motion is fitted in its momentum form, modulated over overlapping
    windows of the pass (:func:`fit_modulated_windows`, module docstring): linear in p like
    the equation itself, but with neither the acceleration nor a speed at one instant,
    whose noise in a regressor would bias the least squares toward zero (errors in
    variables).
    """
    values, cov = fit_modulated_windows(device, log, sm, UNKNOWN, f"stage {stage}: braking.csv")
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
