"""The smoother against filterpy's unscented Kalman filter and RTS smoother on the same model.

rsp_inertia.estimation.smoothing runs its own linear Kalman filter (information-form updates
from per-block sums) and RTS pass, because filterpy's UKF cost ~250 us a block (19 of 27 s of
identify at 10 kHz). The model is linear, so the UKF computes the same filter: here filterpy
runs it the way the smoother did before (blocks of readings, the state at each block's
mid-time, each step's own transition and process noise), as an independent computation of
the block states, and both must give the same angle, speed and speed std at every row.
filterpy is a test dependency for this comparison only.
"""

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter, rts_smoother

from rsp_inertia.estimation.smoothing import (
    _process_noise,
    _transition,
    block_length,
    block_starts,
    hermite,
    jerk_density,
    smooth_log,
)
from rsp_inertia.plant.logs import Log

# Rounding: the UKF's sigma points and Cholesky factors lose ~1e-9 of the speed's variance
# over a pass (its steady-state std wanders 2e-8 of itself at 10 kHz, the information form's
# 3e-14); the angle and speed agree to ~1e-12 of their range.
STATE_AGREE = 1e-11
STD_AGREE = 1e-8


def _sqrt(P: np.ndarray) -> np.ndarray:
    """filterpy's sigma points want the upper factor."""
    return np.linalg.cholesky((P + P.T) / 2).T


def _filterpy_reference(log: Log, quantum: float):
    """(phi, omega, omega_std) at every row by filterpy's UKF over blocks and rts_smoother."""
    t = np.asarray(log.t)
    n = t.size
    dt = float(np.median(np.diff(t)))
    q_j, bandwidth = jerk_density(log, quantum)
    block = block_length(bandwidth, dt)
    z_all = log.phi + quantum / 2
    # The blocks as the smoother groups the rows (a dropped sample shortens its block).
    starts = block_starts(t, block, dt)
    stops = np.append(starts[1:], n)
    n_blocks = starts.size
    centres = (t[starts] + t[stops - 1]) / 2
    if stops[-1] - starts[-1] < block:
        centres[-1] = t[starts[-1]] + (block - 1) / 2 * dt
    steps = np.diff(centres)
    variance = quantum * quantum / 12.0

    def hx_for(k: int):
        tau = t[starts[k] : stops[k]] - centres[k]
        H = np.column_stack([np.ones(tau.size), tau, tau**2 / 2])
        return lambda x: H @ x

    points = MerweScaledSigmaPoints(3, alpha=0.5, beta=2.0, kappa=0.0, sqrt_method=_sqrt)
    ukf = UnscentedKalmanFilter(
        dim_x=3, dim_z=block, dt=float(np.median(steps)), hx=hx_for(0),
        fx=lambda x, T: _transition(T) @ x, points=points,
    )
    m = min(3 * block, n)
    tau = t[:m] - centres[0]
    H = np.column_stack([np.ones(m), tau, tau**2 / 2])
    ukf.x = np.linalg.lstsq(H, z_all[:m], rcond=None)[0]
    ukf.P = 100.0 * variance * np.linalg.inv(H.T @ H)
    means, covs = np.empty((n_blocks, 3)), np.empty((n_blocks, 3, 3))
    for k in range(n_blocks):
        z = z_all[starts[k] : stops[k]]
        if k > 0:
            ukf.Q = _process_noise(steps[k - 1], q_j)
            ukf.predict(dt=steps[k - 1])
        ukf.update(z, R=np.eye(len(z)) * variance, hx=hx_for(k))
        ukf.P = (ukf.P + ukf.P.T) / 2
        means[k], covs[k] = ukf.x, ukf.P
    Fs = [_transition(T) for T in steps] + [np.eye(3)]
    Qs = [_process_noise(T, q_j) for T in steps] + [np.zeros((3, 3))]
    xs, ps, _, _ = rts_smoother(means, covs, Fs, Qs)
    k = np.clip(np.searchsorted(centres, t, side="right") - 1, 0, n_blocks - 2)
    inside = (t >= centres[0]) & (t <= centres[-1])
    a, b = xs[k], xs[k + 1]
    phi = hermite(centres[k], centres[k + 1], a[:, 0], a[:, 1], b[:, 0], b[:, 1], t)
    omega = hermite(centres[k], centres[k + 1], a[:, 1], a[:, 2], b[:, 1], b[:, 2], t)
    omega_std = np.sqrt(np.interp(t, centres, ps[:, 1, 1]))
    return phi[inside], omega[inside], omega_std[inside], inside


@pytest.mark.parametrize("jitter", [False, True])
def test_smoother_equals_filterpy_ukf_and_rts(default_brakings, default_device, jitter):
    """The default stage 1's braking (2,000 rows of it; with timing jitter and dropped rows
    too): angle, speed and speed std at every row as filterpy computes them."""
    log = default_brakings[1].log
    rows = slice(0, 2000)
    t, phi = np.asarray(log.t)[rows], np.asarray(log.phi)[rows]
    if jitter:
        rng = np.random.default_rng(7)
        dt = float(t[1] - t[0])
        keep = np.ones(t.size, dtype=bool)
        keep[rng.choice(np.arange(10, t.size - 10), 20, replace=False)] = False
        t = t + rng.uniform(-0.1, 0.1, t.size) * dt
        t[0] = 0.0
        t, phi = t[keep], phi[keep]
    short = Log(t=t, phi=phi, torque=np.asarray(log.torque)[rows][: t.size])
    quantum = default_device.encoder.quantum
    ours = smooth_log(short, quantum)
    phi_ref, omega_ref, std_ref, inside = _filterpy_reference(short, quantum)
    span_phi = np.ptp(phi_ref)
    span_omega = np.ptp(omega_ref) + np.max(np.abs(omega_ref))
    assert np.max(np.abs(ours.phi[inside] - phi_ref)) < STATE_AGREE * span_phi
    assert np.max(np.abs(ours.omega[inside] - omega_ref)) < STATE_AGREE * span_omega
    assert np.max(np.abs(ours.omega_std[inside] / std_ref - 1.0)) < STD_AGREE
