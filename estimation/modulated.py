"""Lagrange's equation fitted to logged passes by modulating functions (docs/method.md §3-4).

The equation is linear in the harmonic coefficients of M(phi), the gravity terms and the
dissipation coefficients (a1, a2, a3); the spring is known from device.toml. It is fitted in
its momentum form, d(M Omega)/dt = u + F with F = 1/2 M' Omega^2 - D - S
(rsp_inertia.plant.model), multiplied by a weight w(t) that vanishes at both ends of a window
[a, b] and integrated; by parts,

    - integral w' M Omega dt - integral w F dt = integral w u dt

(Shinbrot's method of modulating functions), one linear equation in p per window. No
acceleration and no speed at a single instant enters: the speed only under integrals, against
the smooth weight w(t) = sin^2(pi (t - a) / (b - a)) or its derivative, where the smoothed
speed's error, which has no low-frequency content, averages out. The regressors are the
Jacobians of the model's own M Omega and F (:func:`rsp_inertia.plant.model.momentum_regressor`,
:func:`rsp_inertia.plant.model.force_regressor`); their integrals are Simpson sums over the
samples, the torque's the exact sum of the logged torque held over each sample times the
weight's integral there.

Why: errors in a regressor bias least squares toward zero (errors in variables), most of all
along a direction the data determine weakly. Each modulated equation's signal grows with the
window's length T and its speed-noise term falls with it (as T^-1.5: the smoothed angle's
error, twice differentiated by parts), so long windows, overlapping to keep their number up,
remove the bias: on the 10-bit default stage 1 (braking torque 5% of its friction) the energy
balance over 0.25 s windows that this replaced put M0 36-38% low even with an
errors-in-variables correction; 1 s windows every 0.25 s put it 2.2-2.8% low, 2.0% of which is
the Coulomb degeneracy below (seeds 0-2). Columns with Omega^2 (M' and a3) have the speed
noise's mean taken off (E[F(Omega + e)] = F + F'' var / 2,
:func:`rsp_inertia.plant.model.force_curvature_regressor`).

What a pass can tell. A braking pass alone, under a constant torque, cannot tell Coulomb
friction a1 from the braking torque, and (M, a1 - u, a2, a3, gravity) fit it equally well at
any common scale: the program's nominal model puts a1 = 0 (rsp_inertia.ocp.nominal). The exact
mirror's torque alone is u_b + 2 D(Omega), a function of the speed, which friction mimics.
Both passes of a run together (:func:`fit_modulated` with both) determine everything: the
braking says X + D = u_b at each state and the reverse X' - D = u' at its mirror, X the
inertial, spring and gravity terms. On the default stage 1 at 12 bits that joint fit puts M0
within 3e-4, a1 within 2e-5 N m, a2 within 1e-5 N m s and a3 within 1e-6 N m s^2 of the
truth, closed loop or ideal reverse alike: the friction slopes that identify's tracking
mismatch needs (rsp_inertia.estimation.balance.friction_slope_prior).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.integrate import simpson
from scipy.optimize import lsq_linear

from rsp_inertia.estimation.smoothing import Smoothed, median_step
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.friction import FRICTION
from rsp_inertia.plant.logs import Log
from rsp_inertia.plant.model import (
    PARAMETER_NAMES,
    force_curvature_regressor,
    force_regressor,
    momentum_regressor,
    spring_parameters,
    static_torque,
)

__all__ = ["MIN_SPEED_FRACTION", "MODEL_UNKNOWNS", "WINDOW", "fit_modulated", "modulated_rows"]

MIN_SPEED_FRACTION = 0.05
"""Samples slower than this fraction of a pass's top speed are left out (static friction,
over-confident smoothing near rest)."""

WINDOW = 1.0
"""s, the modulating windows' length on a long pass (module docstring: 0.25 s windows left
M0 6% low on the 10-bit default stage 1, 0.5 s 6%, 1 s 2.5%, 2 s 2.2%, of which 2.0% is the
Coulomb degeneracy; a longer window averages M's harmonics within it)."""

OVERLAP = 4
"""Windows start every WINDOW / OVERLAP: overlapping, so that a pass gives enough of them
(their errors correlate: :func:`_overlap_covariance`)."""

MIN_SPANS = 8
"""A pass shorter than MIN_SPANS x WINDOW has its windows shortened to pass / MIN_SPANS,
which still gives OVERLAP (MIN_SPANS - 1) + 1 = 29 windows."""

SHORTEST_WINDOW = 0.02
"""s: below this a window spans too few samples for the smoother's bandwidth (~1/w_c)."""

NON_NEGATIVE = ("M0", *FRICTION.non_negative)
"""Parameters bounded below by 0 in the fits: the mean inertia and the friction
(rsp_inertia.plant.model.FrictionLaw.non_negative)."""

MODEL_UNKNOWNS = ("M0", *FRICTION.names, "Mc2", "Ms2", "Gs", "Gc", "Ms1", "Mc1")
"""All of the model's parameters but the spring's, which device.toml gives, most important
first: what a fit of whole passes estimates (a run's friction slopes' prior,
rsp_inertia.estimation.balance.PRIOR_UNKNOWNS; a pilot, rsp_inertia.design.pilot)."""

WINDOWS_PER_UNKNOWN = 2
"""Unknowns fitted: at most one per this many windows, in the order given (only a pass
shorter than about 0.16 s, whose windows are the shortest, fits fewer than all)."""


_REGRESSOR_ROWS = 1 << 14
"""Rows whose regressors :func:`modulated_rows` evaluates at once."""


def modulated_rows(
    device: Device,
    log: Log,
    sm: Smoothed,
    source: str,
    step: int = 1,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One pass's modulated equations: rows A (n, 12) over every parameter of
    rsp_inertia.plant.model.PARAMETER_NAMES and their right-hand side y (n,), A p = y for the
    pass's parameters p but the spring's (module docstring), and Q (OVERLAP, n), the banded
    covariance of y from white noise of unit variance in the logged torque:
    Q[lag, j] = cov(y_j, y_j+lag) = sum_k dW_jk dW_j+lag,k, dW_jk the weight's integral over
    sample k of window j (windows OVERLAP or more apart share no sample).

    The pass moves in one direction, the sign of its median speed (the friction's sign); the
    rows faster than MIN_SPEED_FRACTION of its top speed are cut into windows of WINDOW s
    starting every WINDOW / OVERLAP (shorter on a short pass: MIN_SPANS). The torque is the
    logged one, held over each sample and integrated exactly; the spring's part of F,
    -S_spring (its regressor is not linear in (c, phi0)), is moved to the right-hand side.

    Parameters
    ----------
    device : Device
        The device (its spring, taken as known).
    log : Log
        The pass's log (its torque).
    sm : Smoothed
        The pass's smoothed states.
    source : str
        The log's name in messages.
    step : int
        The regressors' Simpson sums take every step-th sample (the windows' ends among
        them); 1, every sample.

    Returns
    -------
    A : np.ndarray, shape (n, 12)
        The rows over every parameter of rsp_inertia.plant.model.PARAMETER_NAMES.
    y : np.ndarray, shape (n,)
        Their right-hand side.
    Q : np.ndarray, shape (OVERLAP, n)
        The banded covariance of y per unit variance of the logged torque.

    Raises
    ------
    InputError
        If the pass moves for less than WINDOWS_PER_UNKNOWN shortest windows.
    """
    spring = spring_parameters(device.spring.stiffness, device.spring.zero_angle)
    dt = median_step(sm.t)  # the sample period (time stamps may jitter)
    # |Omega| > threshold through Omega's sign: no float copy of the pass for np.abs.
    threshold = MIN_SPEED_FRACTION * max(sm.omega.max(), -sm.omega.min())
    moving = (sm.omega > threshold) | (sm.omega < -threshold)
    # The rows from the first moving one to the last, as a slice: the pass's arrays are taken
    # over them as views, not copies (a pass at 10 kHz has millions of rows).
    first = int(np.argmax(moving))
    size = moving.size - first - int(np.argmax(moving[::-1])) if moving.any() else 0
    rows = slice(first, first + size)
    duration = size * dt
    window = max(min(WINDOW, duration / MIN_SPANS), SHORTEST_WINDOW)
    step = max(1, min(int(step), round(window / dt) // 8))  # 8 Simpson steps a window at least
    span = max(round(window / dt / (step * OVERLAP)), 1) * step * OVERLAP
    starts = np.arange(0, size - span, span // OVERLAP)
    times = sm.t[rows]
    if starts.size < WINDOWS_PER_UNKNOWN:
        raise InputError(
            f"{source}: the body moves for only {duration:.3f} s; a model of its motion "
            f"needs at least {WINDOWS_PER_UNKNOWN * SHORTEST_WINDOW:g} s"
        )
    # The regressors at every step-th row (the windows' starts and ends are among them).
    grid = np.arange(first, first + size - (size - 1) % step, step)
    t, phi, omega = sm.t[grid], sm.phi[grid], sm.omega[grid]
    var = sm.speed_error_variance(grid)
    direction = np.full(grid.size, np.sign(np.median(omega)))
    # In blocks of rows: the model's functions make several copies of what they return, and
    # a long pass (600 s every 4 ms) has 150,000 rows of 12 regressors.
    momentum = np.empty((grid.size, len(PARAMETER_NAMES)))
    force = np.empty((grid.size, len(PARAMETER_NAMES)))
    for start in range(0, grid.size, _REGRESSOR_ROWS):
        k = slice(start, start + _REGRESSOR_ROWS)
        momentum[k] = momentum_regressor(phi[k], omega[k], spring)  # linear in Omega: no noise
        # The speed noise's mean, var / 2 F'' (F is quadratic in Omega), taken off.
        force[k] = force_regressor(phi[k], omega[k], spring, direction=direction[k])
        curvature = force_curvature_regressor(phi[k], omega[k], spring, direction=direction[k])
        force[k] -= curvature * (var[k] / 2)[:, None]
    spring_torque = static_torque(phi, spring)
    torque = np.asarray(log.torque, dtype=float)[rows]
    A = np.empty((starts.size, len(PARAMETER_NAMES)))
    y = np.empty(starts.size)
    Q = np.zeros((OVERLAP, starts.size))
    recent: list[tuple[int, np.ndarray]] = []  # the windows a later one may still overlap
    for j, a in enumerate(starts):
        s = slice(a // step, (a + span) // step + 1)
        tt = t[s]
        T = tt[-1] - tt[0]
        w = np.sin(np.pi * (tt - tt[0]) / T) ** 2
        w_dot = np.pi / T * np.sin(2 * np.pi * (tt - tt[0]) / T)
        A[j] = -simpson(w_dot[:, None] * momentum[s] + w[:, None] * force[s], x=tt, axis=0)
        # The logged torque is held over each row's sample (docs/files.md): integral w u dt
        # is sum u_k (W(t_k+1) - W(t_k)) over every row, W(s) = s/2 - T sin(2 pi s / T) /
        # (4 pi) the weight's own integral, exactly.
        held = times[a : a + span + 1] - tt[0]
        weight = held / 2 - T * np.sin(2 * np.pi * held / T) / (4 * np.pi)
        increments = np.diff(weight)
        y[j] = torque[a : a + span] @ increments - simpson(w * spring_torque[s], x=tt)
        # Windows share samples only with the ones that started less than a span before.
        recent = [(m, v) for m, v in recent if a - starts[m] < span]
        Q[0, j] = increments @ increments
        for m, v in recent:
            shift = a - starts[m]
            Q[j - m, m] = v[shift:] @ increments[: span - shift]
        recent.append((j, increments))
    return A, y, Q


def fit_modulated(
    device: Device,
    passes: Sequence[tuple[Log, Smoothed]],
    unknowns: Sequence[str],
    source: str,
    step: int = 1,
    torque_noise: Sequence[float] | None = None,
) -> tuple[dict[str, float], np.ndarray]:
    """Least squares of the modulated equations of one or more passes of one stage.

    Every parameter not in ``unknowns`` is 0 (the spring's come from device.toml); the
    parameters are shared by the passes (one body, one friction law for both directions of
    motion). M0, a1, a2 and a3 are bounded below by 0 (bounded least squares, columns scaled
    to unit norm). Each pass's equations are weighted by the inverse of its own residuals'
    mean square in an unweighted first fit (the torque logs and the speeds of a braking and a
    closed-loop reverse differ in noise).

    Parameters
    ----------
    device : Device
        The gimbal (its spring).
    passes : sequence of (Log, Smoothed)
        Each pass's log (its torque) and its smoothed states (:func:`modulated_rows`).
    unknowns : sequence of str
        Names of rsp_inertia.plant.model.PARAMETER_NAMES to fit, most important first: passes
        with fewer than WINDOWS_PER_UNKNOWN windows per unknown fit only the first ones.
    source : str
        The logs' name in messages (e.g. "stage 1: braking.csv").
    step : int
        The regressors' Simpson sums take every step-th sample (:func:`modulated_rows`).
    torque_noise : sequence of float, optional
        Per pass, the std of its torque log's white noise, N m: its share of the covariance
        is then added exactly (:func:`modulated_rows`' Q) to the residuals' estimate.

    Returns
    -------
    values : dict
        Every name of ``unknowns`` with its estimate, in its SI unit (0 if not fitted).
    covariance : numpy.ndarray, shape (len(unknowns), len(unknowns))
        The estimates' covariance in the order of ``unknowns``, from the residuals with the
        overlapping windows' correlation (:func:`_overlap_covariance`), plus the torque
        noise's share exactly where ``torque_noise`` is given (the residuals hold a part of
        it too: an upper bound; the residuals alone understated M0's spread on a pilot by
        1.5x, the fit taking up much of the few independent windows' noise); NaN for
        unknowns not fitted. It ignores the bounds (an estimate held at its bound has a
        smaller spread than it says).

    Raises
    ------
    InputError
        If a pass moves for less than WINDOWS_PER_UNKNOWN shortest windows.
    """
    unknowns = tuple(unknowns)
    blocks = [modulated_rows(device, log, sm, source, step) for log, sm in passes]
    noise_cov = [Q for _, _, Q in blocks]
    blocks = [(a, y) for a, y, _ in blocks]
    n = sum(len(y) for _, y in blocks)
    fitted = unknowns[: max(1, min(len(unknowns), n // WINDOWS_PER_UNKNOWN))]
    cols = [PARAMETER_NAMES.index(name) for name in fitted]
    # Friction and the mean inertia cannot be negative: bounded least squares keeps the fit
    # physical where the speed noise of a coarse encoder would tip an unbounded one over,
    # instead of clipping its estimates afterwards. Columns scaled to unit norm, as their
    # units differ by orders of magnitude.
    lower = np.array([0.0 if name in NON_NEGATIVE else -np.inf for name in fitted])
    A = np.vstack([a[:, cols] for a, _ in blocks])
    norms = np.linalg.norm(A, axis=0)
    norms[norms == 0.0] = 1.0
    weights = np.ones(len(blocks))
    if len(blocks) > 1:
        first = np.linalg.lstsq(A / norms, np.concatenate([y for _, y in blocks]), rcond=None)[0]
        weights = np.array(
            [1.0 / max(np.sqrt(np.mean((y - a[:, cols] / norms @ first) ** 2)), 1e-300)
             for a, y in blocks]
        )
    scaled = [a[:, cols] / norms * w for (a, _), w in zip(blocks, weights)]
    targets = [y * w for (_, y), w in zip(blocks, weights)]
    fit = lsq_linear(
        np.vstack(scaled), np.concatenate(targets), bounds=(lower * norms, np.inf), method="bvls"
    )
    residuals = [y - a @ fit.x for a, y in zip(scaled, targets)]
    cov_scaled = _overlap_covariance(scaled, residuals)
    if torque_noise is not None:  # the torque noise's share, exactly
        bread = np.linalg.pinv(sum(a.T @ a for a in scaled))
        meat = sum(
            (w * sigma) ** 2 * _banded_gram(a, Q)
            for a, w, sigma, Q in zip(scaled, weights, torque_noise, noise_cov)
        )
        cov_scaled = cov_scaled + bread @ meat @ bread
    cov_fitted = cov_scaled / np.outer(norms, norms)
    values = dict.fromkeys(unknowns, 0.0) | dict(zip(fitted, fit.x / norms))
    index = [unknowns.index(name) for name in fitted]
    covariance = np.full((len(unknowns), len(unknowns)), np.nan)
    covariance[np.ix_(index, index)] = cov_fitted
    return values, covariance


def _banded_gram(a: np.ndarray, band: np.ndarray) -> np.ndarray:
    """a^T Q a for the symmetric banded Q of :func:`modulated_rows` (band[lag, j] = Q_j,j+lag)."""
    gram = (a * band[0][:, None]).T @ a
    for lag in range(1, min(len(band), len(a))):
        cross = (a[:-lag] * band[lag, :-lag, None]).T @ a[lag:]
        gram += cross + cross.T
    return gram


def _overlap_covariance(A: Sequence[np.ndarray], residuals: Sequence[np.ndarray]) -> np.ndarray:
    """Covariance of the least squares A x = y over the passes' stacked windows, from their
    residuals, each window's error correlated with the OVERLAP - 1 windows of its pass it
    shares samples with: the sandwich (A^T A)^-1 S (A^T A)^-1, S the residual-weighted outer
    products of the rows summed over lags below OVERLAP with Bartlett weights
    1 - lag / OVERLAP (Newey and West's estimator, positive semi-definite), times
    m / (m - unknowns) with m the passes' independent windows (n + OVERLAP - 1) / OVERLAP
    each: the fit takes up that many of them (a pilot of 81 overlapping windows, 21 of them
    independent, and 10 unknowns: a Monte Carlo of its torque noise found M0's spread 1.7
    times the uncorrected estimate's). NaN without a degree of freedom."""
    k = A[0].shape[1]
    independent = sum((len(r) + OVERLAP - 1) / OVERLAP for r in residuals)
    if independent <= k:
        return np.full((k, k), np.nan)
    meat = np.zeros((k, k))
    for a, r in zip(A, residuals):
        scores = a * r[:, None]
        meat += scores.T @ scores
        for lag in range(1, min(OVERLAP, len(r))):
            cross = scores[:-lag].T @ scores[lag:]
            meat += (1.0 - lag / OVERLAP) * (cross + cross.T)
    bread = np.linalg.pinv(sum(a.T @ a for a in A))
    return bread @ meat @ bread * independent / (independent - k)
