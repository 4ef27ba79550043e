"""Motor work and torque noise of a pass (estimation/passes.py, docs/method.md §3-4)."""

import dataclasses
import math

import numpy as np
import pytest

from rsp_inertia.estimation.passes import CONSTANCY_TAIL, constancy_p_value, estimate_pass
from rsp_inertia.plant.logs import torque_noise
from rsp_inertia.virtual import device as vd
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
    work = est.sample_at(phi).work
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


@pytest.mark.parametrize("stage", STAGES)
def test_braking_work_is_the_mean_torque_times_the_angle(
    stage, default_device, default_virtual, default_brakings
):
    # The braking log is a constant torque plus white noise (docs/method.md §4): the test accepts
    # it, and the work is the log's mean times the angle. Its error against the noise-free
    # work is (u_bar - u)(phi - phi_0), std sigma / sqrt(N) (phi - phi_0): within 5 of those
    # (plus the count that the start reading may lie below the true release angle).
    braking = default_brakings[stage]
    q = default_device.encoder.quantum
    est = estimate_pass(braking.log, q, f"stage{stage}/braking.csv", constant_torque=True)
    assert est.constancy_p >= CONSTANCY_TAIL
    u = -default_device.stages[stage - 1].braking_torque
    n = len(braking.log)
    sigma_mean = default_virtual.run.torque_noise / math.sqrt(n)
    assert est.torque_mean == pytest.approx(u, abs=5 * sigma_mean)

    start = math.radians(default_virtual.run.release_angle_deg)
    phi = np.linspace(start + 0.05, braking.truth.end_phi - 0.05, 501)
    sample = est.sample_at(phi)
    span = phi - est.smoothed.phi[0]
    assert np.all(np.abs(sample.work - u * (phi - start)) <= 5 * sigma_mean * span + abs(u) * q)
    # Its covariance is the mean's error, shared by every angle.
    cov = est.work_covariance(sample)
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), est.sigma_torque / math.sqrt(n) * span)


def test_a_drifting_braking_torque_is_summed_row_by_row(default_device, default_brakings):
    # A braking torque that drifts by half the noise's std over the pass (invisible row by
    # row): chi^2 of the quarter-turn means ~ N (drift^2 / 12) / sigma^2 ~ 300 on ~37 degrees
    # of freedom, so the test rejects the constant model and the work is the Stieltjes sum.
    log = default_brakings[1].log
    drift = 0.5 * torque_noise(log) * np.linspace(-0.5, 0.5, len(log))
    drifting = dataclasses.replace(log, torque=log.torque + drift)
    q = default_device.encoder.quantum
    est = estimate_pass(drifting, q, "stage1/braking.csv", constant_torque=True)
    assert est.constancy_p < CONSTANCY_TAIL
    assert est.torque_mean is None
    rows = estimate_pass(drifting, q, "stage1/braking.csv")
    np.testing.assert_array_equal(est.work, rows.work)


def test_honest_braking_logs_pass_the_constancy_test_at_its_rate(default_device, default_brakings):
    # Under the constant model the p-value is uniform: over 200 fresh noise draws on the same
    # motion, the share below CONSTANCY_TAIL is ~0.1 % (0 or 1 here) and the share below 0.5 is
    # ~ 1/2 (binomial std 3.5 %: within 0.5 +- 0.15).
    log = default_brakings[1].log
    est = estimate_pass(log, default_device.encoder.quantum, "stage1/braking.csv")
    rng = np.random.default_rng(7)
    sigma = 1e-4
    p = np.array([
        constancy_p_value(
            dataclasses.replace(log, torque=np.full(len(log), -0.005) + rng.normal(0, sigma, len(log))),
            est.smoothed.phi,
            sigma,
        )
        for _ in range(200)
    ])
    assert np.sum(p < CONSTANCY_TAIL) <= 2
    assert 0.35 < np.mean(p < 0.5) < 0.65
