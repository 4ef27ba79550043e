"""Work-energy balances of the two passes of a stage (METHOD.md §3-5).

A pass is turned into functions of the angle: the speed (smoothed), the motor work from the
start of the pass (Stieltjes sum of the logged torque over encoder increments), and the
variance that the torque log's noise puts into that work. The node formula and the least
squares both read a stage through :func:`balance_at`.

Motor work at an angle between two rows. The Stieltjes sum W_K = sum_{k<K} u_k (y_{k+1} - y_k)
over encoder readings y differs from the true work by u_{K-1} e_K - u_0 e_0 - sum e_k du_k,
e = y - phi the reading's error (telescoping). The first term is removed by evaluating the
work at the *smoothed* angle: W(phi*) = W_K + u_K (phi* - y_K), K the last row at or before
phi*; the second is a constant of the pass (it cancels in every difference), the third is
second order (the torque changes little per sample).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimation.smoothing import Smoothed, smooth_log
from plant.errors import InputError
from plant.logs import Log

__all__ = [
    "PassEstimate",
    "estimate_pass",
    "torque_noise",
    "AngleSample",
    "sample_at",
    "check_braking_monotone",
]


def torque_noise(log: Log) -> float:
    """Standard deviation of the torque log's noise, N m, from its sample-to-sample changes.

    The torque a motor applies changes little from one sample to the next; white logging
    noise of std sigma makes the differences' std sigma sqrt(2). A robust scale (median
    absolute deviation) keeps genuine steps from inflating it.
    """
    d = np.diff(log.torque)
    if d.size < 2:
        return 0.0
    mad = np.median(np.abs(d - np.median(d)))
    return float(1.4826 * mad / np.sqrt(2.0))


@dataclass(frozen=True)
class PassEstimate:
    """One pass, ready for energy balances."""

    log: Log
    """The encoder log."""
    smoothed: Smoothed
    """Smoothed angle, speed, acceleration at every row."""
    work: np.ndarray
    """J, motor work from the first row to each row (Stieltjes sum, ZOH)."""
    work_var_steps: np.ndarray
    """rad^2, cumulative sum of (y_{k+1} - y_k)^2 to each row: var(work) = sigma^2 times it."""
    sigma_torque: float
    """N m, std of the torque log's noise."""
    source: str
    """Name of the log for messages."""


def check_braking_monotone(log: Log, source: str) -> None:
    """The braking speed never reverses: encoder readings never decrease (INTERFACES.md)."""
    back = np.nonzero(np.diff(log.phi) < 0)[0]
    if back.size:
        line = int(back[0]) + 3  # row k+1 of the data is line k+3 (header is line 1)
        raise InputError(
            f"{source}, line {line}: the angle decreases: the speed reverses inside the braking"
        )


def estimate_pass(log: Log, quantum: float, source: str) -> PassEstimate:
    """Smooth a pass and accumulate its motor work (METHOD.md §3, Stieltjes sum)."""
    smoothed = smooth_log(log, quantum, source)
    dphi = np.diff(log.phi)
    work = np.concatenate([[0.0], np.cumsum(log.torque[:-1] * dphi)])
    steps = np.concatenate([[0.0], np.cumsum(dphi * dphi)])
    return PassEstimate(
        log=log,
        smoothed=smoothed,
        work=work,
        work_var_steps=steps,
        sigma_torque=torque_noise(log),
        source=source,
    )


@dataclass(frozen=True)
class AngleSample:
    """A pass's quantities at given angles."""

    phi: np.ndarray
    """rad, the angles asked for."""
    time: np.ndarray
    """s, when the pass is there (smoothed angle)."""
    omega: np.ndarray
    """rad/s, speed there (signed)."""
    omega_std: np.ndarray
    """rad/s, std of ``omega``."""
    work: np.ndarray
    """J, motor work from the pass's first row to there."""
    work_var_steps: np.ndarray
    """rad^2, sum of squared encoder increments to there (torque-noise variance factor)."""


def sample_at(est: PassEstimate, phi: np.ndarray) -> AngleSample:
    """Speed, motor work and their noise factors where the pass is at angles ``phi``.

    The smoothed angle is monotone along a pass; the instant it reaches phi* is found by
    linear interpolation between rows and one Newton step with the smoothed speed; the speed
    there by cubic Hermite interpolation with the smoothed acceleration.
    """
    sm = est.smoothed
    phi = np.asarray(phi, dtype=float)
    rising = sm.phi[-1] > sm.phi[0]
    order = slice(None) if rising else slice(None, None, -1)
    ang = sm.phi[order]
    if np.any(np.diff(ang) <= 0):
        # Near rest the smoothed angle can stall; keep the monotone envelope for the search.
        ang = np.maximum.accumulate(ang)
    idx = np.clip(np.searchsorted(ang, phi, side="right") - 1, 0, len(ang) - 2)
    rows = idx if rising else len(ang) - 1 - idx  # row index in the log's order
    nxt = rows + 1 if rising else rows - 1
    a0, a1 = sm.phi[rows], sm.phi[nxt]
    frac = np.where(a1 != a0, (phi - a0) / np.where(a1 != a0, a1 - a0, 1.0), 0.0)
    dt = sm.t[1] - sm.t[0]
    step = dt if rising else -dt
    t = sm.t[rows] + frac * step
    # One Newton step on phi(t) = phi* with the Hermite form of the smoothed angle.
    k = np.minimum(rows, nxt)
    t0, t1 = sm.t[k], sm.t[k + 1]
    s = (t - t0) / (t1 - t0)
    h = t1 - t0
    p = (
        (2 * s**3 - 3 * s**2 + 1) * sm.phi[k]
        + (s**3 - 2 * s**2 + s) * h * sm.omega[k]
        + (-2 * s**3 + 3 * s**2) * sm.phi[k + 1]
        + (s**3 - s**2) * h * sm.omega[k + 1]
    )
    w_lin = sm.omega[k] + (sm.omega[k + 1] - sm.omega[k]) * s
    t = t + np.where(w_lin != 0, (phi - p) / np.where(w_lin != 0, w_lin, 1.0), 0.0)
    t = np.clip(t, t0, t1)
    s = (t - t0) / h
    omega = (
        (2 * s**3 - 3 * s**2 + 1) * sm.omega[k]
        + (s**3 - 2 * s**2 + s) * h * sm.eps[k]
        + (-2 * s**3 + 3 * s**2) * sm.omega[k + 1]
        + (s**3 - s**2) * h * sm.eps[k + 1]
    )
    omega_std = sm.omega_std[k] + (sm.omega_std[k + 1] - sm.omega_std[k]) * s
    # Motor work at the smoothed angle (module docstring): last row at or before time t.
    K = k
    work = est.work[K] + est.log.torque[K] * (phi - est.log.phi[K])
    return AngleSample(
        phi=phi,
        time=t,
        omega=omega,
        omega_std=omega_std,
        work=work,
        work_var_steps=est.work_var_steps[K],
    )
