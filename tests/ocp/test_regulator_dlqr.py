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


def _residual(a, b, q, x) -> tuple[float, np.ndarray]:
    """Relative residual of the discrete Riccati equation at X = x (R = 1), and its gain."""
    gain = np.linalg.solve(1 + b.T @ x @ b, b.T @ x @ a)
    residual = a.T @ x @ a - a.T @ x @ b @ gain + q - x
    return float(np.abs(residual).max() / np.abs(x).max()), gain


def test_riccati_solves_the_equation_for_a_stack():
    # Random stabilisable 2x2 problems, some far from the regulator's (open loop unstable,
    # weak inputs): each stacked solution satisfies the Riccati equation to 1e-9 and at least
    # as well as python-control's; where dlqr's own solution does too, the gains agree to
    # 1e-6. On ill-conditioned draws (X up to 1e9, cond 1e6) dlqr's solution is the less
    # exact one: scipy 1.17's leaves a residual of 4e-8 where the doubling leaves 3e-10, and
    # the gains then differ by 1.3e-6, which is dlqr's error, not the regulator's.
    rng = np.random.default_rng(1)
    n = 20
    A = np.eye(2) + 0.05 * rng.standard_normal((n, 2, 2))
    B = 0.1 * rng.standard_normal((n, 2, 1))
    Q = np.zeros((n, 2, 2))
    Q[:, 0, 0] = rng.uniform(0.1, 1e4, n)
    Q[:, 1, 1] = rng.uniform(0.0, 1.0, n)
    X = _riccati(A, B @ np.swapaxes(B, 1, 2), Q)
    compared = 0
    for k in range(n):
        a, b = A[k], B[k]
        ours, gain = _residual(a, b, Q[k], X[k])
        K, S, _ = control.dlqr(a, b, Q[k], np.eye(1))
        theirs, _ = _residual(a, b, Q[k], S)
        assert ours <= 1e-9
        assert ours <= max(theirs, 1e-12)
        if theirs <= 1e-9:
            np.testing.assert_allclose(gain, K, rtol=1e-6, atol=0)
            compared += 1
    assert compared >= n - 2  # the comparison is not vacuous
