"""The virtual device (docs/method.md §3-4, docs/files.md logs): the integrator conserves
energy, its braking agrees with an independent integration, the logs are what a rig writes,
static friction holds, the ideal reverse is the mirror, the drive keeps its limits."""

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.logs import Program, read_log, write_log
from rsp_inertia.plant.model import (
    acceleration,
    mechanical_energy,
    reduced_inertia,
    static_torque,
)
from rsp_inertia.plant.transducers import encoder_reading
from rsp_inertia.virtual import device as vd
from rsp_inertia.virtual.integrate import BLOCK, advance, step_block

STAGES = (1, 2)


@pytest.fixture(scope="module")
def brakings(default_device, default_virtual):
    """The braking pass of each default stage, simulated once for the module (~0.4 s)."""
    return {s: vd.simulate_braking(default_device, s, default_virtual) for s in STAGES}


@pytest.fixture(scope="module")
def reverses(default_device, default_virtual, brakings):
    """The ideal reverse of each default stage (~4 s for both)."""
    return {
        s: vd.simulate_ideal_reverse(default_device, s, default_virtual, brakings[s])
        for s in STAGES
    }


def release_state(device, stage, virtual) -> np.ndarray:
    return np.array(
        [math.radians(virtual.run.release_angle_deg), device.stages[stage - 1].launch_speed]
    )


def braking_speed_at(braking, phi):
    """Braking speed at angles phi, from the truth, by a cubic spline of Omega^2 over phi.

    Omega^2 (twice the kinetic energy over M) is smooth in phi right down to the rest, where
    Omega itself has a square-root corner; the spline's error, of order dphi^4 with
    dphi <= 6e-3 rad per sample, is below 1e-9 rad/s.
    """
    truth = braking.truth
    phi_k, omega_k = truth.phi, truth.omega
    if truth.end_time > truth.t[-1]:
        phi_k, omega_k = np.append(phi_k, truth.end_phi), np.append(omega_k, 0.0)
    return np.sqrt(np.maximum(CubicSpline(phi_k, omega_k**2)(phi), 0.0))


# --- 1. the integrator conserves energy ----------------------------------------------------


@pytest.mark.parametrize("stage", STAGES)
def test_integrator_conserves_energy_without_dissipation(default_device, default_virtual, stage):
    # No friction, no torque, no spring: only M(phi) and gravity exchange energy with the
    # speed, which swings by the inertia harmonics and m g r_c every turn.
    params = dataclasses.replace(
        vd.true_parameters(default_device, stage, default_virtual),
        stiffness=0.0,
        coulomb=0.0,
        viscous=0.0,
        quadratic=0.0,
    )
    dt = default_device.encoder.dt
    x = release_state(default_device, stage, default_virtual)
    E0 = mechanical_energy(x[0], x[1], params)
    blocks = []
    for _ in range(round(10.0 / (dt * BLOCK))):  # 10 s
        block = step_block(x, 0.0, 1.0, params.vector, dt)
        blocks.append(block)
        x = block[-1]
    trajectory = np.concatenate(blocks)
    assert trajectory[-1, 0] - trajectory[0, 0] > 3 * 2 * math.pi  # turns of swings in M, Pi
    drift = np.abs(mechanical_energy(trajectory[:, 0], trajectory[:, 1], params) / E0 - 1.0)
    # The bound virtual/integrate.py's docstring states: 1e-9 relative over 10 s. RK4 at
    # h = dt/8 loses ~(h Omega)^4 ~ 1e-13 per unit time at these speeds.
    assert drift.max() < 1e-9


# --- 2. an independent integration of the 3-D model ---------------------------------------


def independent_braking(device, stage, virtual):
    """The braking pass from docs/method.md §2-3 in plain numpy, integrated by DOP853.

    M = w^T J w + M_tare and M' = 2 w^T J w' with w = (lam sin phi, lam cos phi, 1); gravity
    m g (x_c cos phi - y_c sin phi); friction (a1 + a3 W^2) sign W + a2 W; braking torque
    constant against the motion. Stops at the first Omega = 0.
    """
    st = device.stages[stage - 1]
    lam, tare, braking = st.gear_ratio, st.tare_inertia, st.braking_torque
    J = virtual.body.tensor
    mg = virtual.body.mass * device.gravity
    xc, yc, _ = virtual.body.com
    a1, a2, a3 = virtual.friction.coulomb, virtual.friction.viscous, virtual.friction.quadratic

    def rhs(t, y):
        phi, W = y
        s, c = math.sin(phi), math.cos(phi)
        w = np.array([lam * s, lam * c, 1.0])
        dw = np.array([lam * c, -lam * s, 0.0])
        M = w @ J @ w + tare
        dM = 2.0 * w @ J @ dw
        direction = math.copysign(1.0, W)
        gravity = mg * (xc * c - yc * s)
        friction = (a1 + a3 * W * W) * direction + a2 * W
        return [W, (-braking * direction - friction - gravity - 0.5 * dM * W * W) / M]

    def stop(t, y):
        return y[1]

    stop.terminal = True
    stop.direction = -1
    sol = solve_ivp(
        rhs,
        (0.0, vd.MAX_BRAKING_TIME),
        release_state(device, stage, virtual),
        method="DOP853",
        rtol=1e-12,
        atol=1e-12,
        dense_output=True,
        events=stop,
    )
    assert sol.status == 1  # stopped on the event
    return sol


@pytest.mark.parametrize("stage", STAGES)
def test_braking_agrees_with_an_independent_integration(
    default_device, default_virtual, brakings, stage
):
    sol = independent_braking(default_device, stage, default_virtual)
    braking = brakings[stage]
    dt, q = default_device.encoder.dt, default_device.encoder.quantum
    T = sol.t_events[0][0]

    # Rows: every sample up to the stop; one more or less if the stop is on a sample.
    rows = math.floor(T / dt) + 1
    on_sample = abs(T / dt - round(T / dt)) * dt < 1e-9
    assert abs(len(braking.log) - rows) <= (1 if on_sample else 0)
    # Stop: the integrators agree on Omega to ~1e-10 rad/s (below) and the braking still
    # decelerates at >= 0.15 rad/s^2 at rest, so the zero of Omega agrees to ~1e-9 s.
    assert abs(braking.truth.end_time - T) < 1e-7
    assert abs(braking.truth.end_phi - sol.y_events[0][0][0]) < 1e-8

    n = min(rows, len(braking.log))
    t = braking.log.t[:n]
    phi, omega = sol.sol(t)
    # Both integrate the same ODE far beyond the encoder's resolution: RK4 at dt/8 and
    # DOP853 at 1e-12 agree to ~1e-10 rad over the ~30 rad of the pass.
    assert np.abs(braking.truth.phi[:n] - phi).max() < 1e-8
    assert np.abs(braking.truth.omega[:n] - omega).max() < 1e-8
    # Encoder: 1e-8 rad is 1e-4 counts, so floor() can differ only where the angle lies
    # within 1e-8 rad of a count boundary, and then by one count.
    counts = np.floor(phi / q) - np.round(braking.log.phi[:n] / q)
    assert np.abs(counts).max() <= 1


# --- 3. the braking protocol of the default experiment --------------------------------------


@pytest.mark.parametrize("stage", STAGES)
def test_default_braking_protocol(default_device, default_virtual, brakings, stage):
    st = default_device.stages[stage - 1]
    braking = brakings[stage]
    release = math.radians(default_virtual.run.release_angle_deg)

    # Short enough to repeat: well under half a minute per pass.
    assert braking.truth.end_time < 30.0
    # At least three whole turns past the first passage of the last node after the release
    # (the least squares pairs positions a whole number of turns apart).
    last_node = st.nodes[-1]
    first_passage = last_node + 2 * math.pi * math.ceil((release - last_node) / (2 * math.pi))
    assert braking.log.phi[-1] - first_passage >= 3 * 2 * math.pi

    # Kinetic energy lost per whole turn, 1 - Omega_b^2 / Omega_a^2 (gravity cancels over a
    # turn, M(phi) is the same at both ends). It conditions M = dA / d(Omega^2): ~10 % or
    # less and speed errors swamp the difference; ~30 % or more and few turns remain.
    # The default protocol gives 0.19-0.29 on the first two turns.
    turns = release + 2 * math.pi * np.arange(3)
    omega = braking_speed_at(braking, turns)
    loss = 1.0 - omega[1:] ** 2 / omega[:-1] ** 2
    assert np.all((loss >= 0.08) & (loss <= 0.36)), loss


# --- 4. the log is what a rig writes ---------------------------------------------------------


@pytest.mark.parametrize("stage", STAGES)
def test_braking_log_format(default_device, default_virtual, brakings, stage, tmp_path):
    st = default_device.stages[stage - 1]
    encoder = default_device.encoder
    log, truth = brakings[stage].log, brakings[stage].truth
    q = encoder.quantum

    # Encoder grid: whole counts (the division by q rounds by < 1e-10 counts), and exactly
    # the incremental encoder's reading of the true angle.
    counts = log.phi / q
    assert np.abs(counts - np.round(counts)).max() < 1e-9
    np.testing.assert_array_equal(log.phi, np.floor(truth.phi / q) * q)
    # Time: k / sample_rate from 0 (k dt and k / rate differ by an ulp at most).
    assert log.t[0] == 0.0
    np.testing.assert_allclose(log.t, np.arange(len(log)) / encoder.sample_rate, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(log.t, truth.t)

    # Torque: the constant braking torque against the motion, plus white noise of the
    # configured std. For n >= 1.2e4 samples the sample std has a relative spread
    # 1/sqrt(2n) < 0.65 %, the mean a spread sigma/sqrt(n): 5 % and 5 sigma are > 7 spreads.
    np.testing.assert_array_equal(truth.torque, -st.braking_torque)
    noise = log.torque - truth.torque
    sigma = default_virtual.run.torque_noise
    n = len(noise)
    assert abs(noise.std() / sigma - 1.0) < 0.05
    assert abs(noise.mean()) < 5 * sigma / math.sqrt(n)

    # The file round trip is exact and passes the reader's checks.
    path = tmp_path / "braking.csv"
    write_log(path, log)
    back = read_log(path, encoder, "braking")
    for column in ("t", "phi", "torque"):
        np.testing.assert_array_equal(getattr(back, column), getattr(log, column))


# --- 5. the end of the braking is an event ---------------------------------------------------


@pytest.mark.parametrize("stage", STAGES)
def test_braking_ends_at_the_first_stop(default_device, default_virtual, brakings, stage):
    st = default_device.stages[stage - 1]
    truth = brakings[stage].truth
    dt = default_device.encoder.dt
    params = vd.true_parameters(default_device, stage, default_virtual)

    assert truth.end_omega == 0.0
    assert truth.t[-1] <= truth.end_time < truth.t[-1] + dt
    # The last row is still moving, and slowly: it stops within one sample, so its speed is
    # at most one sample's worth of deceleration (which barely changes over 1e-3 rad).
    eps = acceleration(truth.phi[-1], truth.omega[-1], -st.braking_torque, params)
    assert eps < 0.0
    assert 0.0 < truth.omega[-1] <= 1.01 * abs(eps) * (truth.end_time - truth.t[-1])
    assert np.all(truth.omega > 0.0)
    assert 0.0 <= truth.end_phi - truth.phi[-1] <= truth.omega[-1] * dt


# --- 6. static friction (docs/method.md §4) -------------------------------------------------


@pytest.fixture(scope="module")
def stage1(default_device, default_virtual):
    """Stage 1's true parameters, its Coulomb friction a1 and the sample period."""
    params = vd.true_parameters(default_device, 1, default_virtual)
    return params, default_virtual.friction.coulomb, default_device.encoder.dt


@pytest.mark.parametrize("fraction", [-1.0, -0.99, -0.5, 0.0, 0.5, 0.99, 1.0])
def test_static_friction_holds_a_body_at_rest(stage1, fraction):
    params, a1, dt = stage1
    phi = 0.7  # where gravity pulls with ~0.04 N m, 400 a1
    if abs(fraction) == 1.0:
        # Exactly at the threshold: without gravity, so that u - S is exactly +-a1.
        params = dataclasses.replace(params, gravity_sin=0.0, gravity_cos=0.0)
    u = static_torque(phi, params) + fraction * a1
    x = np.array([phi, 0.0])
    after = advance(x.copy(), u, dt, (params.vector, params.vector))
    np.testing.assert_array_equal(after, x)


@pytest.mark.parametrize("sign", [-1.0, 1.0])
def test_static_friction_breaks_away_in_the_direction_of_the_net_torque(stage1, sign):
    params, a1, dt = stage1
    phi = 0.7
    u = static_torque(phi, params) + sign * 1.01 * a1
    after = advance(np.array([phi, 0.0]), u, dt, (params.vector, params.vector))
    assert np.sign(after[1]) == sign and np.sign(after[0] - phi) == sign
    # Once moving, kinetic friction a1 opposes the motion: the net torque is 0.01 a1, and the
    # speed after one sample is that over M times dt (the angle moves by 1e-11 rad, gravity
    # changes by 1e-12 N m, viscous and quadratic terms are below 1e-11 N m).
    expected = sign * 0.01 * a1 / reduced_inertia(phi, params) * dt
    assert after[1] == pytest.approx(expected, rel=1e-4)


def test_a_slow_body_stops_and_stays_at_rest(stage1):
    params, a1, dt = stage1
    phi, Omega = 0.7, 1e-3
    # A torque against the motion that static friction can hold at rest.
    u = static_torque(phi, params) - 0.5 * a1
    x = np.array([phi, Omega])
    # Deceleration ~(1.5 a1 + 1e-7)/M ~ 3.7e-3 rad/s^2: it stops within ~0.3 s.
    stop_time = Omega / abs(acceleration(phi, Omega, u, params))
    speeds, angles = [], []
    for _ in range(round(2 * stop_time / dt)):
        x = advance(x, u, dt, (params.vector, params.vector))
        speeds.append(x[1])
        angles.append(x[0])
    speeds, angles = np.array(speeds), np.array(angles)
    stopped = np.flatnonzero(speeds == 0.0)
    assert stopped.size
    first = stopped[0]
    # It stopped once, at the time the deceleration predicts, and then stays put: the speed
    # is exactly zero and the angle exactly constant on every later sample (no chattering).
    assert first * dt == pytest.approx(stop_time, rel=0.02)
    assert np.all(speeds[:first] > 0.0)
    assert np.all(speeds[first:] == 0.0)
    assert np.all(angles[first:] == angles[first])


# --- 7. the ideal reverse is the mirror of the braking -----------------------------------


@pytest.mark.parametrize("stage", STAGES)
def test_ideal_reverse_mirrors_the_braking_speed(
    default_device, default_virtual, brakings, reverses, stage
):
    braking, reverse = brakings[stage], reverses[stage]
    # At every angle the reverse speed equals the braking speed in magnitude (docs/method.md §4).
    # The ideal drive feeds forward the exact inverse dynamics, averaged over each sample;
    # its docstring promises ~1e-6 rad/s, and the spline adds < 1e-9 rad/s.
    assert np.all(reverse.truth.omega[1:] < 0.0)
    mirror = braking_speed_at(braking, reverse.truth.phi)
    error = np.abs(-reverse.truth.omega - mirror)
    assert error.max() < 1e-6


@pytest.mark.parametrize("stage", STAGES)
def test_ideal_reverse_runs_from_rest_back_to_the_release(
    default_device, default_virtual, brakings, reverses, stage, tmp_path
):
    st = default_device.stages[stage - 1]
    braking, reverse = brakings[stage], reverses[stage]
    dt = default_device.encoder.dt
    release, launch = release_state(default_device, stage, default_virtual)
    params = vd.true_parameters(default_device, stage, default_virtual)

    assert reverse.truth.phi[0] == braking.truth.end_phi and reverse.truth.omega[0] == 0.0
    # The program is floor(T/dt) + 1 samples long, so it ends up to one sample past the
    # mirror of the release: by at most launch_speed dt in angle and |eps| dt in speed.
    eps = abs(acceleration(release, launch, -st.braking_torque, params))
    assert abs(reverse.truth.end_phi - release) <= 1.01 * launch * dt
    assert abs(reverse.truth.end_omega + launch) <= 1.01 * eps * dt

    path = tmp_path / "reverse.csv"
    write_log(path, reverse.log)
    back = read_log(path, default_device.encoder, "reverse")
    np.testing.assert_array_equal(back.phi, reverse.log.phi)


# --- 8. the closed loop keeps the drive's limits ---------------------------------------------


def constant_program(n, dt, phi_ref=0.0, torque_ff=0.0, k_phi=0.0, k_omega=0.0) -> Program:
    full = np.ones(n)
    return Program(
        t=np.arange(n) * dt,
        phi_ref=phi_ref * full,
        omega_ref=0.0 * full,
        torque_ff=torque_ff * full,
        k_phi=k_phi * full,
        k_omega=k_omega * full,
    )


def test_run_program_keeps_the_torque_and_rate_limits(default_device, default_virtual):
    motor = default_device.motor
    dt = default_device.encoder.dt
    du = motor.torque_rate_limit * dt
    n = 200
    # Steps of twice the torque limit up and down: beyond both the limit and the rate limit.
    request = np.where(np.arange(n) < 100, 2.0, -2.0) * motor.torque_limit
    request[:10] = 0.0
    base = constant_program(n, dt)
    program = dataclasses.replace(base, torque_ff=request)
    phi0 = 0.7
    run = vd.run_program(default_device, 1, default_virtual, program, (phi0, 0.0))

    u = run.truth.torque
    held = static_torque(phi0, vd.true_parameters(default_device, 1, default_virtual))
    steps = np.diff(np.concatenate([[held], u]))  # the motor held the body before the start
    assert np.abs(u).max() <= motor.torque_limit
    assert np.abs(steps).max() <= du + 1e-12
    # It gets there as fast as allowed: full-rate ramps up to each limit.
    assert u.max() == motor.torque_limit and u.min() == -motor.torque_limit
    assert np.allclose(steps[100:150], -du, rtol=0, atol=1e-12)


@pytest.mark.parametrize("step", [-0.05, 0.05])
def test_run_program_follows_a_step_in_the_reference_angle(default_device, default_virtual, step):
    dt = default_device.encoder.dt
    params = vd.true_parameters(default_device, 1, default_virtual)
    phi0 = 0.7
    target = phi0 + step
    w = 10.0  # rad/s, closed-loop poles of the regulator
    M = reduced_inertia(target, params)
    program = constant_program(
        round(20 / (w * dt)),
        dt,
        phi_ref=target,
        torque_ff=static_torque(target, params),
        k_phi=M * w * w,
        k_omega=2 * M * w,
    )
    run = vd.run_program(default_device, 1, default_virtual, program, (phi0, 0.0))
    truth = run.truth
    # The first torque pushes toward the reference, and the body moves that way.
    assert np.sign(truth.torque[0] - static_torque(phi0, params)) == np.sign(step)
    moved = truth.phi - phi0
    assert np.all(moved * np.sign(step) >= 0.0)
    # After 20/w it sits at the reference within what the loop cannot see or overcome: the
    # encoder's reading (the true angle lies within a count above it, and the observer's
    # estimate between two readings) plus the static friction's dead band a1 / k_phi.
    q = default_device.encoder.quantum
    dead_band = default_virtual.friction.coulomb / (M * w * w)
    assert abs(truth.phi[-1] - target) <= 2 * q + dead_band


# --- 9. the speed observer ---------------------------------------------------------------


def observe_ramp(phi0, omega0, a, bandwidth, dt, q, n=3000):
    """Run the SpeedObserver on the encoder readings of phi0 + omega0 t + a t^2 / 2."""
    t = np.arange(n) * dt
    phi = phi0 + omega0 * t + a * t * t / 2
    y = encoder_reading(phi, q)
    observer = vd.SpeedObserver(float(y[0]), omega0, bandwidth, dt)
    estimate = np.array([observer.update(float(v)) for v in y])
    return estimate - (omega0 + a * t)


# The reading floor(phi/q) q is the true angle minus a constant q/2 and a fluctuation within
# +-q/2. The constant gives no speed error (a type-3 loop's speed channel has no gain at zero
# frequency). The observer is linear in its readings, so after the start-up transient (a few
# 1/w) the fluctuation moves the estimate by at most ||h||_1 q / 2, h the speed's response to
# a unit impulse in the readings (its L1 norm is computed from the observer itself).


def quantization_bound(bandwidth, dt, q):
    observer = vd.SpeedObserver(0.0, 0.0, bandwidth, dt)
    h = [observer.update(1.0 if k == 0 else 0.0) for k in range(round(60 / (bandwidth * dt)))]
    return np.abs(h).sum() * q / 2


@pytest.mark.parametrize("omega0", [0.05, 0.7, 3.0, -6.0])
def test_speed_observer_follows_a_constant_speed(default_device, default_virtual, omega0):
    w = default_virtual.controller.speed_observer_bandwidth
    dt, q = default_device.encoder.dt, default_device.encoder.quantum
    error = observe_ramp(0.3, omega0, 0.0, w, dt, q)
    settled = error[round(30 / (w * dt)) :]  # after 30/w
    assert np.abs(settled).max() <= quantization_bound(w, dt, q)


@pytest.mark.parametrize("a", [-1.0, 1.0])
def test_speed_observer_follows_a_constant_acceleration(default_device, default_virtual, a):
    # Accelerations of 1 rad/s^2 and more occur on every default pass (stage 1 brakes at up
    # to 3.9 rad/s^2): a type-3 loop follows them without a steady error.
    w = default_virtual.controller.speed_observer_bandwidth
    dt, q = default_device.encoder.dt, default_device.encoder.quantum
    error = observe_ramp(0.3, 2.0, a, w, dt, q)
    settled = error[round(30 / (w * dt)) :]
    # No systematic error: the mean over the ~3000 counts swept averages the quantization
    # out (< 1e-3 q w at constant speed, see above); the peak is the quantization's bound.
    assert abs(settled.mean()) <= 0.01 * q * w
    assert np.abs(settled).max() <= quantization_bound(w, dt, q)


# --- 10. determinism -----------------------------------------------------------------------


def test_braking_is_reproducible_and_the_seed_moves_only_the_noise(
    default_device, default_virtual, brakings
):
    first = brakings[1]
    again = vd.simulate_braking(default_device, 1, default_virtual)
    for column in ("t", "phi", "torque"):
        np.testing.assert_array_equal(getattr(again.log, column), getattr(first.log, column))

    reseeded = dataclasses.replace(
        default_virtual,
        run=dataclasses.replace(default_virtual.run, seed=default_virtual.run.seed + 1),
    )
    other = vd.simulate_braking(default_device, 1, reseeded)
    np.testing.assert_array_equal(other.log.t, first.log.t)
    np.testing.assert_array_equal(other.log.phi, first.log.phi)
    np.testing.assert_array_equal(other.truth.phi, first.truth.phi)
    assert other.truth.end_time == first.truth.end_time
    # Two independent noise draws: every row differs, by sqrt(2) sigma in std (5 %: as above).
    difference = other.log.torque - first.log.torque
    assert np.all(difference != 0.0)
    sigma = default_virtual.run.torque_noise
    assert abs(difference.std() / (math.sqrt(2) * sigma) - 1.0) < 0.05


@pytest.mark.parametrize("direction", [Direction.FORWARD, Direction.BACKWARD])
def test_a_stage_release_angle_overrides_the_virtual_rigs(default_device, default_virtual, direction):
    """device.toml's protocol says where to release; virtual.toml's angle is only the rig's
    default. A release 40 deg later is the same motion as the default one seen from 40 deg on:
    same start speed, phi shifted by 40 deg at t = 0 (backward: by -40 deg)."""
    sign = direction.sign
    default = vd.simulate_braking(default_device, 1, default_virtual, direction)
    angle = default_virtual.run.release_angle_deg + 40.0
    stage = dataclasses.replace(default_device.stages[0], release_angle_deg=angle)
    device = dataclasses.replace(default_device, stages=(stage, *default_device.stages[1:]))
    moved = vd.simulate_braking(device, 1, default_virtual, direction)
    assert moved.truth.phi[0] == pytest.approx(sign * math.radians(angle), abs=1e-12)
    assert default.truth.phi[0] == pytest.approx(
        sign * math.radians(default_virtual.run.release_angle_deg), abs=1e-12
    )
    assert moved.truth.omega[0] == default.truth.omega[0] == sign * stage.launch_speed
    assert vd.release_angle(stage, default_virtual) == angle


# --- the drive's logger: jittered sampling, dropped rows ------------------------------------


def _jittery(virtual, jitter=0.2, dropped=0.0):
    return dataclasses.replace(
        virtual,
        logger=dataclasses.replace(virtual.logger, time_jitter=jitter, dropped_fraction=dropped),
    )


@pytest.mark.parametrize("stage", STAGES)
def test_jittered_braking_samples_the_same_motion(default_device, default_virtual, brakings, stage):
    """A drive sampling at jittered instants sees the same braking: the states at its
    instants lie on the regular run's trajectory (Omega^2 as a cubic spline of phi, an
    independent interpolation), the stamps stay within the jitter, and the torque noise is
    the same stream's."""
    regular = brakings[stage]
    sim = vd.simulate_braking(default_device, stage, _jittery(default_virtual))
    dt = default_device.encoder.dt
    t = sim.log.t
    k = np.rint(t / dt)
    assert t[0] == 0.0 and np.all(np.diff(k) == 1)
    assert 0.15 < np.abs(t / dt - k).max() <= 0.2
    assert t[-1] < regular.truth.end_time
    on_path = braking_speed_at(regular, sim.truth.phi)
    np.testing.assert_allclose(sim.truth.omega, on_path, rtol=0, atol=1e-8)
    np.testing.assert_array_equal(sim.log.phi, encoder_reading(sim.truth.phi, default_device.encoder.quantum))
    n = min(len(sim.log), len(regular.log))
    np.testing.assert_array_equal(sim.log.torque[:n], regular.log.torque[:n])


def test_the_logger_drops_rows_but_the_drive_acts(default_device, default_virtual, brakings):
    """With 1% of the rows dropped, about 1% are missing (binomial), never the first or the
    last; the rows kept are the full log's rows, bit for bit."""
    full = vd.simulate_braking(default_device, 1, _jittery(default_virtual, 0.2))
    sim = vd.simulate_braking(default_device, 1, _jittery(default_virtual, 0.2, 0.01))
    n = len(full.log)
    lost = n - len(sim.log)
    assert abs(lost - 0.01 * n) < 4 * math.sqrt(0.01 * n)
    kept = np.isin(full.log.t, sim.log.t)
    assert kept[0] and kept[-1] and kept.sum() == len(sim.log)
    for name in ("t", "phi", "torque"):
        np.testing.assert_array_equal(getattr(full.log, name)[kept], getattr(sim.log, name))
    np.testing.assert_array_equal(full.truth.omega[kept], sim.truth.omega)


def test_a_jittered_drive_keeps_its_rate_limit_per_actual_step(default_device, default_virtual):
    """The closed loop at jittered instants: the torque's change from one instant to the next
    stays within torque_rate_limit times that step, and the run still ends one period after
    its last instant on average."""
    motor = default_device.motor
    dt = default_device.encoder.dt
    n = 200
    request = np.where(np.arange(n) < 100, 2.0, -2.0) * motor.torque_limit
    program = dataclasses.replace(constant_program(n, dt), torque_ff=request)
    run = vd.run_program(default_device, 1, _jittery(default_virtual), program, (0.7, 0.0))
    held = static_torque(0.7, vd.true_parameters(default_device, 1, default_virtual))
    steps = np.diff(np.concatenate([[held], run.truth.torque]))
    h = np.diff(np.concatenate([run.truth.t, [run.truth.end_time]]))
    allowed = motor.torque_rate_limit * np.concatenate([[dt], h[:-1]])
    assert np.all(np.abs(steps) <= allowed + 1e-12)
    assert np.any(np.abs(np.abs(steps) - allowed) < 1e-12)  # it does ride the limit
    assert np.abs(run.truth.t / dt - np.arange(n)).max() <= 0.2
