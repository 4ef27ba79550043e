"""Torsion-pendulum baseline on the same device: the classic reductions (docs/method.md §5).

Motor off, the torsion element of stiffness c zeroed at a node, a small free oscillation.
The classic reduction treats it as an undamped oscillator phi'' + (c/M) phi = 0:

    M = c tau^2 / (4 pi^2),   J_e = (M - M_tare) / (1 + lam^2)

(a) **classic**: tau from the zero crossings of the oscillation;
(b) **damped fit**: phi(t) = phi_e + A exp(-delta t) cos(w_d t + theta) fitted by nonlinear
    least squares, and the undamped frequency w_n^2 = w_d^2 + delta^2 put in M = c / w_n^2
    (the usual correction of the period for viscous damping, as BicycleParameters does).

Both ignore what the RSP method does not: Coulomb and quadratic friction, the gravity
torque of an off-centre body (a stiffness -m g (x_c sin phi + y_c cos phi) of its own about
a horizontal shaft) and the angle dependence of M. Each step is its own small function so
that the data reduction can be followed and tested step by step.

The best practice, what a careful pendulum user does about each of those, is
rsp_inertia.estimation.best_practice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import curve_fit

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.logs import Log

__all__ = [
    "PendulumEstimate",
    "crossing_period",
    "damped_fit",
    "estimate_pendulum",
    "pendulum_inertia",
]


@dataclass(frozen=True)
class PendulumEstimate:
    """Reduced inertia at one node from one pendulum run."""

    stage: int
    """Stage number, from 1."""
    node_deg: float
    """Node, deg."""
    period: float
    """s, from the zero crossings."""
    period_std: float
    """s."""
    M_classic: float
    """kg m^2, c tau^2 / (4 pi^2)."""
    M_classic_std: float
    """kg m^2."""
    M_damped: float
    """kg m^2, c / (w_d^2 + delta^2) from the damped fit."""
    M_damped_std: float
    """kg m^2."""
    damping: float
    """delta, 1/s, decay rate of the fitted envelope."""


def crossing_period(log: Log, source: str) -> tuple[float, float]:
    """Period, s, and its std from the upward crossings of the oscillation's mean angle.

    Crossing instants are interpolated linearly between samples; the period is the slope of
    a straight line through them (crossing k at t_0 + k tau), its std from the residuals.
    """
    phi = log.phi - 0.5 * (log.phi.max() + log.phi.min())
    # Middle of the range, not the mean: the decay shifts the mean toward the late samples.
    up = np.nonzero((phi[:-1] < 0) & (phi[1:] >= 0))[0]
    if up.size < 3:
        raise InputError(f"{source}: fewer than 3 oscillations; log the pendulum longer")
    frac = -phi[up] / (phi[up + 1] - phi[up])
    times = log.t[up] + frac * (log.t[up + 1] - log.t[up])
    k = np.arange(times.size)
    A = np.column_stack([np.ones_like(k), k]).astype(float)
    coef, *_ = np.linalg.lstsq(A, times, rcond=None)
    resid = times - A @ coef
    dof = max(times.size - 2, 1)
    cov = np.linalg.inv(A.T @ A) * (resid @ resid / dof)
    return float(coef[1]), float(math.sqrt(max(cov[1, 1], 0.0)))


def damped_fit(log: Log, period: float) -> tuple[np.ndarray, np.ndarray]:
    """Fit phi_e + A exp(-delta t) cos(w_d t + theta); returns (parameters, their stds).

    Parameters in order [phi_e, A, delta, w_d, theta]. Start values: the mean, half the
    range, no damping, 2 pi / period, and the phase of the first sample.
    """
    t, phi = log.t, log.phi

    def model(t, phi_e, A, delta, w_d, theta):
        return phi_e + A * np.exp(-delta * t) * np.cos(w_d * t + theta)

    phi_e = 0.5 * (phi.max() + phi.min())
    A0 = phi[0] - phi_e
    p0 = [phi_e, abs(A0), 0.0, 2 * math.pi / period, 0.0 if A0 >= 0 else math.pi]
    popt, pcov = curve_fit(model, t, phi, p0=p0, maxfev=20000)
    return popt, np.sqrt(np.abs(np.diag(pcov)))


def pendulum_inertia(stiffness: float, omega_n: float) -> float:
    """M = c / w_n^2 = c tau^2 / (4 pi^2), kg m^2 (docs/method.md §5, baseline)."""
    return stiffness / omega_n**2


def estimate_pendulum(
    log: Log, stiffness: float, stage: int, node_deg: float, source: str
) -> PendulumEstimate:
    """Both pendulum reductions of one run (module docstring: classic and damped fit).

    Parameters
    ----------
    log : Log
        The pendulum run's log.
    stiffness : float
        c, N m/rad, the torsion element's stiffness.
    stage : int
        The stage number, from 1.
    node_deg : float
        deg, the node where the element is zeroed.
    source : str
        Names the log in messages.

    Returns
    -------
    PendulumEstimate
        The period and both reductions' M, kg m^2, with their stds.

    Raises
    ------
    InputError
        Fewer than 3 oscillations in the log (:func:`crossing_period`).
    """
    tau, tau_std = crossing_period(log, source)
    M_classic = pendulum_inertia(stiffness, 2 * math.pi / tau)
    params, stds = damped_fit(log, tau)
    delta, w_d = params[2], params[3]
    w_n = math.sqrt(w_d**2 + delta**2)
    M_damped = pendulum_inertia(stiffness, w_n)
    # dM/M = -2 dw_n/w_n, dw_n = (w_d dw_d + delta ddelta)/w_n (independent errors).
    w_n_std = math.hypot(w_d * stds[3], delta * stds[2]) / w_n
    return PendulumEstimate(
        stage=stage,
        node_deg=node_deg,
        period=tau,
        period_std=tau_std,
        M_classic=M_classic,
        M_classic_std=2 * M_classic * tau_std / tau,
        M_damped=M_damped,
        M_damped_std=2 * M_damped * w_n_std / w_n,
        damping=float(delta),
    )
