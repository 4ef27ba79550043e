"""The virtual rig's imperfections and backward runs (docs/method.md §2-4, virtual/device.py): a
backward braking is the mirror of a forward one, energy balances, the torque gain separates
the logged command from the physical torque, friction may differ backward, the fixture adds
its inertia, the rig's true tare replaces device.toml's."""

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import simpson
from scipy.interpolate import CubicSpline

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import TrueBody
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.logs import Program, read_log, write_log
from rsp_inertia.plant.model import dissipation, mechanical_energy, static_torque
from rsp_inertia.virtual import device as vd
from rsp_inertia.virtual.config import Friction, Rig
from rsp_inertia.virtual.integrate import advance

DIRECTIONS = tuple(Direction)


@pytest.fixture(scope="module")
def device(default_device):
    """The default gimbal with a short stage 1: 5 rad/s braked by 0.05 N m (~5 s, ~2 turns)."""
    stage = dataclasses.replace(default_device.stages[0], launch_speed=5.0, braking_torque=0.05)
    return dataclasses.replace(default_device, stages=(stage, *default_device.stages[1:]))


def with_friction(virtual, **changes):
    return dataclasses.replace(virtual, friction=dataclasses.replace(virtual.friction, **changes))


def mirrored(body: TrueBody) -> TrueBody:
    """The body reflected in the y-z plane (x -> -x): Jxy, Jxz and x_c change sign, so that
    its M(phi) and potential are the original's at -phi (Ms2, Ms1 and Gs negated)."""
    jx, jy, jz, jxy, jyz, jxz = body.inertia
    x, y, z = body.com
    return TrueBody(mass=body.mass, inertia=[jx, jy, jz, -jxy, jyz, -jxz], com=[-x, y, z])


def assert_same_truth(a, b):
    for name in ("t", "phi", "omega", "torque"):
        np.testing.assert_array_equal(getattr(a.truth, name), getattr(b.truth, name))
    assert (a.truth.end_time, a.truth.end_phi) == (b.truth.end_time, b.truth.end_phi)


# --- backward runs ------------------------------------------------------------------------


def test_backward_braking_is_the_mirror_of_the_mirrored_bodys_forward_braking(device, virtual):
    # phi -> -phi maps the equation of motion of the body onto that of the body reflected
    # x -> -x, with the spring's zero angle negated, the motor torque negated and the
    # backward friction playing the forward one. Friction differs backward here (x 2), so
    # that the test also sees the backward run use its own coefficients.
    spring = dataclasses.replace(device.spring, stiffness=2e-3, zero_angle=0.4)
    original = dataclasses.replace(device, spring=spring)
    mirror_device = dataclasses.replace(device, spring=dataclasses.replace(spring, zero_angle=-0.4))
    asymmetric = with_friction(virtual, backward_scale=2.0)
    mirror = dataclasses.replace(
        asymmetric, body=mirrored(asymmetric.body), friction=asymmetric.friction_for(-1)
    )
    backward = vd.simulate_braking(original, 1, asymmetric, Direction.BACKWARD)
    forward = vd.simulate_braking(mirror_device, 1, mirror, Direction.FORWARD)

    assert backward.truth.phi[-1] < backward.truth.phi[0] - 2 * math.pi  # it ran backward
    assert len(backward.log) == len(forward.log)
    # Both integrations do the same arithmetic up to signs (sin is odd, cos even in IEEE
    # arithmetic): they agree to rounding, ~1e-16 per step over ~4e4 RK4 steps at worst
    # (in practice bit for bit).
    np.testing.assert_allclose(backward.truth.phi, -forward.truth.phi, rtol=0, atol=1e-11)
    np.testing.assert_allclose(backward.truth.omega, -forward.truth.omega, rtol=0, atol=1e-11)
    np.testing.assert_array_equal(backward.truth.torque, -forward.truth.torque)
    assert backward.truth.end_time == pytest.approx(forward.truth.end_time, abs=1e-12)
    assert backward.truth.end_phi == pytest.approx(-forward.truth.end_phi, abs=1e-11)
    assert backward.truth.end_omega == 0.0


def test_backward_braking_balances_energy(device, virtual):
    # docs/method.md §3: E(end) - E(release) = motor work + friction work, the motor's constant
    # torque +b times the (negative) displacement, the friction's -integral of D Omega dt.
    asymmetric = with_friction(virtual, backward_scale=1.5)
    braking = vd.simulate_braking(device, 1, asymmetric, Direction.BACKWARD)
    params = vd.true_parameters(device, 1, asymmetric, -1)
    truth = braking.truth
    t = np.append(truth.t, truth.end_time)
    phi = np.append(truth.phi, truth.end_phi)
    omega = np.append(truth.omega, 0.0)

    energy_drop = mechanical_energy(phi[-1], 0.0, params) - mechanical_energy(
        phi[0], omega[0], params
    )
    u = device.stages[0].braking_torque  # physical: torque gain 1
    np.testing.assert_array_equal(truth.torque, u)
    motor_work = u * (phi[-1] - phi[0])
    friction_power = np.asarray(dissipation(omega, params, direction=-1.0)) * omega
    friction_work = -simpson(friction_power, x=t)
    assert motor_work < 0.0 and friction_work < 0.0
    # The state comes from RK4 at dt/8 (~1e-13 relative over the pass); the friction work
    # from Simpson's rule on the 1 kHz samples of a smooth D(Omega) Omega, error ~ dt^4 T
    # max|d4f/dt4| ~ 1e-13 J, the short last interval up to the stop included (it alone holds
    # ~2e-10 J). Of the ~0.57 J exchanged, the balance closes to ~1e-14 J; 1e-10 J is a
    # margin of 1000 over both errors and still catches a missing last interval.
    assert energy_drop == pytest.approx(motor_work + friction_work, abs=1e-10)


def test_backward_braking_logs_a_pass_that_moves_down(device, default_virtual, tmp_path):
    braking = vd.simulate_braking(device, 1, default_virtual, Direction.BACKWARD)
    truth, log = braking.truth, braking.log
    st = device.stages[0]
    # The mirror of the forward release: -release_angle_deg at -launch_speed.
    assert truth.phi[0] == -math.radians(default_virtual.run.release_angle_deg)
    assert truth.omega[0] == -st.launch_speed
    assert np.all(truth.omega < 0.0) and truth.end_omega == 0.0
    dt = device.encoder.dt
    assert truth.t[-1] <= truth.end_time < truth.t[-1] + dt
    assert 0.0 <= truth.phi[-1] - truth.end_phi <= -truth.omega[-1] * dt
    # The motor brakes against the motion: +braking_torque, and the log adds noise to it
    # from the backward pass's own stream (not the forward pass's).
    np.testing.assert_array_equal(truth.torque, st.braking_torque)
    noise = log.torque - st.braking_torque
    forward = vd.simulate_braking(device, 1, default_virtual, Direction.FORWARD)
    forward_noise = forward.log.torque + st.braking_torque
    n = min(len(noise), len(forward_noise))
    assert np.all(noise != 0.0) and not np.any(noise[:n] == forward_noise[:n])
    # The file is a backward braking log and nothing else.
    path = tmp_path / "braking_backward.csv"
    write_log(path, log)
    back = read_log(path, device.encoder, "braking", Direction.BACKWARD)
    np.testing.assert_array_equal(back.phi, log.phi)
    with pytest.raises(InputError, match="must end at a larger phi"):
        read_log(path, device.encoder, "braking")


def braking_speed_at(braking, phi):
    """|Omega| of a braking pass at angles phi: a cubic spline of Omega^2 over phi (smooth
    down to the rest, where Omega itself has a square-root corner), either direction."""
    truth = braking.truth
    phi_k = np.append(truth.phi, truth.end_phi)
    omega_k = np.append(truth.omega, 0.0)
    if truth.end_time == truth.t[-1]:
        phi_k, omega_k = phi_k[:-1], omega_k[:-1]
    order = np.argsort(phi_k)
    return np.sqrt(np.maximum(CubicSpline(phi_k[order], omega_k[order] ** 2)(phi), 0.0))


def test_ideal_reverse_of_a_backward_braking_mirrors_it_with_a_torque_gain(device, virtual):
    # The hardest case at once: backward, friction x 2 backward, a torque gain of 2.
    imperfect = dataclasses.replace(
        with_friction(virtual, backward_scale=2.0), rig=Rig(torque_gain=2.0)
    )
    braking = vd.simulate_braking(device, 1, imperfect, Direction.BACKWARD)
    reverse = vd.simulate_ideal_reverse(device, 1, imperfect, braking, Direction.BACKWARD)
    truth = reverse.truth
    # The reverse moves phi up, from the braking's rest back to its release.
    assert truth.phi[0] == braking.truth.end_phi and np.all(truth.omega[1:] > 0.0)
    assert abs(truth.end_phi - braking.truth.phi[0]) <= 1.01 * device.stages[0].launch_speed * (
        device.encoder.dt
    )
    # The same speed at every angle (docs/method.md §4): the ideal drive applies the physical
    # inverse dynamics exactly, so the tolerance of the forward default case holds.
    error = np.abs(truth.omega - braking_speed_at(braking, truth.phi))
    assert error.max() < 1e-6
    # What the log records is the drive's command, torque_gain times the physical torque.
    np.testing.assert_array_equal(reverse.log.torque, 2.0 * truth.torque)


# --- torque gain ----------------------------------------------------------------------------


@pytest.mark.parametrize("direction", DIRECTIONS)
def test_torque_gain_logs_the_command_and_applies_command_over_gain(device, virtual, direction):
    gain = 2.5
    st = device.stages[0]
    run = vd.simulate_braking(device, 1, dataclasses.replace(virtual, rig=Rig(gain)), direction)
    s = float(direction.sign)
    np.testing.assert_array_equal(run.log.torque, -s * st.braking_torque)
    # The body receives the command times h_b = 1 / gain (rounding aside, command / gain).
    h_b = Rig(gain).drive_gains[1]
    assert h_b == 1 / gain
    np.testing.assert_array_equal(run.truth.torque, -s * st.braking_torque * h_b)
    # Physically, a braking torque of braking_torque / gain on an exact rig.
    weaker = dataclasses.replace(st, braking_torque=st.braking_torque * h_b)
    exact = dataclasses.replace(device, stages=(weaker, *device.stages[1:]))
    assert_same_truth(run, vd.simulate_braking(exact, 1, virtual, direction))


def test_closed_loop_logs_the_command_and_applies_command_over_gain(device, virtual):
    gain = 0.5
    dt = device.encoder.dt
    phi0 = 0.5  # where gravity needs ~0.07 N m to hold the body
    imperfect = dataclasses.replace(virtual, rig=Rig(gain))
    held = static_torque(phi0, vd.true_parameters(device, 1, imperfect))
    # Before the program the drive held the body still: its command was gain x the static
    # torque, which differs from the static torque by more than one sample's rate limit, so
    # only a rate limiter that starts from the command lets this program through unchanged.
    assert (1 - gain) * held > device.motor.torque_rate_limit * dt
    n = 200
    full = np.ones(n)
    program = Program(
        t=np.arange(n) * dt,
        phi_ref=phi0 * full,
        omega_ref=0.0 * full,
        torque_ff=gain * held + np.linspace(0.0, 0.05, n),  # within the limits
        k_phi=0.0 * full,
        k_omega=0.0 * full,
    )
    run = vd.run_program(device, 1, imperfect, program, (phi0, 0.0))
    # The program's torque reaches the log as commanded, the body gets it over the gain.
    np.testing.assert_array_equal(run.log.torque, program.torque_ff)
    np.testing.assert_array_equal(run.truth.torque, program.torque_ff / gain)


# --- friction by direction -----------------------------------------------------------------


def test_backward_scale_one_changes_nothing(device, virtual):
    plain = vd.simulate_braking(device, 1, virtual, Direction.BACKWARD)
    explicit = with_friction(virtual, backward_scale=1.0)
    same_table = dataclasses.replace(
        virtual,
        friction_backward=Friction(
            virtual.friction.coulomb, virtual.friction.viscous, virtual.friction.quadratic
        ),
    )
    for other in (explicit, same_table):
        for direction in (1, -1):
            np.testing.assert_array_equal(
                vd.true_parameters(device, 1, other, direction).vector,
                vd.true_parameters(device, 1, virtual, direction).vector,
            )
        assert_same_truth(vd.simulate_braking(device, 1, other, Direction.BACKWARD), plain)


def test_backward_scale_changes_only_backward_motion(device, virtual):
    scaled = with_friction(virtual, backward_scale=3.0)
    forward = vd.true_parameters(device, 1, scaled, 1)
    backward = vd.true_parameters(device, 1, scaled, -1)
    np.testing.assert_array_equal(forward.vector, vd.true_parameters(device, 1, virtual).vector)
    f = virtual.friction
    assert (backward.coulomb, backward.viscous, backward.quadratic) == (
        3.0 * f.coulomb,
        3.0 * f.viscous,
        3.0 * f.quadratic,
    )
    np.testing.assert_array_equal(backward.vector[:9], forward.vector[:9])  # all but friction
    # A forward braking never moves backward: bit for bit the symmetric rig's.
    assert_same_truth(
        vd.simulate_braking(device, 1, scaled, Direction.FORWARD),
        vd.simulate_braking(device, 1, virtual, Direction.FORWARD),
    )
    # A backward one loses more energy and stops sooner.
    assert (
        vd.simulate_braking(device, 1, scaled, Direction.BACKWARD).truth.end_time
        < vd.simulate_braking(device, 1, virtual, Direction.BACKWARD).truth.end_time
    )
    # The explicit [friction_backward] table with the same coefficients is the same rig.
    table = dataclasses.replace(
        virtual, friction_backward=Friction(3 * f.coulomb, 3 * f.viscous, 3 * f.quadratic)
    )
    np.testing.assert_array_equal(vd.true_parameters(device, 1, table, -1).vector, backward.vector)


@pytest.mark.parametrize("sign", [-1.0, 1.0])
def test_static_friction_is_that_of_the_direction_the_net_torque_pushes(device, virtual, sign):
    # Backward static friction 2 a1: a net torque of 1.5 a1 moves the body forward but
    # cannot move it backward (docs/method.md §4, with the coefficient of that direction).
    rig = with_friction(virtual, backward_scale=2.0)
    forward, backward = (vd.true_parameters(device, 1, rig, d) for d in (1, -1))
    a1 = forward.coulomb
    phi = 0.7
    u = static_torque(phi, forward) + sign * 1.5 * a1
    x = np.array([phi, 0.0])
    after = advance(x.copy(), u, device.encoder.dt, (forward.vector, backward.vector))
    if sign > 0:
        assert after[1] > 0.0 and after[0] > phi
    else:
        np.testing.assert_array_equal(after, x)


# --- fixture, empty fixture and true tare ----------------------------------------------------

FIXTURE = TrueBody(mass=0.5, inertia=[0.004, 0.005, 0.008, 2e-4, 1e-4, -3e-4], com=[0.01, 0, 0])


def combined(body: TrueBody, fixture: TrueBody) -> TrueBody:
    """One rigid body made of both: tensors about O add, the centre of mass is the mean."""
    mass = body.mass + fixture.mass
    com = (body.mass * body.com + fixture.mass * fixture.com) / mass
    return TrueBody(mass=mass, inertia=body.inertia + fixture.inertia, com=com)


def test_the_fixture_adds_its_inertia_and_weight(device, virtual):
    with_fixture = dataclasses.replace(virtual, fixture=FIXTURE)
    one_body = dataclasses.replace(virtual, body=combined(virtual.body, FIXTURE))
    a = vd.true_parameters(device, 1, with_fixture)
    b = vd.true_parameters(device, 1, one_body)
    # Equal to rounding: the gravity terms are sum m_i g x_i against (sum m_i) g x_mean.
    np.testing.assert_allclose(a.vector, b.vector, rtol=1e-14, atol=1e-17)
    assert a.vector[0] > vd.true_parameters(device, 1, virtual).vector[0]
    first = vd.simulate_braking(device, 1, with_fixture).truth
    second = vd.simulate_braking(device, 1, one_body).truth
    # Parameters equal to ~1e-16 relative: the trajectories agree far below the encoder's
    # resolution (1e-4 rad); over ~2 turns the difference stays ~1e-13 rad.
    assert len(first.t) == len(second.t)
    np.testing.assert_allclose(first.phi, second.phi, rtol=0, atol=1e-10)
    np.testing.assert_allclose(first.omega, second.omega, rtol=0, atol=1e-10)


def test_an_empty_fixture_run_has_only_the_fixture_and_the_tare(device, virtual):
    empty = dataclasses.replace(virtual, body=None, fixture=FIXTURE)
    alone = dataclasses.replace(virtual, body=FIXTURE)
    np.testing.assert_array_equal(
        vd.true_parameters(device, 1, empty).vector, vd.true_parameters(device, 1, alone).vector
    )
    bare = vd.true_parameters(device, 2, dataclasses.replace(virtual, body=None))
    np.testing.assert_array_equal(
        bare.inertia_harmonics, [device.stages[1].tare_inertia, 0, 0, 0, 0]
    )
    assert bare.gravity_sin == bare.gravity_cos == 0.0
    braking = vd.simulate_braking(device, 1, empty, Direction.BACKWARD)
    assert braking.truth.end_phi < braking.truth.phi[0]


def test_the_rigs_tare_replaces_device_tomls(device, virtual):
    tares = (0.01, 0.2)
    rig = dataclasses.replace(virtual, rig=Rig(tare_inertia=tares))
    for stage, tare in enumerate(tares, 1):
        st = dataclasses.replace(device.stages[stage - 1], tare_inertia=tare)
        stages = list(device.stages)
        stages[stage - 1] = st
        exact = dataclasses.replace(device, stages=tuple(stages))
        np.testing.assert_array_equal(
            vd.true_parameters(device, stage, rig).vector,
            vd.true_parameters(exact, stage, virtual).vector,
        )
    assert_same_truth(
        vd.simulate_braking(device, 1, rig),
        vd.simulate_braking(
            dataclasses.replace(
                device,
                stages=(dataclasses.replace(device.stages[0], tare_inertia=0.01), device.stages[1]),
            ),
            1,
            virtual,
        ),
    )


def test_a_tare_list_of_the_wrong_length_is_an_input_error(device, virtual):
    rig = dataclasses.replace(virtual, rig=Rig(tare_inertia=(0.01, 0.02, 0.03)))
    with pytest.raises(InputError) as error:
        vd.true_parameters(device, 1, rig)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith("virtual.toml: rig.tare_inertia:")
    assert "(2), got 3" in message


def test_direction_arguments_are_checked(device, virtual):
    with pytest.raises(ValueError, match="sign of Omega"):
        vd.true_parameters(device, 1, virtual, 0)
    forward = vd.simulate_braking(device, 1, virtual)
    with pytest.raises(ValueError, match="does not run backward"):
        vd.ideal_program(device, 1, virtual, forward, Direction.BACKWARD)
