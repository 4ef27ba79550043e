"""The torsion pendulum's best-practice reduction (docs/method.md §5, the baseline's third way).

The classic reductions (rsp_inertia.estimation.pendulum) ignore Coulomb and quadratic
friction, an off-centre body's gravity stiffness and the amplitude dependence of the
frequency. :func:`half_cycle_fit` and :func:`best_practice_inertia` do what a careful pendulum
user does about each of those:

- *Coulomb and viscous friction.* Between two turning points the friction's sign is
  fixed, so M x'' + a2 x' + a1 sgn + k x = 0 is a linear oscillator about a centre
  shifted by a1 / k: x = c_i + exp(-delta t) (a_i cos w_d t + b_i sin w_d t) on every
  half cycle i, with the same w_d and delta throughout and a centre that alternates.
  Fitted to every half cycle at once (variable projection: c_i, a_i, b_i by linear
  least squares for each trial (w, delta)), then w_n^2 = w_d^2 + delta^2, exact for this
  model; Coulomb friction leaves the frequency alone. Quadratic friction acts as an
  amplitude-dependent viscous term: its frequency effect is of order (delta / w)^2,
  which the budget carries as the damping model's error.
- *Amplitude.* Gravity's curvature and M's variation with the angle make the frequency
  depend on the amplitude, to first order w_d (1 + kappa A^2): each half cycle has its
  own amplitude A_i (half its range), kappa is fitted with the rest when the amplitudes
  spread (AMPLITUDE_SPREAD; a prior KAPPA_PRIOR keeps it physical), and w_d is its value
  at zero amplitude. A pendulum that barely decays cannot tell kappa from w_d: kappa is
  then 0 and its effect budgeted (KAPPA_BOUND).
- *Gravity stiffness.* The body's centre of mass off the shaft adds d^2 Pi / d phi^2 =
  -(Gs sin phi_k + Gc cos phi_k) to the torsion stiffness c at the node (docs/method.md §3:
  Pi = Gs sin phi + Gc cos phi). Gs, Gc come from the RSP least squares (the body's,
  with its covariance) plus the calibrated fixture's: M = (c + k_g) / w_n^2.
- *Stiffness.* The calibrated one (rsp_inertia.estimation.stiffness), else device.toml's
  [pendulum] stiffness with its stated std.

Each J_best carries the std of its own budget: the fit (encoder readings), the
stiffness, the gravity correction, and the damping model.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from rsp_inertia.estimation.pendulum import pendulum_inertia
from rsp_inertia.estimation.smoothing import median_step
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.logs import Log

__all__ = [
    "AMPLITUDE_SPREAD",
    "KAPPA_BOUND",
    "KAPPA_PRIOR",
    "MIN_AMPLITUDE_COUNTS",
    "MIN_HALF_CYCLES",
    "BestPractice",
    "HalfCycleFit",
    "best_practice_inertia",
    "encoder_edges",
    "gravity_stiffness",
    "half_cycle_fit",
    "turning_points",
]

MIN_HALF_CYCLES = 6
"""Half cycles the best-practice fit needs (three periods: the amplitude term needs a spread
of amplitudes, the damping a decay)."""

KAPPA_PRIOR = 1.0
"""1/rad^2, std of the Gaussian prior on kappa, the frequency's relative change per squared
amplitude. A pendulum that barely decays gives every half cycle nearly the same amplitude,
and then kappa and the zero-amplitude frequency trade off freely. Physically kappa stays
small: gravity's curvature is m g r / c ~ 0.04 of the stiffness here, and M's relative
second derivative is below 4 (its harmonics are smaller than M0), which give |kappa| of
order 0.01-0.5 (fitted 0.01-0.15 where the amplitude decays). With a prior std of 1 the data
decide when the amplitudes spread, and the prior bounds the extrapolation when they do not
(kappa A^2 <= 8e-3 at 5 deg)."""

KAPPA_BOUND = 0.15
"""1/rad^2: |kappa| assumed when the amplitudes do not spread enough to fit it
(AMPLITUDE_SPREAD): the largest fitted on the virtual device where they do (-0.10 to +0.11
over the default stages' nodes at friction x1-x100). The amplitude budget is then
2 M KAPPA_BOUND A_max^2, 2.3e-3 of M at 5 deg."""

AMPLITUDE_SPREAD = 0.75
"""kappa is fitted only when the smallest half-cycle amplitude squared is at most this
fraction of the largest; above it (a pendulum that barely decays: the default stage 2 at
friction x1 keeps 0.95) kappa is 0 and KAPPA_BOUND budgets the amplitude effect."""

MIN_AMPLITUDE_COUNTS = 20
"""Half cycles whose amplitude is under this many encoder counts are left out: near the end
of a run Coulomb friction stops the body, and a few counts are all quantization."""


@dataclass(frozen=True)
class HalfCycleFit:
    """The free oscillation's frequency, decay and amplitude dependence (module docstring)."""

    omega_n: float
    """rad/s, undamped angular frequency at zero amplitude, sqrt(w_d^2 + delta^2)."""
    omega_n_std: float
    """rad/s, from the fit alone."""
    omega_d: float
    """rad/s, damped frequency at zero amplitude."""
    delta: float
    """1/s, viscous decay rate."""
    kappa: float
    """1/rad^2, relative frequency change per squared amplitude."""
    kappa_fitted: bool
    """Whether the amplitudes spread enough to fit kappa (AMPLITUDE_SPREAD); else 0."""
    centre: float
    """rad, the equilibrium: the mean of the half cycles' centres over an even number of
    them (Coulomb friction shifts them alternately by +-a1 / k)."""
    amplitude: float
    """rad, the largest half-cycle amplitude fitted."""
    half_cycles: int
    """Half cycles fitted."""
    residual_rms: float
    """rad, of the fit (encoder edges alone give x' dt / sqrt 12, at most q / sqrt 12)."""


def turning_points(log: Log, period: float) -> np.ndarray:
    """Sample indices where the oscillation turns, from the readings' slope over a tenth of
    a period (the quantization's steps averaged out); turns closer than a quarter period
    are merged."""
    t, phi = log.t, log.phi
    dt = median_step(t)
    half = max(round(period / 20 / dt), 1)
    slope = np.zeros_like(phi)
    slope[half:-half] = phi[2 * half :] - phi[: -2 * half]
    sign = np.sign(slope)
    nz = np.nonzero(sign)[0]
    turns: list[int] = []
    for j in np.nonzero(sign[nz[1:]] != sign[nz[:-1]])[0]:
        k = int(nz[j + 1])
        if turns and (t[k] - t[turns[-1]]) < period / 4:
            continue
        # The extremum near the flip: a maximum after a rise, a minimum after a fall.
        lo, hi = max(k - 2 * half, 0), min(k + 2 * half, phi.size - 1)
        window = phi[lo : hi + 1]
        rising = sign[nz[j]] > 0
        turns.append(lo + int(np.argmax(window) if rising else np.argmin(window)))
    return np.asarray(turns, dtype=int)


def encoder_edges(t: np.ndarray, phi: np.ndarray, quantum: float) -> tuple[np.ndarray, np.ndarray]:
    """(time, angle) of every change of an encoder's reading: the midpoint of the two samples
    and the mean of the two readings plus half a count.

    The readings are floor(x / q) q. When they step by one count the body crossed the level
    between the two counts, max of the two readings, which the mean plus q / 2 is, exactly,
    somewhere within the sample: the observation's error is x' u, u uniform over +-dt/2, and
    no longer the staircase's q / sqrt 12, constant over the samples that stay on one count.
    A step of several counts (a fine encoder, a fast body) crosses several levels; their mean
    is the same expression, and the error that of the readings' mean.

    Parameters
    ----------
    t : numpy.ndarray
        s, the samples' times.
    phi : numpy.ndarray
        rad, the encoder's readings floor(x / q) q.
    quantum : float
        q, rad, the encoder's count.

    Returns
    -------
    time, angle : numpy.ndarray
        s and rad, one entry per change of the reading.
    """
    change = np.nonzero(np.diff(phi) != 0.0)[0]
    return 0.5 * (t[change] + t[change + 1]), 0.5 * (phi[change] + phi[change + 1]) + quantum / 2


def half_cycle_fit(log: Log, period: float, quantum: float, source: str) -> HalfCycleFit:
    """Fit x = c_i + exp(-delta s) (a_i cos w_i s + b_i sin w_i s) on every half cycle i
    (s from its start), w_i = w_d (1 + kappa A_i^2), sharing (w_d, delta, kappa), kappa with
    a Gaussian prior of std KAPPA_PRIOR.

    Variable projection: for trial (w_d, delta, kappa) each half cycle's c_i, a_i, b_i are a
    linear least squares, and the shared three minimise the sum of squares
    (scipy.optimize.least_squares); their covariance is the residual variance times
    (J^T J)^-1 of the projected residuals (Golub and Pereyra).

    The observations are the encoder's edges (:func:`encoder_edges`), not its readings: a
    reading that stays on one count for many samples is a staircase whose odd harmonics,
    over a half-cycle window, lean on the frequency's column and bias it, while an edge is
    the crossing of a known level.

    Parameters
    ----------
    log : Log
        The pendulum run's log.
    period : float
        s, the oscillation's approximate period (the start of the fit; it sets the turning
        points' detection, :func:`turning_points`).
    quantum : float
        q, rad, the encoder's count.
    source : str
        Names the log in messages.

    Returns
    -------
    HalfCycleFit
        The frequency at zero amplitude with its std, the decay, kappa and the centre.

    Raises
    ------
    InputError
        Fewer than MIN_HALF_CYCLES half cycles above MIN_AMPLITUDE_COUNTS counts.
    """
    turns = turning_points(log, period)
    t, phi = log.t, log.phi
    segments = []
    for a, b in itertools.pairwise(turns):
        amplitude = 0.5 * abs(phi[b] - phi[a])
        if amplitude < MIN_AMPLITUDE_COUNTS * quantum:
            break
        te, xe = encoder_edges(t[a : b + 1], phi[a : b + 1], quantum)
        segments.append((te - t[a], xe, amplitude))
    if len(segments) < MIN_HALF_CYCLES:
        raise InputError(
            f"{source}: {len(segments)} half cycles of the oscillation above "
            f"{MIN_AMPLITUDE_COUNTS} counts, the best-practice fit needs {MIN_HALF_CYCLES} "
            "(friction stops the pendulum too soon: a larger amplitude or a stiffer spring)"
        )

    segments = segments[: len(segments) // 2 * 2]  # pairs: the Coulomb shifts cancel

    def solve(p: np.ndarray) -> tuple[np.ndarray, list[float]]:
        """Projected residuals and the half cycles' centres c_i at (w_d, delta, kappa)."""
        w, delta, kappa = p
        out, centres = [], []
        for s, y, amp in segments:
            wi = w * (1.0 + kappa * amp * amp)
            decay = np.exp(-delta * s)
            X = np.column_stack([np.ones_like(s), decay * np.cos(wi * s), decay * np.sin(wi * s)])
            coef, *_ = np.linalg.lstsq(X, y, rcond=None)
            out.append(y - X @ coef)
            centres.append(float(coef[0]))
        return np.concatenate(out), centres

    # An edge's error, x' u with u uniform over +-dt/2 (at most a count's, q / sqrt 12): the
    # prior's row in the same weights.
    dt = median_step(log.t)
    step = np.concatenate(
        [np.minimum(np.abs(np.gradient(y, s)) * dt, quantum) for s, y, _ in segments if s.size > 1]
    )
    sigma = float(np.sqrt(np.mean(step**2) / 12.0))
    amplitudes = np.array([amp for _, _, amp in segments])
    kappa_fitted = (amplitudes.min() / amplitudes.max()) ** 2 <= AMPLITUDE_SPREAD

    def residuals(p: np.ndarray) -> np.ndarray:
        if not kappa_fitted:
            return solve(np.append(p, 0.0))[0]
        return np.append(solve(p)[0], sigma * p[2] / KAPPA_PRIOR)

    w0 = 2 * math.pi / period
    start, scale = [w0, 0.0, 0.0], [w0 * 1e-3, 1e-2, 1e-2]
    shared = 3 if kappa_fitted else 2
    fit = least_squares(residuals, x0=start[:shared], x_scale=scale[:shared])
    r = fit.fun
    n = r.size - (1 if kappa_fitted else 0)  # the prior's row is not a reading
    variance = float(r @ r) / max(n - shared - 3 * len(segments), 1)
    cov = np.zeros((3, 3))
    cov[:shared, :shared] = (
        variance * _correlation_factor(r[:n], period, dt)
        * np.linalg.pinv(fit.jac.T @ fit.jac)
    )
    params = np.append(fit.x, 0.0) if not kappa_fitted else fit.x
    w_d, delta, kappa = map(float, params)
    centres = solve(params)[1]
    w_n = math.hypot(w_d, delta)
    # d w_n = (w_d d w_d + delta d delta) / w_n.
    grad = np.array([w_d / w_n, delta / w_n, 0.0])
    return HalfCycleFit(
        omega_n=w_n,
        omega_n_std=float(math.sqrt(max(grad @ cov @ grad, 0.0))),
        omega_d=w_d,
        delta=delta,
        kappa=kappa,
        kappa_fitted=bool(kappa_fitted),
        centre=float(np.mean(centres)),
        amplitude=float(max(amp for _, _, amp in segments)),
        half_cycles=len(segments),
        residual_rms=float(math.sqrt(variance)),
    )


def _correlation_factor(r: np.ndarray, period: float, dt: float) -> float:
    """1 + 2 sum_k rho_k of the residuals over lags up to a tenth of a period, at least 1:
    the variance factor of an average of correlated errors. A reading's quantization error is
    independent from sample to sample only while the body crosses counts quickly; near the
    turning points, and everywhere on a coarse encoder, it stays on one count for many
    samples."""
    lags = max(min(round(period / 10 / dt), r.size // 4), 1)
    r = r - r.mean()
    c0 = float(r @ r)
    if c0 == 0.0:
        return 1.0
    rho = [float(r[k:] @ r[:-k]) / c0 for k in range(1, lags + 1)]
    return max(1.0 + 2.0 * sum(rho), 1.0)


@dataclass(frozen=True)
class BestPractice:
    """Reduced inertia at a node by the best-practice reduction, with its budget."""

    M: float
    """kg m^2, (c + k_g) / w_n^2."""
    M_std: float
    """kg m^2, the budget's parts in quadrature."""
    budget: dict[str, float]
    """kg m^2 per source: "fit", "stiffness", "gravity", "damping model", "amplitude"."""
    gravity_stiffness: float
    """k_g, N m/rad."""
    fit: HalfCycleFit


def gravity_stiffness(gravity: np.ndarray, phi: float) -> float:
    """k_g = d^2 Pi / d phi^2 = -(Gs sin phi + Gc cos phi), N m/rad, of gravity terms
    [Gs, Gc] at the angle phi (docs/method.md §3: Pi = Gs sin phi + Gc cos phi)."""
    return -(float(gravity[0]) * math.sin(phi) + float(gravity[1]) * math.cos(phi))


def best_practice_inertia(
    fit: HalfCycleFit,
    stiffness: float,
    stiffness_std: float,
    node: float,
    gravity: np.ndarray,
    gravity_cov: np.ndarray,
) -> BestPractice:
    """M = (c + k_g) / w_n^2 at node angle ``node``, k_g = -(Gs sin + Gc cos)(node).

    Two model errors are budgeted at the size of the correction they come from:
    the damping model's, M (delta / w_n)^2 (quadratic friction's frequency effect is of that
    order), and the amplitude extrapolation's, 2 M |kappa| A_max^2 (KAPPA_BOUND for kappa
    when it was not fitted; w (1 + kappa A^2) is only the first term of the frequency's
    dependence on the amplitude).

    Parameters
    ----------
    fit : HalfCycleFit
        The oscillation's fit (:func:`half_cycle_fit`).
    stiffness : float
        c, N m/rad, the torsion element's stiffness.
    stiffness_std : float
        N m/rad, its std.
    node : float
        rad, the node's angle.
    gravity : numpy.ndarray, shape (2,)
        [Gs, Gc], N m, of everything on the shaft (body and fixture).
    gravity_cov : numpy.ndarray, shape (2, 2)
        N^2 m^2, their covariance.

    Returns
    -------
    BestPractice
        M, kg m^2, with its std and the budget's parts.
    """
    rows = np.array([-math.sin(node), -math.cos(node)])  # d k_g / d[Gs, Gc]
    k_g = gravity_stiffness(gravity, node)
    k = stiffness + k_g
    w2 = fit.omega_n**2
    M = pendulum_inertia(k, fit.omega_n)
    budget = {
        "fit": 2 * M * fit.omega_n_std / fit.omega_n,
        "stiffness": stiffness_std / w2,
        "gravity": float(math.sqrt(max(rows @ gravity_cov @ rows, 0.0))) / w2,
        "damping model": M * (fit.delta / fit.omega_n) ** 2,
        "amplitude": 2 * M * (abs(fit.kappa) if fit.kappa_fitted else KAPPA_BOUND)
        * fit.amplitude**2,
    }
    return BestPractice(
        M=M,
        M_std=float(math.sqrt(sum(v * v for v in budget.values()))),
        budget=budget,
        gravity_stiffness=k_g,
        fit=fit,
    )
