"""Coarse encoders: the quantization lines, the motor work's angle term, the nominal model.

Physics checked against the virtual device's truth and against closed forms:

- the smoothed angle's white-noise error variance has g_phi(0) = 5/18 in closed form;
- averaged over the speed (v > 1/2 count per sample) the quantization lines' variances are
  the white ones (the aliased harmonics fill the band evenly), and at a given speed they
  follow what a 10- and a 12-bit encoder actually leave in the smoothed speed, where the
  white value is off by up to 10x;
- the work's error from the smoothed angle under a torque that changes every sample has the
  variance :func:`angle_work_variance` says where the readings' errors are white, and less
  below a count per sample (Monte Carlo over reading offsets);
- the program's nominal model of a 10- and a 12-bit braking keeps the inertia's scale (the
  energy-window fit lost 36-90% of it).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from rsp_inertia.estimation.passes import angle_work_variance
from rsp_inertia.estimation.smoothing import (
    angle_error_autocovariance,
    noise_density,
    quantization_error_variance,
    smooth_log,
    speed_error_autocovariance,
)
from rsp_inertia.ocp.nominal import fit_nominal
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.logs import Log
from rsp_inertia.plant.transducers import encoder_reading
from rsp_inertia.virtual import device as vd


def test_angle_error_kernel_has_its_closed_form():
    # int_0^inf dx / (1 + x^6)^2 = 5 pi / 18, so g_phi(0) = 5/18.
    r, w_c = 3.0e-12, 200.0
    assert angle_error_autocovariance(0.0, w_c, r) == pytest.approx(r * w_c * 5 / 18, rel=1e-6)


@pytest.mark.parametrize("bits", [10, 14])
def test_quantization_lines_average_to_the_white_values(bits):
    q, dt, w_c = 2 * math.pi / 2**bits, 1e-3, 240.0
    r = noise_density(q, dt)
    v = np.linspace(0.5, 3.0, 50_001)  # counts per sample
    angle, speed = quantization_error_variance(v * q / dt, q, dt, w_c)
    assert np.mean(speed) == pytest.approx(speed_error_autocovariance(0.0, w_c, r), rel=3e-3)
    assert np.mean(angle) == pytest.approx(angle_error_autocovariance(0.0, w_c, r), rel=3e-3)
    # Below half a count per sample the low harmonics alias above the band: less error.
    slow = quantization_error_variance(np.linspace(0.1, 0.4, 2001) * q / dt, q, dt, w_c)[1]
    assert np.mean(slow) < 0.6 * speed_error_autocovariance(0.0, w_c, r)


@pytest.fixture(scope="module")
def coarse_brakings(default_device, default_virtual):
    """The default stages' brakings read by a 10-bit and a 12-bit encoder (seed 1)."""
    out = {}
    for bits in (10, 12):
        device = replace(
            default_device, encoder=replace(default_device.encoder, counts_per_rev=2**bits)
        )
        virtual = replace(default_virtual, run=replace(default_virtual.run, seed=1))
        for stage in (1, 2):
            braking = vd.simulate_braking(device, stage, virtual, Direction.FORWARD)
            out[bits, stage] = (device, virtual, braking, smooth_log(braking.log, device.encoder.quantum))
    return out


@pytest.mark.parametrize("bits", [10, 12])
@pytest.mark.parametrize("stage", [1, 2])
def test_quantization_lines_follow_the_smoothed_speeds_error(bits, stage, coarse_brakings):
    # Over the middle of the pass (10-90%), in thirds: the actual mean square error of the
    # smoothed speed against the line model's mean at the true speeds. Measured ratios
    # 0.8-1.3, and 2.1 on the 12-bit stage 2's middle third, which brakes through one count
    # per sample (every harmonic aliases near 0 there: the lines' resonance is sharpest); the
    # white value is off by 0.1-0.5x on the 10-bit stage 2.
    device, _, braking, sm = coarse_brakings[bits, stage]
    err = sm.omega - braking.truth.omega
    n = err.size
    q, dt = device.encoder.quantum, device.encoder.dt
    for lo, hi in ((0.1, 0.37), (0.37, 0.63), (0.63, 0.9)):
        part = slice(int(lo * n), int(hi * n))
        lines = quantization_error_variance(braking.truth.omega[part][::10], q, dt, sm.bandwidth)[1]
        ratio = np.mean(err[part] ** 2) / np.mean(lines)
        assert 0.5 < ratio < 2.5, (lo, ratio)


def _work_errors(speed: float, draws: int = 40):
    """The angle term's actual and predicted variances over reading offsets and speeds near
    ``speed`` (rad/s) on a 12-bit encoder, one torque that jumps at random every sample
    (independent of the readings). Between two interior rows the work over the smoothed
    angles, evaluated at the smoothed angle as the balances do, misses -sum e^_k du_k."""
    rng = np.random.default_rng(7)
    q, dt, n = 2 * math.pi / 4096, 1e-3, 4000
    t = np.arange(n) * dt
    torque = 0.05 + 0.01 * rng.standard_normal(n)
    a, b = 500, n - 500
    errors, predicted = [], []
    for _ in range(draws):
        offset, omega = rng.uniform(0, q), speed * rng.uniform(0.9, 1.1)
        phi = offset + omega * t + 0.2 * speed * np.sin(1.3 * t)
        sm = smooth_log(Log(t=t, phi=encoder_reading(phi, q), torque=torque), q)
        e = sm.phi - phi
        errors.append(-np.sum(e[a + 1 : b] * np.diff(torque)[a : b - 1]))
        v = angle_work_variance(torque, sm)
        predicted.append(v[b] - v[a])
    return float(np.var(errors)), float(np.mean(predicted))


def test_angle_work_variance_matches_a_monte_carlo_of_reading_offsets():
    # Several counts per sample (the readings' errors white): the variance as predicted,
    # within the Monte Carlo's scatter (40 draws: +-25%) and the model's 20%. Measured 0.81.
    actual, predicted = _work_errors(speed=8.0)
    assert 0.6 < actual / predicted < 1.6
    # Below a count per sample the angle error is a few aliased lines, whose low frequencies
    # carry less power than the white kernel's (the level is the lines', but not the shape):
    # the prediction errs high. Measured 0.65 at 0.6 counts per sample.
    actual, predicted = _work_errors(speed=0.9)
    assert 0.15 < actual / predicted < 1.2


@pytest.mark.parametrize("bits", [10, 12])
def test_nominal_model_keeps_the_inertia_scale_on_a_coarse_braking(bits, coarse_brakings):
    # Energy windows with the speeds at their ends lost the scale on coarse logs (errors in
    # variables: M0 62-67% low at 12 bits, 85-90% at 10; corrected, still 36-70% low on the
    # 10-bit stage 1). The modulated fit (rsp_inertia.estimation.modulated) keeps it: M0
    # within 1% of the truth scaled by the Coulomb degeneracy u_b / (u_b + a1), the scale a
    # braking determines (measured: 0.27% and 0.06% at 10 bits, 0.05% and 0.03% at 12).
    for stage in (1, 2):
        device, virtual, braking, sm = coarse_brakings[bits, stage]
        fit = fit_nominal(device, stage, braking.log, sm)
        true = vd.true_parameters(device, stage, virtual, 1.0)
        u_b = device.stages[stage - 1].braking_torque
        k = u_b / (u_b + virtual.friction.coulomb)
        M0, M0_true = fit.inertia_harmonics[0], k * true.inertia_harmonics[0]
        assert abs(M0 / M0_true - 1) < 0.01, (stage, M0 / M0_true - 1)


def test_a_run_under_one_count_per_sample_gets_the_coarse_encoder_warning():
    # Omega^2 ~ S / 2 at each balance angle: a run at 0.5 counts per sample (median) is
    # warned, one at 2 counts per sample is not.
    from types import SimpleNamespace

    from rsp_inertia.estimation.model_tests import coarse_encoder_warnings

    q, dt = 2 * math.pi / 1024, 1e-3
    def run(counts):
        speed = counts * q / dt * np.linspace(0.8, 1.2, 101)
        return SimpleNamespace(speed_sq=2 * speed**2)

    found = coarse_encoder_warnings([run(0.5), run(2.0)], q, dt, ["stage 1 forward", "stage 2 forward"])
    assert len(found) == 1
    assert found[0].startswith("stage 1 forward: the encoder reads 0.5 counts per sample")
