"""The LQR regulator of the reverse pass (ocp/regulator.py).

For a pure inertia M the continuous design puts the closed loop at natural frequency w and
damping 1/sqrt 2: k_phi = M w^2, k_omega = sqrt 2 M w. The regulator solves the discrete
problem at the sample period (zero-order hold), which moves the gains at first order in w dt.
"""

import math

import numpy as np
import pytest
import scipy.linalg

from rsp_inertia.ocp.regulator import GAIN_STEP, MAX_BANDWIDTH, bandwidth, lqr_gains
from rsp_inertia.plant.model import ModelParameters, acceleration, reduced_inertia
from rsp_inertia.virtual import device as vd
from tests.ocp.conftest import STAGES


@pytest.mark.parametrize("stage", STAGES)
def test_pure_inertia_gains_are_the_continuous_design(
    stage, default_device, default_virtual, programs
):
    # The stage's true mean inertia, alone: no friction, gravity or angle dependence.
    M = vd.true_parameters(default_device, stage, default_virtual).inertia_harmonics[0]
    pure = ModelParameters(inertia_harmonics=[M, 0.0, 0.0, 0.0, 0.0])
    ref = programs[stage].mirror
    k_phi, k_omega = lqr_gains(
        default_device, ref.t, ref.phi, ref.omega, np.zeros_like(ref.t), pure
    )
    w = bandwidth(default_device, M)
    wdt = w * default_device.encoder.dt
    # Discretisation at the sample period shifts the gains at first order in w dt (4.5% at
    # the 45 rad/s ceiling, 1.6% at stage 2's 16 rad/s).
    np.testing.assert_allclose(k_phi, M * w * w, rtol=wdt)
    np.testing.assert_allclose(k_omega, math.sqrt(2) * M * w, rtol=wdt)
    # A pure inertia is the same everywhere: the gains do not vary along the reference.
    assert np.ptp(k_phi) <= 1e-9 * k_phi.max() and np.ptp(k_omega) <= 1e-9 * k_omega.max()


@pytest.mark.parametrize("stage", STAGES)
def test_one_count_moves_the_torque_by_at_most_one_sample_of_rate(stage, default_device, programs):
    # The bandwidth's purpose (ocp/regulator.py): one encoder count of angle error must not
    # change the torque by more than the motor can in one sample, k_phi q <= rate dt, up to
    # the O(w dt) the discrete design moves k_phi by. Stage 1 sits at the 45 rad/s ceiling.
    prog = programs[stage].program
    enc, motor = default_device.encoder, default_device.motor
    M = reduced_inertia(prog.phi_ref, programs[stage].nominal).max()
    w = bandwidth(default_device, M)
    assert w <= MAX_BANDWIDTH
    assert prog.k_phi.max() * enc.quantum <= motor.torque_rate_limit * enc.dt * (1 + w * enc.dt)


def discrete_closed_loop(device, nominal, phi, omega, u, k_phi, k_omega) -> np.ndarray:
    """Ad - Bd K of the error dynamics at one point of the reference (finite differences).

    Linearised independently of the regulator's CasADi Jacobian: central differences of the
    model's acceleration, with steps (1e-6 rad, 1e-6 rad/s) whose truncation error (~1e-12
    relative) and rounding (~1e-10) are far below anything the spectral radius could feel.
    """
    h = 1e-6

    def eps(p, w):
        return float(acceleration(p, w, u, nominal, direction=-1.0))

    d_phi = (eps(phi + h, omega) - eps(phi - h, omega)) / (2 * h)
    d_omega = (eps(phi, omega + h) - eps(phi, omega - h)) / (2 * h)
    M = float(reduced_inertia(phi, nominal))
    dt = device.encoder.dt
    aug = np.zeros((3, 3))
    aug[:2, :2] = np.array([[0.0, 1.0], [d_phi, d_omega]]) * dt
    aug[1, 2] = dt / M
    E = scipy.linalg.expm(aug)  # zero-order hold: [[Ad, Bd], [0, 1]]
    return E[:2, :2] - E[:2, 2:] @ np.array([[k_phi, k_omega]])


@pytest.mark.parametrize("stage", STAGES)
def test_discrete_closed_loop_is_stable_along_the_reference(stage, default_device, programs):
    result = programs[stage]
    prog, nominal = result.program, result.nominal
    dt = default_device.encoder.dt
    # At the gain points and half-way between them (where the gains are interpolated).
    step = max(round(GAIN_STEP / dt / 2), 1)
    M = reduced_inertia(prog.phi_ref, nominal).max()
    w = bandwidth(default_device, M)
    radius = []
    for i in range(0, prog.t.size, step):
        A = discrete_closed_loop(
            default_device,
            nominal,
            prog.phi_ref[i],
            prog.omega_ref[i],
            prog.torque_ff[i],
            prog.k_phi[i],
            prog.k_omega[i],
        )
        radius.append(np.abs(np.linalg.eigvals(A)).max())
    radius = np.array(radius)
    assert np.all(radius < 1.0)
    # Not merely stable: the design decays as exp(-w t / sqrt 2); friction and M(phi) move it
    # a little, but everywhere the loop keeps at least half that decay rate.
    assert radius.max() <= math.exp(-w * dt / (2 * math.sqrt(2)))
