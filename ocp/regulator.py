"""State-feedback regulator of the reverse pass: LQR gains along the mirror.

Error dynamics, linearised along the reference (phi', Omega') of the nominal model
(rsp_inertia.plant.model), e = (phi - phi', Omega - Omega'):

    de/dt = A(t) e + B(t) du,   A = [[0, 1], [d eps/d phi, d eps/d Omega]],   B = [0, 1/M(phi')]

discretised at the encoder's sample period (zero-order hold, matrix exponential). Gains
K = [k_phi, k_omega] of the discrete LQR with Q = diag((M w^2)^2, 0), R = 1: for a pure
inertia this puts the closed loop at natural frequency w, damping 1/sqrt 2
(k_phi = M w^2, k_omega = sqrt 2 M w); friction and the angle dependence of M shift it a
little, which the frozen-time LQR accounts for. Computed every ``GAIN_STEP`` seconds and
interpolated (time-varying gains: M changes by ~5% within a turn and by the speed's decay).

The gains are python-control's ``control.dlqr`` (the stable solution X of the discrete
algebraic Riccati equation, K = (R + B'XB)^-1 B'XA), computed for all the points at once:
the Riccati equation by the structure-preserving doubling algorithm on stacks of 2x2
matrices (:func:`_riccati`, ~10 iterations of quadratic convergence), which spares a
``dlqr`` call's Python and LAPACK overhead per point and the import of python-control.
tests/ocp/test_regulator_dlqr.py checks it against ``control.dlqr`` (1e-9 relative).

The bandwidth w: high enough to absorb a nominal model 30% off, low enough that the
encoder's quantization does not make the torque chatter. One count q of angle error moves
the torque by k_phi q, and the drive's speed estimate, which jumps by about c_o q with each
count (c_o = 3 w_o^2 dt for a third-order tracking observer of bandwidth w_o, the virtual
drive's), moves it by k_omega c_o q. With the LQR gains k_phi = M w^2, k_omega = sqrt 2 M w,
keeping that step within one sample's rate limit,

    M q (w^2 + sqrt 2 c_o w) <= torque_rate_limit dt,

gives the largest w (the root of the quadratic), capped at ``MAX_BANDWIDTH``.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import scipy.linalg
from threadpoolctl import threadpool_limits

from rsp_inertia.plant.config import Device
from rsp_inertia.plant.model import MODEL, ModelParameters, reduced_inertia

__all__ = ["GAIN_STEP", "MAX_BANDWIDTH", "OBSERVER_BANDWIDTH", "bandwidth", "lqr_gains"]

MAX_BANDWIDTH = 45.0
"""rad/s: ceiling on the regulator's bandwidth, between a lower one's lag behind a wrong
nominal model and a higher one's encoder jitter (both near or under 1e-3 of the speed at the
nodes of the default stage 1 with the nominal model 30% off in inertia)."""

GAIN_STEP = 0.05
"""s between gain computations (interpolated in between)."""

_DIRECTION = -1.0

_JAC = ca.Function(
    "eps_jacobian",
    [MODEL.phi, MODEL.Omega, MODEL.u, MODEL.direction, MODEL.p],
    [ca.jacobian(MODEL.eps, ca.vertcat(MODEL.phi, MODEL.Omega))],
)


OBSERVER_BANDWIDTH = 100.0
"""rad/s: the drive's speed observer assumed by the bandwidth rule (module docstring); the
virtual drive's (virtual.toml controller.speed_observer_bandwidth). Without the observer's
step a heavy stage's loop chatters on the drive's rate limiter and leaves slow residuals in
the balances that no encoder noise explains; the price of counting it is looser tracking of
a wrong nominal model on the heavy stage, which the balances' mismatch terms absorb."""


def bandwidth(device: Device, M: float) -> float:
    """Regulator bandwidth w, rad/s, for a reduced inertia M (module docstring)."""
    enc = device.encoder
    c_o = 3.0 * OBSERVER_BANDWIDTH**2 * enc.dt
    step = device.motor.torque_rate_limit * enc.dt / (M * enc.quantum)
    b = math.sqrt(2.0) * c_o
    limit = (-b + math.sqrt(b * b + 4.0 * step)) / 2.0
    return min(MAX_BANDWIDTH, limit)


def lqr_gains(
    device: Device,
    t: np.ndarray,
    phi: np.ndarray,
    omega: np.ndarray,
    torque: np.ndarray,
    nominal: ModelParameters,
) -> tuple[np.ndarray, np.ndarray]:
    """Time-varying LQR gains (k_phi, k_omega) at times ``t`` along a reference.

    Parameters
    ----------
    device : Device
        The gimbal: its encoder's sample period and the regulator's bandwidth.
    t, phi, omega, torque : numpy.ndarray
        The reference (s, rad, rad/s) and its feedforward torque (N m), same length.
    nominal : ModelParameters
        The nominal model.

    Returns
    -------
    k_phi, k_omega : arrays like ``t``, N m/rad and N m s/rad.
    """
    dt = device.encoder.dt
    step = max(round(GAIN_STEP / dt), 1)
    idx = np.unique(np.append(np.arange(0, t.size, step), t.size - 1))
    M = reduced_inertia(phi[idx], nominal)
    w = bandwidth(device, float(np.max(M)))
    # Stacks of 2x2 problems: BLAS threads only add overhead, and under load they
    # oversubscribe the cores.
    with threadpool_limits(limits=1):
        K = _gains(device, phi[idx], omega[idx], torque[idx], M, w, nominal.vector)
    return np.interp(t, t[idx], K[:, 0]), np.interp(t, t[idx], K[:, 1])


def _gains(device: Device, phi, omega, torque, M, w: float, p) -> np.ndarray:
    """[k_phi, k_omega] of the frozen-time discrete LQR at each point, shape (n, 2)."""
    dt = device.encoder.dt
    n = len(phi)
    rows = [np.asarray(a, dtype=float).reshape(1, n) for a in (phi, omega, torque)]
    jac = np.asarray(_JAC.map(n)(*rows, _DIRECTION, p)).reshape(n, 2)
    # A = [[0, 1], [d eps/d phi, d eps/d Omega]], B = [0, 1/M]; zero-order-hold
    # discretisation through the augmented matrix exponential, one per point.
    aug = np.zeros((n, 3, 3))
    aug[:, 0, 1] = dt
    aug[:, 1, :2] = jac * dt
    aug[:, 1, 2] = dt / M
    E = scipy.linalg.expm(aug)
    A, B = E[:, :2, :2], E[:, :2, 2:]
    Bt = np.swapaxes(B, 1, 2)
    Q = np.zeros((n, 2, 2))
    Q[:, 0, 0] = (M * w * w) ** 2
    X = _riccati(A, B @ Bt, Q)  # R = 1
    return np.linalg.solve(Bt @ X @ B + 1.0, Bt @ X @ A)[:, 0, :]


RICCATI_TOLERANCE = 1e-15
"""Relative change of X at which the doubling iteration stops (the next step would change
X by about the square of this: the iteration converges quadratically)."""


def _riccati(A: np.ndarray, G: np.ndarray, H: np.ndarray, max_iter: int = 64) -> np.ndarray:
    """Stabilising solutions X of X = A'XA - A'XB (R + B'XB)^-1 B'XA + Q, stacked.

    Structure-preserving doubling (Chu, Fan and Lin 2005) with G = B R^-1 B' and H = Q:
    A_{k+1} = A_k W^-1 A_k, G_{k+1} = G_k + A_k W^-1 G_k A_k', H_{k+1} = H_k + A_k' H_k W^-1 A_k
    with W = I + G_k H_k; H_k converges quadratically to X when (A, B) is stabilisable and
    (Q, A) has no unobservable mode on the unit circle. Arrays of shape (n, m, m).
    """
    eye = np.eye(A.shape[-1])
    for _ in range(max_iter):
        W = eye + G @ H
        WA = np.linalg.solve(W, A)
        At = np.swapaxes(A, 1, 2)
        step = At @ H @ WA
        G = G + A @ np.linalg.solve(W, G) @ At
        A = A @ WA
        H = H + step
        change = np.abs(step).max(axis=(1, 2)) / np.abs(H).max(axis=(1, 2))
        if change.max() <= RICCATI_TOLERANCE:
            return H
    raise ValueError(
        f"LQR: the Riccati iteration did not converge in {max_iter} steps "
        f"(relative change {change.max():.1e})"
    )
