"""The virtual motor whose torque constant follows its magnets' temperature
(rsp_inertia.virtual.thermal, virtual.toml ``[rig]``): the thermal model against its ODE, the
torque scale row by row, the energy balance of a braking whose torque drifts, the logged
temperature, and the defaults leaving every pass as it was."""

import dataclasses

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rsp_inertia.plant.config import load_device, write_device
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.logs import read_device_log
from rsp_inertia.plant.model import dissipation, mechanical_energy
from rsp_inertia.plant.transducers import delivered_torque
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual import device as vd
from rsp_inertia.virtual.config import load_virtual, write_virtual
from rsp_inertia.virtual.integrate import advance, true_pair
from rsp_inertia.virtual.thermal import (
    COLD,
    TEMPERATURE_QUANTUM,
    MotorState,
    advance_motor,
    heating_power,
)
from tests.virtual.test_device import braking_speed_at

ALPHA = -0.0011  # 1/K, NdFeB


def with_rig(virtual, **changes):
    return dataclasses.replace(virtual, rig=dataclasses.replace(virtual.rig, **changes))


def hot(virtual, resistance=300.0, lag=5.0, tempco=ALPHA):
    """A motor that heats fast: on stage 2 (0.12 N m, 0.24 A at 0.5 N m/A) 17 W, tens of
    kelvin (17 K in the magnets) within the braking, so that every effect is far above the integrator's error."""
    return with_rig(
        virtual,
        torque_constant_tempco=tempco,
        torque_constant=0.5,
        winding_resistance=resistance,
        thermal_resistance=4.0,
        winding_time_constant=60.0,
        magnet_lag=lag,
    )


def ode(rig, state, power, h):
    """The two-node model integrated numerically (an independent truth for the closed form)."""

    def f(_, y):
        w, m = y
        dm = (w - m) / rig.magnet_lag if rig.magnet_lag > 0 else 0.0
        return [(power * rig.thermal_resistance - w) / rig.winding_time_constant, dm]

    sol = solve_ivp(
        f, (0.0, max(h)), [state.winding, state.magnet], t_eval=h, rtol=1e-12, atol=1e-12,
        method="DOP853",
    )
    return sol.y


@pytest.mark.parametrize("lag", [5.0, 60.0, 60.0 * (1 + 1e-12), 200.0])
def test_the_closed_form_is_the_models_solution(virtual, lag):
    # The step response from a warm start, the double root tau_m = tau_w (and next to it)
    # included; solve_ivp at 1e-12 tolerances is the truth.
    rig = hot(virtual, lag=lag).rig
    start = MotorState(winding=3.0, magnet=1.0)
    h = np.linspace(0.0, 600.0, 61)
    w, m = advance_motor(rig, start, 2.5, h)
    w_ref, m_ref = ode(rig, start, 2.5, h)
    np.testing.assert_allclose(w, w_ref, atol=1e-8)
    np.testing.assert_allclose(m, m_ref, atol=1e-8)


def test_the_winding_settles_at_p_times_r_th_along_the_first_order_step(virtual):
    rig = hot(virtual).rig
    power = heating_power(rig, 0.12)
    assert power == pytest.approx((0.12 / 0.5) ** 2 * 300.0)  # I^2 R
    tau = rig.winding_time_constant
    w, _ = advance_motor(rig, COLD, power, np.array([tau, 3 * tau, 50 * tau]))
    steady = power * rig.thermal_resistance
    np.testing.assert_allclose(w, steady * (1 - np.exp([-1.0, -3.0, -50.0])), rtol=1e-14)
    assert w[-1] == pytest.approx(steady, rel=1e-15)


def test_the_magnets_lag_a_ramp_by_their_time_constant(virtual):
    # A winding time constant of 1e9 s makes the winding's rise a ramp r t over minutes; the
    # magnets then follow r (t - tau_m (1 - exp(-t / tau_m))): tau_m behind.
    lag = 7.0
    rig = with_rig(hot(virtual, lag=lag), winding_time_constant=1e9).rig
    power = 1e8  # W: r = P R_th / tau_w = 0.4 K/s
    r = power * rig.thermal_resistance / rig.winding_time_constant
    t = np.array([1.0, 7.0, 20.0, 100.0])
    w, m = advance_motor(rig, COLD, power, t)
    # The ramp's curvature over 100 s: r t^2 / (2 tau_w) = 2e-6 K.
    np.testing.assert_allclose(w, r * t, atol=1e-4)
    np.testing.assert_allclose(m, r * (t - lag * (1 - np.exp(-t / lag))), atol=1e-4)
    assert (w - m)[-1] == pytest.approx(r * lag, rel=1e-4)


def test_the_defaults_leave_every_pass_as_it_was(default_device, virtual):
    # alpha = 0 with a winding that heats, and a pass on the default rig, are today's passes
    # bit for bit; only the logged temperature differs.
    base = vd.simulate_braking(default_device, 1, virtual)
    heated = hot(virtual, tempco=0.0)
    braking = vd.simulate_braking(default_device, 1, heated)
    assert base.truth.winding is None and base.log.temperature is None
    assert base.truth.end_motor == COLD
    for name in ("t", "phi", "torque"):
        assert np.array_equal(getattr(base.log, name), getattr(braking.log, name))
        assert np.array_equal(getattr(base.truth, name), getattr(braking.truth, name))
    assert braking.truth.end_motor.winding > 0.0
    reverse = vd.simulate_ideal_reverse(default_device, 1, heated, braking)
    base_reverse = vd.simulate_ideal_reverse(default_device, 1, virtual, base)
    for name in ("t", "phi", "torque"):
        assert np.array_equal(getattr(base_reverse.log, name), getattr(reverse.log, name))
        assert np.array_equal(getattr(base_reverse.truth, name), getattr(reverse.truth, name))


def test_a_prescribed_offset_scales_the_reverse_torque_exactly(default_device, virtual):
    # No heating, the whole motor dT warmer in the reverse: the closed-loop reverse's body
    # receives (1 + alpha dT) times what today's drive delivers for each command, row by row.
    dT = 2.0
    offset = with_rig(virtual, torque_constant_tempco=ALPHA, reverse_temperature_offset=dT)
    braking = vd.simulate_braking(default_device, 1, offset)
    assert np.array_equal(braking.log.torque, vd.simulate_braking(default_device, 1, virtual).log.torque)
    program = vd.ideal_program(default_device, 1, offset, braking)
    reverse = vd.run_program(default_device, 1, offset, program, (braking.truth.end_phi, 0.0))
    truth = reverse.truth
    moving = truth.omega != 0.0
    today = delivered_torque(reverse.log.torque, np.sign(truth.omega), virtual.rig.drive_gains)
    assert np.count_nonzero(moving) > 1000
    np.testing.assert_allclose(
        truth.torque[moving], (1 + ALPHA * dT) * today[moving], rtol=1e-15, atol=0.0
    )
    np.testing.assert_array_equal(truth.magnet, dT)
    # The logged temperature is the ambient plus the offset, within the sensor's noise.
    rig = offset.rig
    assert np.all(np.abs(reverse.log.temperature - (rig.ambient_temperature + dT))
                  <= 6 * rig.temperature_noise + TEMPERATURE_QUANTUM / 2)


@pytest.fixture(scope="module")
def warm_braking(default_device, virtual):
    return vd.simulate_braking(default_device, 2, hot(virtual))


def test_a_warming_braking_closes_its_energy_balance_on_the_drifting_torque(
    default_device, virtual, warm_braking
):
    # docs/method.md §3 on stage 2's braking whose magnets warm by tens of kelvin: the energy
    # change is the work of the torque the body receives, sample by sample (each held over
    # its sample), plus the friction's. The constant command's work leaves a gap: the
    # integral of the torque's change, by which the warm motor brakes less.
    warm = hot(virtual)
    truth = warm_braking.truth
    assert truth.magnet[-1] > 15.0  # K: a torque 1.9% weaker at the end
    params = vd.true_parameters(default_device, 2, warm)
    pair = true_pair(default_device, 2, warm)
    t = np.append(truth.t, truth.end_time)
    phi = np.append(truth.phi, truth.end_phi)
    omega = np.append(truth.omega, 0.0)
    dphi = np.diff(phi)
    energy_change = mechanical_energy(phi[-1], 0.0, params) - mechanical_energy(
        phi[0], omega[0], params
    )
    h = np.diff(t)
    middle = np.array(
        [advance(np.array([p, w]), u, dh / 2, pair)
         for p, w, u, dh in zip(phi, omega, truth.torque, h)]
    )

    def power(w):
        return np.asarray(dissipation(w, params, direction=1.0)) * w

    friction_work = -np.sum(h / 6 * (power(omega[:-1]) + 4 * power(middle[:, 1]) + power(omega[1:])))
    delivered_work = np.sum(truth.torque * dphi)
    constant_work = np.sum(truth.torque[0] * dphi)
    # RK4 at dt/8 over 22 s: ~1e-12 relative on the ~0.6 J exchanged (the cold braking's
    # own balance, tests/plant/test_transducers.py, closes to 1e-11 J).
    assert energy_change == pytest.approx(delivered_work + friction_work, abs=1e-9)
    gap = delivered_work - constant_work  # > 0: the braking torque weakens as it warms
    assert gap > 1e-3
    np.testing.assert_allclose(
        truth.torque, truth.torque[0] * (1 + ALPHA * truth.magnet), rtol=1e-15
    )


def test_a_warming_braking_decays_slower_and_runs_further(default_device, virtual, warm_braking):
    cold = vd.simulate_braking(default_device, 2, virtual)
    warm = warm_braking
    assert warm.truth.end_time > cold.truth.end_time
    assert warm.truth.end_phi > cold.truth.end_phi
    # At the same angle the warm body is faster once the magnets have warmed.
    phi = cold.truth.phi[len(cold.truth.phi) // 2 :: 1000]
    assert np.all(braking_speed_at(warm, phi) > braking_speed_at(cold, phi))


def test_the_log_records_the_winding_and_the_reverse_starts_where_the_braking_left(
    default_device, virtual, warm_braking
):
    warm = hot(virtual)
    rig = warm.rig
    truth, log = warm_braking.truth, warm_braking.log
    expected = rig.ambient_temperature + truth.winding
    # The sensor's noise (0.05 K) then the 0.1 K rounding: within 6 sigma + half a step.
    assert np.all(np.abs(log.temperature - expected) <= 6 * rig.temperature_noise + 0.05)
    assert np.mean(log.temperature - expected) == pytest.approx(0.0, abs=0.01)
    assert np.allclose(np.round(log.temperature / 0.1) * 0.1, log.temperature, atol=1e-12)
    # The magnets, never logged, trail the winding while it warms.
    assert np.all(truth.magnet[1:] < truth.winding[1:])
    reverse = vd.simulate_ideal_reverse(default_device, 2, warm, warm_braking)
    assert reverse.truth.winding[0] == warm_braking.truth.end_motor.winding
    assert reverse.truth.magnet[0] == warm_braking.truth.end_motor.magnet
    # The ideal reverse still mirrors the drifting braking (its program follows the torque).
    mirror = braking_speed_at(warm_braking, reverse.truth.phi)
    assert np.abs(-reverse.truth.omega - mirror).max() < 1e-5


def test_the_logs_temperature_column_carries_the_winding(tmp_path):
    # Through the files: device.toml names a temperature column; simulate writes the winding's
    # temperature there, rising through the braking and on through the reverse, which starts
    # where the braking left the motor.
    root = create_default_experiment(tmp_path / "exp")
    device = load_device(root / "device.toml")
    device = dataclasses.replace(
        device, log=dataclasses.replace(device.log, temperature_column="temperature")
    )
    write_device(root / "device.toml", device)
    virtual = load_virtual(root / "virtual.toml")
    write_virtual(root / "virtual.toml", hot(virtual, resistance=30.0))
    simulate(root, stage=2, part="braking")
    simulate(root, stage=2, part="reverse", ideal=True)
    exp = open_experiment(root)
    forward = Direction.FORWARD
    braking = read_device_log(exp.braking_path(2, forward), exp.device, "braking", forward)
    reverse = read_device_log(exp.reverse_path(2, forward), exp.device, "reverse", forward)
    warm = hot(virtual, resistance=30.0)
    truth = vd.simulate_braking(exp.device, 2, warm)
    np.testing.assert_array_equal(braking.temperature, truth.log.temperature)
    rig = warm.rig
    assert braking.temperature[0] == pytest.approx(rig.ambient_temperature, abs=0.3)
    rise = truth.truth.end_motor.winding  # K, 2.2 K at 30 ohm
    assert braking.temperature[-1] - braking.temperature[0] == pytest.approx(rise, abs=0.35)
    assert reverse.temperature[0] == pytest.approx(rig.ambient_temperature + rise, abs=0.3)
    assert reverse.temperature[-1] > reverse.temperature[0] + 1.0


def test_a_warming_motor_on_a_drive_that_jitters_drops_and_holds(default_device, virtual):
    # The logger's imperfections cut and extend the rows; the temperature follows the rows.
    rough = dataclasses.replace(
        hot(virtual),
        logger=dataclasses.replace(
            virtual.logger, time_jitter=0.2, dropped_fraction=0.1, hold_after_stop=0.5
        ),
    )
    braking = vd.simulate_braking(default_device, 1, rough)
    assert len(braking.log.temperature) == len(braking.log)
    assert len(braking.truth.magnet) == len(braking.truth.t)
    reverse = vd.simulate_ideal_reverse(default_device, 1, rough, braking)
    assert len(reverse.log.temperature) == len(reverse.log)
    gains = rough.rig.drive_gains
    moving = reverse.truth.omega != 0.0
    today = delivered_torque(reverse.log.torque, np.sign(reverse.truth.omega), gains)
    factor = 1 + ALPHA * reverse.truth.magnet
    np.testing.assert_allclose(reverse.truth.torque[moving], (factor * today)[moving], rtol=1e-13)


def test_runs_start_warmer_by_the_rise_and_cool_as_the_model_says(default_device, virtual):
    # No heating, magnets at the winding: run k (stage k + 1 of the default device, forward
    # only) starts k dT above the ambient and cools along dT k exp(-t / tau_w), and the body
    # receives the cold run's torque times 1 + alpha (T_magnet - ambient), row by row.
    dT = 3.0
    rig = {"torque_constant_tempco": ALPHA, "winding_time_constant": 60.0}
    cold = with_rig(virtual, **rig)
    warm = with_rig(virtual, run_start_rise=dT, **rig)
    first = vd.simulate_braking(default_device, 1, warm)
    assert np.array_equal(first.truth.magnet, np.zeros(len(first.truth.t)))
    assert np.array_equal(first.log.torque, vd.simulate_braking(default_device, 1, cold).log.torque)
    second = vd.simulate_braking(default_device, 2, warm)
    truth = second.truth
    np.testing.assert_allclose(truth.magnet, dT * np.exp(-truth.t / 60.0), rtol=1e-12, atol=0.0)
    base = vd.simulate_braking(default_device, 2, virtual).truth.torque[0]
    np.testing.assert_allclose(truth.torque, base * (1 + ALPHA * truth.magnet), rtol=1e-14)
    # The log records it: the ambient plus the rise, within the sensor's noise.
    T = second.log.temperature
    assert abs(T[0] - (warm.rig.ambient_temperature + dT)) <= (
        6 * warm.rig.temperature_noise + TEMPERATURE_QUANTUM / 2
    )
    # The reverse starts where the braking left the motor.
    assert truth.end_motor.magnet == pytest.approx(dT * np.exp(-truth.end_time / 60.0), rel=1e-12)
