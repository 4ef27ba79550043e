"""The Kalman + RTS smoother (estimation/smoothing.py) against the virtual device's true speed.

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

import functools
import math

import numpy as np
import pytest
from scipy.integrate import trapezoid

from rsp_inertia.estimation.smoothing import (
    BANDWIDTH_FACTOR,
    _block_readings,
    _kalman_filter,
    _process_noise,
    _rts_smoother,
    _speed_kernel,
    _transition,
    smooth_log,
    speed_error_autocovariance,
)
from rsp_inertia.infra.progress import reporting
from rsp_inertia.plant.logs import Log
from tests.estimation.conftest import STAGES
from tests.infra.test_progress import Recorder


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
    # (rsp_inertia.estimation.tensor_fit), so the derived value need only be right within a factor 2.
    assert 0.5 * derived < np.var(err) < 2 * derived


def test_the_kalman_smoother_solves_the_least_squares_of_its_model():
    # The RTS smoother of a linear model is the solution of the least squares over all its
    # states at once (prior, process noise and readings), and its covariance that problem's
    # inverse normal matrix. Checked here on a short jittered log in 50 blocks, against the
    # dense normal equations: the filter's information-form update and the rearranged RTS
    # recursion (smoothing.py) against the definition.
    rng = np.random.default_rng(1)
    q = 2 * math.pi / 2**16
    rows, block, dt = 300, 6, 1e-3
    t = (np.arange(rows) + rng.uniform(-0.2, 0.2, rows)) * dt
    z = np.floor((0.3 + 5 * t - 2 * t**2) / q) * q + q / 2
    centres = (t[::block] + t[block - 1 :: block]) / 2
    steps = np.diff(centres)
    n = centres.size
    q_j = q * q / 12 * dt * 200.0**6  # w_c = 200 rad/s
    F = np.stack([_transition(T) for T in steps])
    Q = [_process_noise(T, q_j) for T in steps]
    x0, P0 = np.array([z[0], 5.0, -4.0]), np.diag([q * q, 1.0, 100.0])
    starts = np.arange(n) * block
    readings = functools.partial(_block_readings, t, z, centres, starts, block, q * q / 12)
    which = np.arange(n - 1)  # every step its own transition
    means, covs, predicted = _kalman_filter(x0, P0, F, Q, which, readings, "smoothing")
    xs, speed_var = _rts_smoother(means, covs, predicted, F, which)

    A, b, reference = readings(slice(0, n))
    N = np.zeros((3 * n, 3 * n))
    rhs = np.zeros(3 * n)
    N[:3, :3] = np.linalg.inv(P0)
    rhs[:3] = N[:3, :3] @ x0
    for k in range(1, n):  # block 0's readings are in the start (x0, P0)
        i, j = slice(3 * k - 3, 3 * k), slice(3 * k, 3 * k + 3)
        W = np.linalg.inv(Q[k - 1])
        N[j, j] += W + A[k]
        N[i, i] += F[k - 1].T @ W @ F[k - 1]
        N[i, j] -= F[k - 1].T @ W
        N[j, i] -= W @ F[k - 1]
        rhs[j] += b[k] + A[k][:, 0] * reference[k]
    # The correction that the normal equations ask of the smoother's states, solved scaled to
    # (rad, rad/s x 1 ms, rad/s^2 x 1 ms^2) (the raw normal matrix spans 20 orders): zero to
    # the rounding of the residual, 1e-16 of the readings' information (~1e-16 x 1e10 x 0.4
    # rad per rad) through the inverse, a fraction of 1e-6 of a count here.
    D = np.tile([1.0, dt, dt * dt], n)
    scaled = np.linalg.inv(N * D[:, None] * D[None, :])
    correction = D * (scaled @ (D * (rhs - N @ xs.reshape(-1))))
    assert np.abs(correction[0::3]).max() < 1e-6 * q
    assert np.abs(correction[1::3]).max() < 1e-6 * q / (block * dt)
    # The covariance: the inverse normal matrix's speed entries, to its condition (~1e8
    # scaled) times the rounding.
    np.testing.assert_allclose(speed_var, (D * D * np.diag(scaled))[1::3], rtol=1e-8)


def test_smoothing_reports_its_progress(default_device, default_brakings):
    recorder = Recorder()
    with reporting(recorder):
        smooth_log(default_brakings[1].log, default_device.encoder.quantum, "braking.csv")
    seen = recorder.fractions
    assert {task for task, _ in seen} == {"braking.csv: smoothing"}
    assert seen[0][1] == 0.0 and seen[-1][1] == 1.0
