"""The rig's transducers (plant/transducers.py, docs/method.md §3): an encoder that reads
phi + e(phi) and a drive whose transmission loses power by the direction of its flow. The
error series and its inverse agree, the drive's two gains split every torque by the power
flow and never make energy, a back-driven loss is a stronger braking and a driving loss a
weaker pilot, the energy balance closes on the delivered torque only, the ideal reverse still
mirrors the braking, the closed loop regulates on what the encoder reads, every log is the
erroneous encoder's reading, and the default rig is the exact one."""

import dataclasses
import math

import numpy as np
import pytest

from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.logs import write_log
from rsp_inertia.plant.model import (
    dissipation,
    mechanical_energy,
    reduced_inertia,
    static_torque,
)
from rsp_inertia.plant.transducers import (
    angle_error,
    delivered_torque,
    drive_gains,
    encoder_reading,
    error_basis,
    error_coefficients,
    error_slope_basis,
    logged_torque,
    power_flow_split,
    true_angle,
)
from rsp_inertia.virtual import device as vd
from rsp_inertia.virtual.config import Rig, load_virtual
from rsp_inertia.virtual.integrate import advance, true_pair
from tests.conftest import DEFAULTS
from tests.virtual.test_device import constant_program
from tests.virtual.test_rig import DIRECTIONS, assert_same_truth, braking_speed_at

Q = 2 * math.pi / 65536
"""rad, one count of the default 16-bit encoder."""

REALISTIC = ([2e-4, 5e-5, 2e-5], [30.0, -60.0, 110.0])
"""A good encoder's error curve, e = sum A_n sin(n phi + p_n): eccentricity 2e-4 rad (41
arcsec, two counts), runout and graduation below (amplitudes rad, phases deg)."""

LARGE = ([1e-3, 3e-4, 1e-4], [30.0, -60.0, 110.0])
"""A poor one: 1e-3 rad (206 arcsec, ten counts) of eccentricity."""

GROSS = ([2e-2, 1e-2, 5e-3], [30.0, -60.0, 110.0])
"""No real encoder: a disc a degree off centre, where the inverse's fixed-point iteration no
longer reaches rounding in its four steps."""

LOSSY = Rig(torque_gain=1.02, efficiency_driving=0.85, efficiency_backdriven=0.8)
"""A drive whose torque constant is 2 % off and whose transmission loses 15 % of the power
while the motor drives the body and 20 % while the body drives the motor back."""


@pytest.fixture(scope="module")
def device(default_device):
    """The default gimbal with a short stage 1: 5 rad/s braked by 0.05 N m (~3 s, ~1 turn)
    and pendulum runs of 5 s."""
    stage = dataclasses.replace(default_device.stages[0], launch_speed=5.0, braking_torque=0.05)
    pendulum = dataclasses.replace(default_device.pendulum, duration=5.0)
    return dataclasses.replace(
        default_device, stages=(stage, *default_device.stages[1:]), pendulum=pendulum
    )


def with_rig(virtual, **changes):
    return dataclasses.replace(virtual, rig=dataclasses.replace(virtual.rig, **changes))


def with_encoder_error(virtual, curve):
    amplitude, phase = curve
    return with_rig(
        virtual, encoder_error_amplitude=tuple(amplitude), encoder_error_phase_deg=tuple(phase)
    )


def slope_bound(amplitude) -> float:
    """max |e'(phi)| <= sum_n n A_n: the contraction factor of the inverse's iteration."""
    return sum(n * a for n, a in enumerate(amplitude, 1))


# --- the encoder's error series -------------------------------------------------------------


@pytest.mark.parametrize("curve", [REALISTIC, LARGE, GROSS], ids=["realistic", "large", "gross"])
def test_true_angle_inverts_the_reading_error(curve):
    amplitude, phase = curve
    theta = error_coefficients(amplitude, phase)
    phi = np.linspace(-4 * math.pi, 4 * math.pi, 20001)
    back = true_angle(phi + angle_error(phi, theta), theta)
    # phi = r - e(phi) by fixed-point iteration: each of its four evaluations of e gains the
    # factor L = max|e'|, so what is left is L^4 max|e| (5e-18 rad realistic, 2e-14 rad large,
    # 3e-7 rad gross), on top of the rounding of phi + e - e: a few ulps of |phi| <= 4 pi
    # (ulp 1.8e-15 rad).
    bound = 4 * np.spacing(4 * math.pi) + slope_bound(amplitude) ** 4 * sum(amplitude)
    assert np.abs(back - phi).max() <= bound
    if curve is not GROSS:  # every real encoder: to rounding
        assert bound < 3e-14
    # And the other way round: the angle found reads the reading given.
    reading = np.linspace(-4 * math.pi, 4 * math.pi, 20001)
    found = true_angle(reading, theta)
    assert np.abs(found + angle_error(found, theta) - reading).max() <= bound
    # And the correction is real, not lost in rounding: it reaches the first order's size.
    assert np.abs(found - reading).max() > 0.5 * amplitude[0]


def test_error_slope_basis_is_the_derivative_of_error_basis():
    phi = np.linspace(-7.0, 7.0, 1401)
    orders = 4
    h = 1e-5
    slope = (error_basis(phi + h, orders) - error_basis(phi - h, orders)) / (2 * h)
    # Central differences: truncation h^2/6 max|f'''| = h^2 n^3 / 6 <= 1.1e-9 for n <= 4, and
    # the rounding of two values of size 1 over 2h, ~1e-16 / 1e-5 = 1e-11.
    np.testing.assert_allclose(error_slope_basis(phi, orders), slope, rtol=0, atol=2e-9)
    # So e'(phi) of any coefficients is the slope basis times them.
    theta = error_coefficients(*LARGE)
    e_slope = (angle_error(phi + h, theta) - angle_error(phi - h, theta)) / (2 * h)
    np.testing.assert_allclose(error_slope_basis(phi, 3) @ theta, e_slope, rtol=0, atol=1e-11)


def test_error_coefficients_give_the_amplitude_and_phase_form():
    amplitude, phase = [3e-4, 1e-4, 4e-5], [0.0, 135.0, -90.0]
    phi = np.linspace(-7.0, 7.0, 1401)
    n = np.arange(1, 4)
    expected = (np.asarray(amplitude) * np.sin(phi[:, None] * n + np.radians(phase))).sum(axis=1)
    # The two differ by rounding only: mostly that of the angle n phi + p (ulp(3 x 7 rad) =
    # 3.6e-15 rad) times the amplitudes, ~1.6e-18 rad.
    rounding = sum(amplitude) * np.spacing(3 * 7.0)
    np.testing.assert_allclose(
        angle_error(phi, error_coefficients(amplitude, phase)), expected, rtol=0, atol=rounding
    )
    # The first order alone at phase 0 is A sin(phi): c_1 = 0, s_1 = A.
    np.testing.assert_array_equal(error_coefficients([2e-4], [0.0]), [0.0, 2e-4])
    assert error_coefficients([], []).size == 0


# --- scalar and array paths -----------------------------------------------------------------


def test_the_encoders_scalar_and_array_paths_read_alike():
    # The drive's loop reads one sample at a time (plain floats), the logger a whole pass at
    # once (numpy): both must read the same counts. A difference in the last ulp of e could
    # move a reading by a count only where phi + e lies within ~1e-15 rad of a count boundary:
    # never among these angles, unless one path computed something else.
    phi = np.linspace(-4 * math.pi, 4 * math.pi, 40001) + 1e-7
    for theta in ((), np.zeros(4), error_coefficients(*REALISTIC), error_coefficients(*LARGE)):
        array = encoder_reading(phi, Q, theta)
        scalar = np.array([encoder_reading(float(p), Q, theta) for p in phi])
        np.testing.assert_array_equal(scalar, array)
        assert isinstance(encoder_reading(0.3, Q, theta), float)
    # On count boundaries, where a rounding decides the count, the exact encoder's two paths
    # do the same arithmetic.
    counts = np.arange(-1000, 1000) * Q
    scalar = [encoder_reading(float(c), Q) for c in counts]
    np.testing.assert_array_equal(scalar, encoder_reading(counts, Q))


COMMANDS = [-0.3, -1e-3, 0.0, 2e-3, 0.25]
MOTIONS = [-1.0, -2e-4, 0.0, 3e-5, 1.0]  # signs of a speed, or angle increments
GAINS = drive_gains(1.02, 0.85, 0.8)


def test_the_drives_scalar_and_array_paths_agree():
    command, motion = (a.ravel() for a in np.meshgrid(COMMANDS, MOTIONS))
    for transfer in (delivered_torque, logged_torque):
        array = transfer(command, motion, GAINS)
        scalar = [transfer(float(c), float(m), GAINS) for c, m in zip(command, motion)]
        np.testing.assert_array_equal(scalar, array)
        # A whole log against one direction (the pilot's forward spin-up) broadcasts.
        forward = np.ones_like(motion)
        np.testing.assert_array_equal(
            transfer(command, 1.0, GAINS), transfer(command, forward, GAINS)
        )


def test_logged_torque_inverts_delivered_torque():
    command, motion = (a.ravel() for a in np.meshgrid(COMMANDS, MOTIONS))
    # Both gains are positive: the delivered torque has the command's sign, so the same split
    # undoes it. x h / h is x to one rounding each way (relative 2.2e-16).
    back = logged_torque(delivered_torque(command, motion, GAINS), motion, GAINS)
    np.testing.assert_allclose(back, command, rtol=4.5e-16, atol=0)
    again = delivered_torque(logged_torque(command, motion, GAINS), motion, GAINS)
    np.testing.assert_allclose(again, command, rtol=4.5e-16, atol=0)
    for c, m in zip(command, motion):
        assert logged_torque(delivered_torque(c, m, GAINS), m, GAINS) == pytest.approx(
            c, rel=4.5e-16, abs=0
        )


def test_the_power_flow_split_adds_up_and_the_transmission_makes_no_energy():
    command, motion = (a.ravel() for a in np.meshgrid(COMMANDS, MOTIONS))
    driving, back = power_flow_split(command, motion)
    # One of the two parts is the torque, the other zero: they add up exactly.
    np.testing.assert_array_equal(driving + back, command)
    assert np.all(driving * back == 0.0)
    assert np.all(driving * motion >= 0.0) and np.all(back * motion <= 0.0)
    assert np.all(driving[motion == 0.0] == command[motion == 0.0])  # at rest: driving
    assert np.any(driving != 0.0) and np.any(back != 0.0)
    # The motor's own torque is command / gain. Whichever way the power flows, the
    # transmission takes power out of the motion and never adds any: the motor's power
    # exceeds the body's while it drives, the body's exceeds the motor's while back-driven.
    gain = 1.02
    delivered = delivered_torque(command, motion, GAINS)
    assert np.all((command / gain - delivered) * motion >= 0.0)
    # A lossless transmission passes it all.
    lossless = drive_gains(gain, 1.0, 1.0)
    np.testing.assert_allclose(delivered_torque(command, motion, lossless), command / gain)


# --- the lossy drive on the virtual device ----------------------------------------------------


@pytest.mark.parametrize("direction", DIRECTIONS)
def test_a_backdriven_loss_brakes_like_a_stronger_braking_torque(device, virtual, direction):
    # While braking the body drives the motor back: it gives the command times
    # h_b = 1 / (eta_b gain), here 1 / (0.8 x 1.03) = 1.21 times the command.
    lossy = with_rig(virtual, torque_gain=1.03, efficiency_backdriven=0.8)
    st = device.stages[0]
    s = float(direction.sign)
    h_b = lossy.rig.drive_gains[1]
    run = vd.simulate_braking(device, 1, lossy, direction)
    np.testing.assert_array_equal(run.log.torque, -s * st.braking_torque)
    np.testing.assert_array_equal(run.truth.torque, -s * st.braking_torque * h_b)
    # Physically, the braking of an exact rig with a braking torque h_b times larger.
    stronger = dataclasses.replace(st, braking_torque=st.braking_torque * h_b)
    exact = dataclasses.replace(device, stages=(stronger, *device.stages[1:]))
    assert_same_truth(run, vd.simulate_braking(exact, 1, virtual, direction))
    # The driving efficiency never acts on a braking: the power only flows back.
    both = with_rig(lossy, efficiency_driving=0.6)
    other = vd.simulate_braking(device, 1, both, direction)
    assert_same_truth(run, other)
    np.testing.assert_array_equal(other.log.torque, run.log.torque)


def test_a_driving_loss_spins_the_pilot_up_like_a_weaker_torque(device, virtual):
    # The pilot's motor drives the body forward and then is off: the body receives h_d =
    # eta_d / gain times the command, and the back-driven efficiency never acts.
    lossy = with_rig(virtual, torque_gain=1.02, efficiency_driving=0.85)
    h_d = lossy.rig.drive_gains[0]
    pilot = vd.simulate_pilot(device, 1, lossy)
    command = vd.PILOT_TORQUE_FRACTION * device.motor.torque_limit
    assert set(pilot.log.torque) == {command, 0.0}
    np.testing.assert_array_equal(pilot.truth.torque, h_d * pilot.log.torque)
    # Physically, the pilot of an exact rig whose pilot torque (a fraction of the torque
    # limit) is h_d times the command: the same truth, bit for bit (x 0.5 is exact).
    motor = dataclasses.replace(device.motor, torque_limit=device.motor.torque_limit * h_d)
    weaker = vd.simulate_pilot(dataclasses.replace(device, motor=motor), 1, virtual)
    assert_same_truth(pilot, weaker)
    backdriven = with_rig(lossy, efficiency_backdriven=0.5)
    assert_same_truth(pilot, vd.simulate_pilot(device, 1, backdriven))


def swinging_torque_program(device, n=1000):
    """Open loop, a torque of +-0.04 N m swinging at 4 Hz for a second: on a body spinning at
    6 rad/s it alternately drives it and brakes it, without ever stopping it."""
    dt = device.encoder.dt
    program = constant_program(n, dt)
    return dataclasses.replace(program, torque_ff=0.04 * np.sin(2 * math.pi * 4.0 * program.t))


@pytest.mark.parametrize("s", [1.0, -1.0], ids=DIRECTIONS)
def test_the_energy_balance_closes_on_the_delivered_torque(device, virtual, s):
    # docs/method.md §3: E(end) - E(start) = the work of the torque the body receives + the
    # friction's work. On a lossy drive that torque is h_d or h_b times the logged command by
    # the direction of the power flow, so the logged command's own work leaves a gap.
    lossy = dataclasses.replace(virtual, rig=LOSSY)
    run = vd.run_program(device, 1, lossy, swinging_torque_program(device), (0.5, s * 6.0))
    truth = run.truth
    params = vd.true_parameters(device, 1, lossy, s)
    pair = true_pair(device, 1, lossy)
    t = np.append(truth.t, truth.end_time)
    phi = np.append(truth.phi, truth.end_phi)
    omega = np.append(truth.omega, truth.end_omega)
    assert np.all(omega * s > 4.0)  # it never stops: one friction law throughout
    dphi = np.diff(phi)
    driving, back = power_flow_split(run.log.torque, dphi)
    assert np.sum(driving * dphi) > 0.05 and np.sum(back * dphi) < -0.05  # both flows, J

    energy_change = mechanical_energy(phi[-1], omega[-1], params) - mechanical_energy(
        phi[0], omega[0], params
    )
    # The torque is held over each sample: its work there is exactly torque x dphi.
    delivered_work = np.sum(truth.torque * dphi)
    logged_work = np.sum(run.log.torque * dphi)
    # The friction's work, -int D(Omega) Omega dt, by Simpson's rule on each sample with its
    # midpoint state from the integrator itself: the held torque steps at every sample, so
    # Omega has a kink there (Simpson across samples errs by ~2e-8 J); within one sample
    # the integrand is smooth and the rule's error ~h^5 f''''/2880 is far below 1e-15 J.
    h = np.diff(t)
    middle = np.array(
        [
            advance(np.array([p, w]), u, dh / 2, pair)
            for p, w, u, dh in zip(phi, omega, truth.torque, h)
        ]
    )

    def power(w):
        return np.asarray(dissipation(w, params, direction=s)) * w

    simpson = h / 6 * (power(omega[:-1]) + 4 * power(middle[:, 1]) + power(omega[1:]))
    friction_work = -np.sum(simpson)
    # The states come from RK4 at dt/8, ~1e-13 relative over the second: the ~0.2 J the
    # energy changes by balances to ~1e-14 J. 1e-11 J keeps a margin of 1000 and is 3e-10
    # of the gap the logged command leaves (~0.03 J).
    assert energy_change == pytest.approx(delivered_work + friction_work, abs=1e-11)
    assert abs(energy_change - logged_work - friction_work) > 0.01
    # What the estimators do with the log: h_d on its driving part, h_b on its back-driven
    # part (split by the sign of torque x angle increment) closes it as well.
    h_d, h_b = LOSSY.drive_gains
    split_work = h_d * np.sum(driving * dphi) + h_b * np.sum(back * dphi)
    assert energy_change == pytest.approx(split_work + friction_work, abs=1e-11)
    # And the transmission takes power out of the motion on every sample, never adds any:
    # the body's work falls short of the motor's (its torque: command / gain) while driving,
    # and exceeds what reaches the motor while back-driven.
    motor = run.log.torque / LOSSY.torque_gain
    assert np.all((truth.torque - motor) * dphi <= 0.0)


@pytest.mark.parametrize("direction", DIRECTIONS)
def test_the_ideal_reverse_on_a_lossy_drive_still_mirrors_the_braking(device, virtual, direction):
    lossy = dataclasses.replace(virtual, rig=LOSSY)
    braking = vd.simulate_braking(device, 1, lossy, direction)
    reverse = vd.simulate_ideal_reverse(device, 1, lossy, braking, direction)
    truth = reverse.truth
    # The same speed at every angle (docs/method.md §4): the ideal drive applies the physical
    # inverse dynamics exactly whatever the transmission, so test_rig's tolerance holds.
    error = np.abs(np.abs(truth.omega) - braking_speed_at(braking, truth.phi))
    assert error.max() < 1e-6
    # Its log is the command a lossy drive needs for the torque the body received: split by
    # the direction the body moves over each sample (from rest: the way it broke away).
    step = np.diff(np.append(truth.phi, truth.end_phi))
    motion = np.where(truth.omega != 0.0, np.sign(truth.omega), np.sign(step))
    needed = logged_torque(truth.torque, motion, LOSSY.drive_gains)
    np.testing.assert_array_equal(reverse.log.torque, needed)
    # On the reverse the motor powers the body back up, against the friction and the mirror
    # of the braking torque: every row drives, and the drive commands 1 / h_d times more.
    assert np.all(truth.torque * motion > 0.0)
    np.testing.assert_array_equal(reverse.log.torque, truth.torque / LOSSY.drive_gains[0])


def test_a_command_the_transmission_cannot_pass_holds_the_body(device, virtual):
    # At rest against gravity S > 0, a command u with h_d u < S < h_b u moves the body
    # neither way: driving it forward would deliver only h_d u < S, and being back-driven it
    # would have to deliver h_b u > S, which pushes it forward. The transmission's own
    # friction holds it, as a worm gear holds a load.
    lossy = dataclasses.replace(virtual, rig=LOSSY)
    h_d, h_b = LOSSY.drive_gains
    phi0 = 0.5
    held = float(static_torque(phi0, vd.true_parameters(device, 1, lossy)))
    assert held > 0.05  # N m, against 1e-4 N m of static friction in the bearings
    program = constant_program(300, device.encoder.dt, torque_ff=held / math.sqrt(h_d * h_b))
    truth = vd.run_program(device, 1, lossy, program, (phi0, 0.0)).truth
    np.testing.assert_array_equal(truth.omega, 0.0)
    np.testing.assert_array_equal(truth.phi, phi0)


# --- the erroneous encoder on the virtual device ----------------------------------------------


def test_the_closed_loop_regulates_on_what_the_encoder_reads(device, virtual):
    # A balanced body (no gravity torque, no spring) held at phi_ref by stiff feedback alone:
    # the drive only knows the reading, so it settles where the encoder reads phi_ref, at the
    # true angle true_angle(phi_ref), not at phi_ref.
    balanced = dataclasses.replace(virtual, body=dataclasses.replace(virtual.body, com=[0, 0, 0]))
    erring = with_encoder_error(balanced, ([1e-3, 3e-4], [90.0, 20.0]))
    theta = erring.rig.encoder_error
    q = device.encoder.quantum
    phi_ref = 5000 * q  # a reading: whole counts
    target = float(true_angle(phi_ref, theta))
    assert abs(target - phi_ref) > 10 * q  # the error is 12 counts here
    params = vd.true_parameters(device, 1, erring)
    w = 20.0  # rad/s, closed-loop poles of the regulator
    M = reduced_inertia(target, params)
    dt = device.encoder.dt
    program = constant_program(
        round(20 / (w * dt)), dt, phi_ref=phi_ref, k_phi=M * w * w, k_omega=2 * M * w
    )
    for rig, centre in ((erring, target), (balanced, phi_ref)):
        run = vd.run_program(device, 1, rig, program, (phi_ref, 0.0))
        settled = run.truth.phi[-200:]
        # After 20/w it reads phi_ref and stays: phi + e(phi) in [phi_ref, phi_ref + q), i.e.
        # the true angle within one count above true_angle(phi_ref) (the count's width in
        # phi is q / (1 + e'), |e'| <= 1.6e-3); the static friction's dead band
        # a1 / k_phi (0.06 counts) lies inside the count.
        np.testing.assert_array_equal(run.log.phi[-200:], phi_ref)
        assert np.all((settled >= centre) & (settled < centre + q * (1 + 2e-3)))


def test_every_log_is_the_erring_encoders_reading_of_the_true_angle(device, virtual):
    amplitude, phase = LARGE
    erring = with_encoder_error(virtual, LARGE)
    q = device.encoder.quantum
    braking = vd.simulate_braking(device, 1, erring)
    passes = {
        "braking": braking,
        "braking backward": vd.simulate_braking(device, 1, erring, Direction.BACKWARD),
        "reverse": vd.simulate_ideal_reverse(device, 1, erring, braking),
        "pendulum": vd.simulate_pendulum(device, 1, erring, 0),
        "pilot": vd.simulate_pilot(device, 1, erring),
    }
    n = np.arange(1, len(amplitude) + 1)
    for name, run in passes.items():
        phi = run.truth.phi
        # e = sum A_n sin(n phi + p_n) as virtual.toml states it, computed here on its own:
        # it differs from the simulator's series by ~1e-19 rad, which moves a reading only
        # where phi + e lies that close to a count boundary: never in these ~3e4 samples.
        e = (np.asarray(amplitude) * np.sin(phi[:, None] * n + np.radians(phase))).sum(axis=1)
        np.testing.assert_array_equal(run.log.phi, np.floor((phi + e) / q) * q, err_msg=name)
        # And it is not the exact encoder's: e spans +-14 counts.
        exact = np.floor(phi / q) * q
        assert np.mean(run.log.phi != exact) > 0.5, name


def test_the_default_rig_is_the_exact_one(device, default_virtual, tmp_path):
    # Efficiencies of 1 and an error curve of zero amplitude, stated in virtual.toml, give
    # the same log files, byte for byte, as a virtual.toml without those keys (torque noise
    # on: the random streams are the same too).
    text = (DEFAULTS / "virtual.toml").read_text()
    keys = (
        "\n[rig]\nefficiency_driving = 1.0\nefficiency_backdriven = 1.0\n"
        "encoder_error_amplitude = [0.0, 0.0]\nencoder_error_phase_deg = [30.0, -45.0]\n"
    )
    plain = tmp_path / "plain.toml"
    plain.write_text(text)
    stated = tmp_path / "stated.toml"
    stated.write_text(text + keys)
    rigs = {"plain": load_virtual(plain), "stated": load_virtual(stated)}
    assert rigs["plain"] == default_virtual
    assert rigs["stated"].rig.encoder_error.size == 4 and rigs["stated"] != default_virtual

    def logs(virtual):
        braking = vd.simulate_braking(device, 1, virtual)
        program = vd.ideal_program(device, 1, virtual, braking)
        start = (braking.truth.end_phi, 0.0)
        return {
            "braking": braking.log,
            "braking_backward": vd.simulate_braking(device, 1, virtual, Direction.BACKWARD).log,
            "reverse_ideal": vd.simulate_ideal_reverse(device, 1, virtual, braking).log,
            "reverse": vd.run_program(device, 1, virtual, program, start).log,
            "pendulum": vd.simulate_pendulum(device, 1, virtual, 0).log,
            "pilot": vd.simulate_pilot(device, 1, virtual).log,
        }

    for rig, virtual in rigs.items():
        for name, log in logs(virtual).items():
            write_log(tmp_path / f"{rig}-{name}.csv", log)
    for name in ("braking", "braking_backward", "reverse_ideal", "reverse", "pendulum", "pilot"):
        plain_bytes = (tmp_path / f"plain-{name}.csv").read_bytes()
        assert (tmp_path / f"stated-{name}.csv").read_bytes() == plain_bytes, name
