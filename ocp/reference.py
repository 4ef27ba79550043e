"""The mirrored reference of the reverse pass (docs/method.md §4, the paper's (2)-(3)).

In file time (each log from t = 0), with T the braking's rest time:

    phi'(t') = phi(T - t'),   Omega'(t') = -Omega(T - t'),   eps'(t') = eps(T - t')

for 0 <= t' <= T. The braking states come from the Kalman/RTS smoother of the identification
(rsp_inertia.estimation.smoothing: the same estimates, not a second smoother).

The rest. The braking log ends at the last sample before the speed reaches zero; the rest
lies less than a sample later. A straight line fitted to the smoothed speed over the last
``REST_WINDOW`` seconds, or over the last ``REST_COUNTS`` counts of motion if that is longer
(the deceleration is constant to first order near rest) gives the
rest time T (its root) and, integrated, the angles there and the rest angle phi7.
A fit over a window, not the last smoothed state alone: at the very
end of a log the smoother has no later data and its speed scatters by ~1e-2 rad/s (enough
to move T by several samples, or to make the end speed negative, which would make the
mirror start forwards). Over that last window the mirror is the fitted deceleration.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from rsp_inertia.estimation.smoothing import Smoothed, hermite, median_step
from rsp_inertia.infra.errors import InputError

__all__ = ["REST_COUNTS", "REST_WINDOW", "Mirror", "RestFit", "braking_states_at", "mirror", "rest_fit"]

REST_WINDOW = 0.05
"""s of the braking's end over which the deceleration to rest is fitted."""

REST_COUNTS = 20
"""The fit's window is widened until the body moves at least this many encoder counts in it
(a coarse encoder near rest moves a count in many samples: 50 ms of a 12-bit log near rest
hold a count or two, too few to fit a deceleration)."""


@dataclass(frozen=True)
class Mirror:
    """The reverse pass's reference on the program's time grid."""

    t: np.ndarray
    """s, from 0 at the start of the reverse (the braking's rest), step 1/sample_rate."""
    phi: np.ndarray
    """rad, phi(T - t)."""
    omega: np.ndarray
    """rad/s, -Omega(T - t) (negative: the body runs back)."""
    eps: np.ndarray
    """rad/s^2, eps(T - t)."""
    rest_time: float
    """T, s: when the braking came to rest (braking log's time)."""
    rest_angle: float
    """phi7, rad: where it came to rest."""
    fitted_from: float
    """s, braking time from which on the mirror is the fitted deceleration, not the smoother."""


@dataclass(frozen=True)
class RestFit:
    """Straight line fitted to the braking's speed over its last REST_WINDOW."""

    t_n: float
    """s, time of the last sample."""
    start: float
    """s, where the fit takes over from the smoother."""
    speed: float
    """rad/s, fitted speed at t_n (>= 0)."""
    decel: float
    """rad/s^2, fitted deceleration (> 0)."""
    phi7: float
    """rad, rest angle."""

    @property
    def rest_time(self) -> float:
        """T, s."""
        return self.t_n + self.speed / self.decel

    def states(self, times: np.ndarray):
        """(phi, Omega, eps) at braking times up to the rest, on the fitted line."""
        left = self.rest_time - np.asarray(times)  # time still to go to rest
        return self.phi7 - self.decel * left**2 / 2, self.decel * left, np.full(left.shape, -self.decel)


def rest_fit(sm: Smoothed, source: str, quantum: float) -> RestFit:
    """The deceleration to rest fitted over the braking's end (module docstring).

    Parameters
    ----------
    sm : Smoothed
        The smoothed braking pass.
    source : str
        Names the log in messages.
    quantum : float
        rad, the encoder's count: the window holds at least REST_COUNTS of them.

    Returns
    -------
    RestFit
        The fitted line and the rest angle phi7.

    Raises
    ------
    InputError
        The body is not decelerating at the end of the log, or the log ends well before
        the rest: the braking did not reach rest.
    """
    dt = median_step(sm.t)  # the sample period (time stamps may jitter)
    n = max(round(REST_WINDOW / dt), 3)
    moved = sm.phi[-1] - sm.phi  # distance still to go at each sample
    enough = np.nonzero(moved >= REST_COUNTS * quantum)[0]
    if enough.size:
        n = max(n, len(sm.t) - int(enough[-1]))
    n = min(n, len(sm.t))
    slope, end = np.polyfit(sm.t[-n:] - sm.t[-1], sm.omega[-n:], 1)
    if slope >= 0.0:
        raise InputError(
            f"{source}: the body is not decelerating at the end of the log (speed "
            f"{end:.3g} rad/s, acceleration {slope:.3g} rad/s^2): the braking did not reach rest"
        )
    # The log runs up to the rest, so the rest is not before its last sample: a fitted end
    # speed below zero is the smoother's scatter.
    fit = RestFit(float(sm.t[-1]), float(sm.t[-n]), max(float(end), 0.0), float(-slope), 0.0)
    if fit.rest_time - fit.t_n > (sm.t[-1] - fit.start) + dt:
        raise InputError(
            f"{source}: the log ends {fit.rest_time - fit.t_n:.3g} s before the body comes to "
            f"rest (speed {fit.speed:.3g} rad/s): the braking did not reach rest"
        )
    # phi7: the smoothed angle where the fit starts plus the line's distance to rest.
    left = fit.rest_time - fit.start
    return dataclasses.replace(fit, phi7=float(sm.phi[-n]) + fit.decel * left**2 / 2)


def braking_states_at(sm: Smoothed, times: np.ndarray, rest: tuple[float, float]):
    """Smoothed braking (phi, Omega, eps) at arbitrary times of the braking log.

    Cubic Hermite between samples (phi with Omega, Omega with eps); after the last sample,
    the constant deceleration that ends at the rest point.

    Parameters
    ----------
    sm : Smoothed
        The smoothed braking pass.
    times : numpy.ndarray
        s, times of the braking log.
    rest : tuple of float
        The rest point (T, phi7): s, rad.

    Returns
    -------
    phi, Omega, eps : numpy.ndarray
        rad, rad/s, rad/s^2 at ``times``.
    """
    times = np.asarray(times, dtype=float)
    t = sm.t
    k = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 2)
    at = np.maximum(times, t[k])
    phi = hermite(t[k], t[k + 1], sm.phi[k], sm.omega[k], sm.phi[k + 1], sm.omega[k + 1], at)
    omega = hermite(t[k], t[k + 1], sm.omega[k], sm.eps[k], sm.omega[k + 1], sm.eps[k + 1], at)
    s = np.minimum((at - t[k]) / (t[k + 1] - t[k]), 1.0)
    eps = sm.eps[k] + (sm.eps[k + 1] - sm.eps[k]) * s
    tail = times > t[-1]
    if np.any(tail):
        T, phi7 = rest
        decel = max(sm.omega[-1], 0.0) / max(T - t[-1], 1e-12)
        left = T - times[tail]  # time still to go to rest
        omega[tail] = decel * left
        phi[tail] = phi7 - decel * left**2 / 2
        eps[tail] = -decel
    return phi, omega, eps


def mirror(
    sm: Smoothed, sample_rate: float, quantum: float, source: str = "braking.csv"
) -> Mirror:
    """The time mirror of a smoothed braking pass at the encoder's sample rate.

    Parameters
    ----------
    sm : Smoothed
        The smoothed braking pass.
    sample_rate : float
        Hz, the encoder's sample rate: the mirror's grid.
    quantum : float
        q, rad: an encoder count (:func:`rest_fit`).
    source : str, optional
        Names the log in messages.

    Returns
    -------
    Mirror
        The reverse pass's reference.

    Raises
    ------
    InputError
        The braking did not reach rest (:func:`rest_fit`).
    """
    fit = rest_fit(sm, source, quantum)
    T, phi7 = fit.rest_time, fit.phi7
    dt = 1.0 / sample_rate
    n = math.floor(T / dt + 1e-9) + 1
    t = np.arange(n) * dt
    phi, omega, eps = braking_states_at(sm, T - t, (T, phi7))
    # Over the last window the fitted deceleration replaces the smoother (module docstring).
    last = T - t >= fit.start
    phi[last], omega[last], eps[last] = fit.states(T - t[last])
    return Mirror(
        t=t, phi=phi, omega=-omega, eps=eps, rest_time=T, rest_angle=phi7, fitted_from=fit.start
    )
