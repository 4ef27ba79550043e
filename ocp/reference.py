"""The mirrored reference of the reverse pass (METHOD.md §4, the paper's (2)-(3)).

In file time (each log from t = 0), with T the braking's rest time:

    phi'(t') = phi(T - t'),   Omega'(t') = -Omega(T - t'),   eps'(t') = eps(T - t')

for 0 <= t' <= T. The braking states come from the UKF/RTS smoother of the identification
(estimation.smoothing: the same estimates, not a second smoother).

The rest time. The braking log ends at the last sample before the speed reaches zero; the
rest lies less than a sample later. Over that last stretch the deceleration is constant to
first order, so from the last smoothed state (t_n, phi_n, Omega_n > 0, eps_n < 0):
T = t_n + Omega_n / |eps_n| and phi7 = phi_n + Omega_n^2 / (2 |eps_n|).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from estimation.smoothing import Smoothed, hermite
from plant.errors import InputError

__all__ = ["Mirror", "rest_point", "mirror", "braking_states_at"]


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


def rest_point(sm: Smoothed, source: str = "braking.csv") -> tuple[float, float]:
    """Rest time T and angle phi7 of a braking pass, from its last smoothed state."""
    w, e = float(sm.omega[-1]), float(sm.eps[-1])
    if w <= 0.0:
        return float(sm.t[-1]), float(sm.phi[-1])
    if e >= 0.0:
        raise InputError(
            f"{source}: the body is not decelerating at the end of the log "
            f"(speed {w:.3g} rad/s, acceleration {e:.3g} rad/s^2): the braking did not reach rest"
        )
    tau = w / -e
    return float(sm.t[-1] + tau), float(sm.phi[-1] + w * tau / 2)


def braking_states_at(sm: Smoothed, times: np.ndarray, rest: tuple[float, float]):
    """Smoothed braking (phi, Omega, eps) at arbitrary times of the braking log.

    Cubic Hermite between samples (phi with Omega, Omega with eps); after the last sample,
    the constant deceleration that ends at the rest point.
    """
    times = np.asarray(times, dtype=float)
    t = sm.t
    dt = t[1] - t[0]
    k = np.clip(np.floor((times - t[0]) / dt).astype(int), 0, len(t) - 2)
    at = np.maximum(times, t[k])
    phi = hermite(t[k], t[k + 1], sm.phi[k], sm.omega[k], sm.phi[k + 1], sm.omega[k + 1], at)
    omega = hermite(t[k], t[k + 1], sm.omega[k], sm.eps[k], sm.omega[k + 1], sm.eps[k + 1], at)
    s = np.minimum((at - t[k]) / dt, 1.0)
    eps = sm.eps[k] + (sm.eps[k + 1] - sm.eps[k]) * s
    tail = times > t[-1]
    if np.any(tail):
        T, phi7 = rest
        decel = sm.omega[-1] / max(T - t[-1], 1e-12)
        left = T - times[tail]  # time still to go to rest
        omega[tail] = decel * left
        phi[tail] = phi7 - decel * left**2 / 2
        eps[tail] = -decel
    return phi, omega, eps


def mirror(sm: Smoothed, sample_rate: float, source: str = "braking.csv") -> Mirror:
    """The time mirror of a smoothed braking pass at the encoder's sample rate."""
    T, phi7 = rest_point(sm, source)
    dt = 1.0 / sample_rate
    n = int(math.floor(T / dt + 1e-9)) + 1
    t = np.arange(n) * dt
    phi, omega, eps = braking_states_at(sm, T - t, (T, phi7))
    return Mirror(t=t, phi=phi, omega=-omega, eps=eps, rest_time=T, rest_angle=phi7)
