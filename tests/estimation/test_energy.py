"""Motor work and torque noise of a pass (estimation/energy.py, METHOD.md §3-4)."""

import dataclasses
import math

import numpy as np
import pytest

from estimation.energy import estimate_pass, sample_at, torque_noise
from plant import virtual as vd
from tests.estimation.conftest import STAGES


@pytest.mark.parametrize("stage", STAGES)
def test_constant_torque_does_torque_times_angle(stage, default_device, default_virtual):
    # A braking pass logged without torque noise: the motor holds u = -braking_torque.
    quiet = dataclasses.replace(
        default_virtual, run=dataclasses.replace(default_virtual.run, torque_noise=0.0)
    )
    braking = vd.simulate_braking(default_device, stage, quiet)
    q = default_device.encoder.quantum
    est = estimate_pass(braking.log, q, f"stage{stage}/braking.csv")
    u = -default_device.stages[stage - 1].braking_torque
    np.testing.assert_array_equal(braking.log.torque, u)
    assert est.sigma_torque == 0.0

    start = math.radians(default_virtual.run.release_angle_deg)
    end = braking.truth.end_phi
    phi = np.linspace(start + 0.05, end - 0.05, 997)  # angles between rows, whole pass
    work = sample_at(est, phi).work
    # W = u (phi - phi_start): the Stieltjes sum telescopes to u (phi - y_0), y_0 the first
    # reading, which lies within one count below the true release angle.
    assert np.all(np.abs(work - u * (phi - start)) <= abs(u) * q)


@pytest.mark.parametrize("stage", STAGES)
def test_torque_noise_is_read_from_the_log(stage, default_virtual, default_brakings):
    log = default_brakings[stage].log
    # The MAD of the sample-to-sample changes has a relative scatter of about
    # 1 / sqrt(0.37 * 2 n) (its Gaussian efficiency is 0.37) ~ 1 % for n > 10^4 rows:
    # 5 % is four of those.
    assert len(log) > 10_000
    assert torque_noise(log) == pytest.approx(default_virtual.run.torque_noise, rel=0.05)
