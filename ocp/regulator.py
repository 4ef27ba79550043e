"""State-feedback regulator of the reverse pass: LQR gains along the mirror (python-control).

Error dynamics, linearised along the reference (phi', Omega') of the nominal model
(plant.model), e = (phi - phi', Omega - Omega'):

    de/dt = A(t) e + B(t) du,   A = [[0, 1], [d eps/d phi, d eps/d Omega]],   B = [0, 1/M(phi')]

discretised at the encoder's sample period (zero-order hold, matrix exponential). Gains
K = [k_phi, k_omega] from ``control.dlqr`` with Q = diag((M w^2)^2, 0), R = 1: for a pure
inertia this puts the closed loop at natural frequency w, damping 1/sqrt 2
(k_phi = M w^2, k_omega = sqrt 2 M w); friction and the angle dependence of M shift it a
little, which the frozen-time LQR accounts for. Computed every ``GAIN_STEP`` seconds and
interpolated (time-varying gains: M changes by ~5% within a turn and by the speed's decay).

The bandwidth w: high enough to absorb a nominal model 30% off, low enough that the
encoder's quantization does not make the torque chatter. One count q of angle error moves
the torque by k_phi q; keeping that within one sample's rate limit (torque_rate_limit dt)
gives w <= sqrt(torque_rate_limit dt / (M q)), capped at ``MAX_BANDWIDTH``.
"""

from __future__ import annotations

import math

import casadi as ca
import control
import numpy as np
import scipy.linalg
from threadpoolctl import threadpool_limits

from plant.config import Device
from plant.model import MODEL, ModelParameters, reduced_inertia

__all__ = ["GAIN_STEP", "MAX_BANDWIDTH", "bandwidth", "lqr_gains"]

MAX_BANDWIDTH = 45.0
"""rad/s: ceiling on the regulator's bandwidth. Measured on the default stage 1 with the
nominal model 30% off in inertia: 30 rad/s left a systematic lag of ~9e-4 of the speed at
the nodes, 60 rad/s let the encoder's jitter through (peaks of 2e-3); 45 keeps both near
or under 1e-3."""

GAIN_STEP = 0.05
"""s between gain computations (interpolated in between)."""

_DIRECTION = -1.0

_JAC = ca.Function(
    "eps_jacobian",
    [MODEL.phi, MODEL.Omega, MODEL.u, MODEL.direction, MODEL.p],
    [ca.jacobian(MODEL.eps, ca.vertcat(MODEL.phi, MODEL.Omega))],
)


def bandwidth(device: Device, M: float) -> float:
    """Regulator bandwidth w, rad/s, for a reduced inertia M (module docstring)."""
    enc = device.encoder
    limit = math.sqrt(device.motor.torque_rate_limit * enc.dt / (M * enc.quantum))
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
    t, phi, omega, torque : arrays
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
    p = nominal.vector
    # 2x2 problems: BLAS threads only add overhead, and under load they oversubscribe the
    # cores (measured: 24 ms per dlqr call with two other busy processes, 30x the idle time).
    with threadpool_limits(limits=1):
        K_all = [_gain(device, phi[i], omega[i], torque[i], M[j], w, p) for j, i in enumerate(idx)]
    k_phi, k_omega = np.array(K_all).T
    return np.interp(t, t[idx], k_phi), np.interp(t, t[idx], k_omega)


def _gain(device: Device, phi: float, omega: float, torque: float, M: float, w: float, p):
    """[k_phi, k_omega] of the frozen-time discrete LQR at one point of the reference."""
    dt = device.encoder.dt
    jac = np.asarray(_JAC(phi, omega, torque, _DIRECTION, p)).ravel()
    A = np.array([[0.0, 1.0], [jac[0], jac[1]]])
    B = np.array([[0.0], [1.0 / M]])
    # Zero-order-hold discretisation through the augmented matrix exponential.
    aug = np.zeros((3, 3))
    aug[:2, :2], aug[:2, 2:] = A * dt, B * dt
    E = scipy.linalg.expm(aug)
    Q = np.diag([(M * w * w) ** 2, 0.0])
    K, _, _ = control.dlqr(E[:2, :2], E[:2, 2:], Q, np.eye(1))
    return K[0, 0], K[0, 1]

