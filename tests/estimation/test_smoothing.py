"""The UKF + RTS smoother (estimation/smoothing.py) against the virtual device's true speed.

Noise model behind the bounds. The encoder reading's error, after the smoother restores the
half count, is uniform over one count q: variance q^2/12 per sample, spectral density
r = (q^2/12) dt when the body moves many counts per sample (white). In steady state the RTS
smoother of the triple integrator is the two-sided Wiener filter H(w) = 1 / (1 + (w/w_c)^6),
w_c = (q_j / r)^(1/6). Its speed error has two parts:

- reading noise through the filter: (1/2 pi) int r w^2 |H|^2 dw = r w_c^3 / 12
  (substitute v = (w/w_c)^3: int_0^inf dv / (1 + v^2)^2 = pi/4);
- the lag on the motion, which for the model's own white-jerk motion adds as much again, so the
  model's error variance (what the smoother's covariance reports) is
  (1/2 pi) int r w^2 H dw = r w_c^3 / 6 (int_0^inf u^2 / (1 + u^6) du = pi/6).

The virtual body's motion is far smoother than white jerk of density q_j (that q_j is set for
the highest harmonic to pass, smoothing.py), so the actual error lies between the two:
RMS^2 in [r w_c^3 / 12, r w_c^3 / 6].
"""

import math

import numpy as np
import pytest
from scipy.integrate import trapezoid

from rsp_inertia.estimation.smoothing import (
    BANDWIDTH_FACTOR,
    _speed_kernel,
    smooth_log,
    speed_error_autocovariance,
)
from rsp_inertia.plant.logs import Log
from tests.estimation.conftest import STAGES


@pytest.fixture(scope="module")
def smoothed(default_device, default_brakings):
    """Each default stage's braking log, smoothed once for the module (~1 s for both)."""
    q = default_device.encoder.quantum
    return {s: smooth_log(default_brakings[s].log, q, f"stage{s}/braking.csv") for s in STAGES}


def reading_noise_density(device) -> float:
    """r = (q^2/12) dt, rad^2 s: the quantization's spectral density (module docstring)."""
    q = device.encoder.quantum
    return q * q / 12.0 * device.encoder.dt


def speed_error(smoothed, braking) -> np.ndarray:
    return smoothed.omega - braking.truth.omega


@pytest.mark.parametrize("stage", STAGES)
def test_bandwidth_follows_from_the_jerk_density_and_the_top_speed(
    stage, default_device, default_brakings, smoothed
):
    sm = smoothed[stage]
    r = reading_noise_density(default_device)
    assert (sm.jerk_density / r) ** (1 / 6) == pytest.approx(sm.bandwidth, rel=1e-12)
    # w_c = 2 BANDWIDTH_FACTOR Omega_max; the top speed is the launch speed. The smoother reads
    # it from readings BLOCK samples apart, so the speed lost over those 10 ms (under 0.5 %
    # here) and one count over the span are the tolerance: 1 %.
    launch = default_device.stages[stage - 1].launch_speed
    assert sm.bandwidth == pytest.approx(2 * BANDWIDTH_FACTOR * launch, rel=0.01)


@pytest.mark.parametrize("stage", STAGES)
def test_speed_error_has_no_bias(stage, default_device, default_brakings, smoothed):
    braking = default_brakings[stage]
    err = speed_error(smoothed[stage], braking)
    rms = np.sqrt(np.mean(err**2))
    # The smoother is linear and the restored reading error has zero mean, so the mean speed
    # error is the angle error's change over the pass divided by its duration:
    # mean(Omega^ - Omega) ~ [(phi^ - phi)(T) - (phi^ - phi)(0)] / T, at most 2 q / T with the
    # smoothed angle within a count of the truth at both ends.
    q = default_device.encoder.quantum
    duration = braking.truth.t[-1]
    assert abs(err.mean()) <= 2 * q / duration
    assert abs(err.mean()) < 0.05 * rms


@pytest.mark.parametrize("stage", STAGES)
def test_smoothed_angle_beats_the_raw_reading(stage, default_device, default_brakings, smoothed):
    braking = default_brakings[stage]
    q = default_device.encoder.quantum
    raw = braking.log.phi + q / 2 - braking.truth.phi
    smooth = smoothed[stage].phi - braking.truth.phi
    # The raw reading's error is uniform over one count (RMS q / sqrt 12); the smoother
    # averages w_c^-1 / dt ~ 10-20 readings, so it must do clearly better than one reading.
    assert np.sqrt(np.mean(raw**2)) == pytest.approx(q / math.sqrt(12), rel=0.02)
    assert np.sqrt(np.mean(smooth**2)) < 0.5 * q / math.sqrt(12)


@pytest.mark.parametrize("stage", STAGES)
def test_speed_error_respects_the_wiener_bound(stage, default_device, default_brakings, smoothed):
    sm = smoothed[stage]
    rms = np.sqrt(np.mean(speed_error(sm, default_brakings[stage]) ** 2))
    r = reading_noise_density(default_device)
    model_rms = math.sqrt(r * sm.bandwidth**3 / 6)  # module docstring: the model's error
    # Factor 2 over the model's RMS: the quantization is not exactly white (it is a
    # deterministic function of the angle) and the filter's start-up transient is included.
    bound = 2 * model_rms
    assert rms <= bound
    # Not vacuous: the bound is within a factor 10 of what the smoother really achieves.
    assert bound < 10 * rms


@pytest.mark.parametrize("stage", STAGES)
def test_reported_speed_std_is_honest(stage, default_brakings, smoothed):
    sm = smoothed[stage]
    rms = np.sqrt(np.mean(speed_error(sm, default_brakings[stage]) ** 2))
    reported = np.sqrt(np.mean(sm.omega_std**2))
    # The covariance is the model's r w_c^3 / 6, the actual error nearer r w_c^3 / 12 (module
    # docstring): reported / actual ~ sqrt 2, so a factor 2 either way is the honest band.
    assert 0.5 * rms < reported < 2 * rms


def test_a_long_log_is_smoothed_at_every_row(default_device):
    # 25,000 rows (25 s at 1 kHz): a uniform deceleration from 3 rad/s to rest, read by the
    # default encoder. The default passes may be shorter, so the log is built here.
    enc = default_device.encoder
    q = enc.quantum
    n = 25_000
    t = np.arange(n) * enc.dt
    duration = n * enc.dt
    top = 3.0
    angle = 0.3 + top * (t - t**2 / (2 * duration))
    log = Log(t=t, phi=np.floor(angle / q) * q, torque=np.full(n, -0.01))
    sm = smooth_log(log, q, "long.csv")
    for name in ("t", "phi", "omega", "eps", "omega_std"):
        values = getattr(sm, name)
        assert values.shape == (n,), name
        assert np.all(np.isfinite(values)), name
    np.testing.assert_array_equal(sm.t, log.t)
    assert np.all(sm.omega_std > 0)
    # And the speed is right: the same Wiener bound as on the virtual device's passes.
    rms = np.sqrt(np.mean((sm.omega - top * (1 - t / duration)) ** 2))
    assert rms <= 2 * math.sqrt(reading_noise_density(default_device) * sm.bandwidth**3 / 6)


def test_speed_error_kernel_has_the_derived_variance_and_no_mean():
    # g(0) = 1/12 in closed form (module docstring); the speed error is the derivative of the
    # angle's error, so its spectrum vanishes at w = 0: int_0^inf g(s) ds = f(0) / 2 = 0.
    s, g = _speed_kernel()
    assert g[0] == pytest.approx(1 / 12, rel=1e-6)
    assert abs(trapezoid(g, s)) < 1e-6 * g[0] * s[-1]
    r, w_c = 2.0e-12, 300.0
    assert speed_error_autocovariance(0.0, w_c, r) == pytest.approx(r * w_c**3 / 12, rel=1e-6)


@pytest.mark.parametrize("stage", STAGES)
def test_speed_error_autocovariance_matches_the_virtual_device(
    stage, default_device, default_brakings, smoothed
):
    sm = smoothed[stage]
    err = speed_error(sm, default_brakings[stage])[300:-300]  # steady state, away from the ends
    derived = speed_error_autocovariance(0.0, sm.bandwidth, sm.noise_density)
    # Shape. The error is correlated over ~10-40 rows (R changes sign at w_c tau ~ 2.5,
    # w_c ~ 70-240 rad/s), so n rows hold at least n/40 independent values and a sample
    # correlation scatters by at most 1/sqrt(n/40) ~ 0.05 for n > 10^4: 0.12 is 2.4 of those.
    assert len(err) > 10_000
    dt = default_device.encoder.dt
    for lag in (3, 5, 10, 15, 20, 30, 50):
        measured = np.mean(err[:-lag] * err[lag:]) / np.var(err)
        model = speed_error_autocovariance(lag * dt, sm.bandwidth, sm.noise_density) / derived
        assert measured == pytest.approx(model, abs=0.12), lag
    # Level. Measured: 0.75-1.05 of r w_c^3 / 12 on stage 1, 0.55-0.7 on stage 2 at 5-50
    # counts per sample (the block filter's Hermite interpolation smooths a little more when
    # w_c T_block approaches 1, and the quantization is not exactly white), 1.2-1.7 below
    # 4 counts per sample. The least squares calibrates the level on its residuals
    # (rsp_inertia.estimation.tensor), so the derived value need only be right within a factor 2.
    assert 0.5 * derived < np.var(err) < 2 * derived
