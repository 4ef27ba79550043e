"""The regulator's stacked Riccati solution against python-control's ``dlqr`` (ocp/regulator.py).

python-control defines the gains; the regulator computes the same discrete LQR for all the
points of a reference at once. Both are checked here on the default programs' own
linearisations: at the gain points of each stage, every ``lqr_gains`` value equals
``control.dlqr``'s on the same (A, B, Q, R) to 1e-9 relative.
"""

import numpy as np
import pytest
import scipy.linalg
from rsp_inertia.ocp.regulator import _DIRECTION, _JAC, GAIN_STEP, _riccati, bandwidth, lqr_gains
from rsp_inertia.plant.model import reduced_inertia

from tests.ocp.conftest import STAGES

control = pytest.importorskip("control")

POINTS = 7
"""Gain points checked per stage, spread along the reference (start, end and between)."""


def dlqr_gains(device, nominal, phi, omega, u, M, w) -> np.ndarray:
    """[k_phi, k_omega] from control.dlqr at one point, on the regulator's discretisation."""
    dt = device.encoder.dt
    jac = np.asarray(_JAC(phi, omega, u, _DIRECTION, nominal.vector)).ravel()
    aug = np.zeros((3, 3))
    aug[:2, :2] = np.array([[0.0, 1.0], [jac[0], jac[1]]]) * dt
    aug[1, 2] = dt / M
    E = scipy.linalg.expm(aug)  # zero-order hold: [[Ad, Bd], [0, 1]]
    K, _, _ = control.dlqr(E[:2, :2], E[:2, 2:], np.diag([(M * w * w) ** 2, 0.0]), np.eye(1))
    return K[0]


@pytest.mark.parametrize("stage", STAGES)
def test_gains_are_python_controls_dlqr(stage, default_device, programs):
    result = programs[stage]
    prog, nominal = result.program, result.nominal
    k_phi, k_omega = lqr_gains(
        default_device, prog.t, prog.phi_ref, prog.omega_ref, prog.torque_ff, nominal
    )
    # The gain points (lqr_gains interpolates between them); w from the largest M there.
    step = max(round(GAIN_STEP / default_device.encoder.dt), 1)
    idx = np.unique(np.append(np.arange(0, prog.t.size, step), prog.t.size - 1))
    M = reduced_inertia(prog.phi_ref[idx], nominal)
    w = bandwidth(default_device, float(M.max()))
    for j in np.unique(np.linspace(0, idx.size - 1, POINTS).round().astype(int)):
        i = idx[j]
        expected = dlqr_gains(
            default_device, nominal, prog.phi_ref[i], prog.omega_ref[i], prog.torque_ff[i], M[j], w
        )
        np.testing.assert_allclose([k_phi[i], k_omega[i]], expected, rtol=1e-9, atol=0)


def test_riccati_solves_the_equation_for_a_stack():
    # Random stabilisable 2x2 problems, some far from the regulator's (open loop unstable,
    # weak inputs): each stacked solution satisfies the Riccati equation and gives dlqr's
    # gains. Where the draw is ill-conditioned (X up to 1e9) the two differ by up to ~2e-7,
    # with the doubling's residual the smaller (25x smaller than scipy's on the worst draw):
    # hence the looser tolerance here than on the regulator's own problems above.
    rng = np.random.default_rng(1)
    n = 20
    A = np.eye(2) + 0.05 * rng.standard_normal((n, 2, 2))
    B = 0.1 * rng.standard_normal((n, 2, 1))
    Q = np.zeros((n, 2, 2))
    Q[:, 0, 0] = rng.uniform(0.1, 1e4, n)
    Q[:, 1, 1] = rng.uniform(0.0, 1.0, n)
    X = _riccati(A, B @ np.swapaxes(B, 1, 2), Q)
    for k in range(n):
        a, b, x = A[k], B[k], X[k]
        gain = np.linalg.solve(1 + b.T @ x @ b, b.T @ x @ a)
        residual = a.T @ x @ a - a.T @ x @ b @ gain + Q[k] - x
        assert np.abs(residual).max() <= 1e-9 * np.abs(x).max()
        K, _, _ = control.dlqr(a, b, Q[k], np.eye(1))
        np.testing.assert_allclose(gain, K, rtol=1e-6, atol=0)
