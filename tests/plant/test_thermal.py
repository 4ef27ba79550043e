"""The torque constant's temperature compensation (plant/transducers.py, plant/logs.py,
device.toml [motor]): the magnets' lag against its closed-form responses and an ODE solver,
the factor, the log it scales, and the keys' rules."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import load_device
from rsp_inertia.plant.logs import Log, compensate_temperature
from rsp_inertia.plant.transducers import magnet_temperature, thermal_torque_factor
from tests.plant.test_config import DEVICE_TOML, assert_one_line, edited, write

TAU = 5.0
"""s, the magnets' lag in these tests."""


def irregular_stamps(n: int, seed: int = 3) -> np.ndarray:
    """Increasing time stamps with steps from 1 ms to 0.5 s (dropped samples, a slow logger)."""
    rng = np.random.default_rng(seed)
    return np.concatenate([[0.0], np.cumsum(rng.uniform(1e-3, 0.5, n - 1))])


def test_the_lag_follows_a_ramp_as_its_closed_form_on_irregular_stamps():
    # T = T0 + r t from T_mag(0) = T0: T_mag = T0 + r t - r tau (1 - exp(-t / tau)).
    t = irregular_stamps(400)
    T0, r = 30.0, 0.05
    got = magnet_temperature(T0 + r * t, t, TAU)
    want = T0 + r * t - r * TAU * (1.0 - np.exp(-t / TAU))
    # Exact but for rounding: a few ulp of 40 C per step, summed over 400 steps.
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-11)


def test_the_lag_follows_a_step_as_its_closed_form():
    # T steps from T0 to T1 within 1 ns at t = 0, then holds: T_mag = T1 - (T1 - T0) exp(-t /
    # tau), to the ramp's 1 ns / tau of the step.
    t = np.concatenate([[0.0, 1e-9], 1e-9 + irregular_stamps(200)[1:]])
    T0, T1 = 20.0, 35.0
    T = np.where(t > 0.0, T1, T0)
    got = magnet_temperature(T, t, TAU)
    want = T1 - (T1 - T0) * np.exp(-t / TAU)
    np.testing.assert_allclose(got, want, rtol=0, atol=(T1 - T0) * 1e-9 / TAU + 1e-12)


def test_the_lag_agrees_with_an_ode_solver_on_a_wandering_trace():
    t = irregular_stamps(120, seed=8)
    T = 25.0 + 3.0 * np.sin(t / 7.0) + 0.5 * np.cos(t / 1.3)

    def rate(s, y):
        return [(np.interp(s, t, T) - y[0]) / TAU]

    # The solver steps inside each interval where T is linear (a kink at every stamp).
    solved = solve_ivp(rate, (t[0], t[-1]), [T[0]], t_eval=t, rtol=1e-11, atol=1e-11,
                       max_step=float(np.min(np.diff(t))))
    np.testing.assert_allclose(magnet_temperature(T, t, TAU), solved.y[0], rtol=0, atol=1e-7)


def test_without_a_lag_the_magnets_are_at_the_logged_temperature():
    t = irregular_stamps(10)
    T = 20.0 + t
    np.testing.assert_array_equal(magnet_temperature(T, t, None), T)


def test_the_factor_is_one_plus_alpha_times_the_magnets_rise_over_the_reference():
    t = irregular_stamps(50)
    T = 30.0 + 0.1 * t
    factor = thermal_torque_factor(T, t, -0.0011, TAU, 23.0)
    np.testing.assert_allclose(factor, 1.0 - 0.0011 * (magnet_temperature(T, t, TAU) - 23.0),
                               rtol=0, atol=1e-15)
    assert math.isclose(factor[0], 1.0 - 0.0011 * 7.0, rel_tol=1e-15)


class Motor:
    """A device.toml [motor] of the compensation's keys alone."""

    torque_constant_tempco = -0.0011
    torque_constant_tempco_std = None
    temperature_lag = TAU
    reference_temperature = 23.0


def test_a_log_is_scaled_row_by_row_and_left_alone_without_a_temperature_or_tempco():
    t = np.arange(6) * 1e-3
    log = Log(t=t, phi=t * 3.0, torque=np.full(6, 0.02), temperature=np.full(6, 33.0))
    scaled = compensate_temperature(log, Motor)
    np.testing.assert_allclose(scaled.torque, 0.02 * (1.0 - 0.0011 * 10.0), rtol=1e-15)
    np.testing.assert_array_equal(scaled.phi, log.phi)
    np.testing.assert_array_equal(scaled.temperature, log.temperature)
    # No temperature logged, or no tempco stated: the very same log (bit for bit).
    bare = Log(t=t, phi=t * 3.0, torque=np.full(6, 0.02))
    assert compensate_temperature(bare, Motor) is bare

    class NoTempco(Motor):
        torque_constant_tempco = None

    assert compensate_temperature(log, NoTempco) is log


TEMPCO = """torque_constant_tempco = -0.0011
torque_constant_tempco_std = 1e-4
temperature_lag = 5.0
reference_temperature = 23.0
"""
RATE = "torque_rate_limit = 20.0     # N m/s, |du/dt| <= this\n"
LOGGED = RATE + TEMPCO + "\n[log]\ntemperature_column = 'T'\n"


def test_the_tempcos_keys_load(tmp_path):
    device = load_device(write(tmp_path, "device.toml", edited(DEVICE_TOML, RATE, LOGGED)))
    motor = device.motor
    assert (motor.torque_constant_tempco, motor.torque_constant_tempco_std) == (-0.0011, 1e-4)
    assert (motor.temperature_lag, motor.reference_temperature) == (5.0, 23.0)


@pytest.mark.parametrize(
    "new, key, fault",
    [
        pytest.param(RATE + TEMPCO, "motor.torque_constant_tempco", "log.temperature_column",
                     id="no temperature logged"),
        pytest.param(LOGGED.replace("reference_temperature = 23.0\n", ""),
                     "motor.torque_constant_tempco", "needs motor.reference_temperature",
                     id="no reference"),
        pytest.param(RATE + "temperature_lag = 5.0\n", "motor.temperature_lag",
                     "needs motor.torque_constant_tempco", id="a lag without a tempco"),
        pytest.param(RATE + "torque_constant_tempco_std = 1e-4\n",
                     "motor.torque_constant_tempco_std", "needs motor.torque_constant_tempco",
                     id="a std without a tempco"),
        pytest.param(RATE + "reference_temperature = 23.0\n", "motor.reference_temperature",
                     "needs motor.torque_constant_tempco", id="a reference without a tempco"),
        pytest.param(LOGGED.replace("lag = 5.0", "lag = 0.0"), "motor.temperature_lag",
                     "must be > 0", id="a zero lag"),
        pytest.param(LOGGED.replace("tempco = -0.0011", "tempco = -0.11"),
                     "motor.torque_constant_tempco", "-0.11 %/K is -0.0011",
                     id="a tempco in percent"),
        pytest.param(RATE + "torque_constant_drift_std = 0.02\n",
                     "motor.torque_constant_drift_std", "0.02 % is 0.0002",
                     id="a drift's std in percent"),
        pytest.param(RATE + "torque_constant_drift_std = -1e-4\n",
                     "motor.torque_constant_drift_std", "within [0, 0.01]",
                     id="a negative drift's std"),
    ],
)
def test_inconsistent_tempco_keys_are_one_line(tmp_path, new, key, fault):
    path = write(tmp_path, "device.toml", edited(DEVICE_TOML, RATE, new))
    with pytest.raises(InputError) as error:
        load_device(path)
    assert_one_line(error, str(path), key, fault)


def test_a_drifts_std_loads_without_a_temperature(tmp_path):
    path = write(tmp_path, "device.toml",
                 edited(DEVICE_TOML, RATE, RATE + "torque_constant_drift_std = 2e-4\n"))
    assert load_device(path).motor.torque_constant_drift_std == 2e-4


def test_calibrate_says_in_one_line_that_the_tempco_stays_device_tomls():
    # Two runs' logs whose magnets sit at 24 and 26 C (no lag in these constant traces).
    from types import SimpleNamespace

    from rsp_inertia.estimation.reading import tempco_line

    t = np.arange(4) * 1e-3

    def log(T):
        return Log(t=t, phi=t, torque=np.zeros(4), temperature=np.full(4, T))

    logs = SimpleNamespace(runs={(1, "f"): (log(24.0), log(26.0))})
    line = tempco_line(Motor, [logs, None])
    assert "\n" not in line
    for part in ("does not estimate", "-0.0011", "reference_temperature = 23 C",
                 "24.00 to 26.00 C, mean 25.00 C"):
        assert part in line, line

    class NoTempco(Motor):
        torque_constant_tempco = None

    assert tempco_line(NoTempco, [logs]) == ""


def test_calibrates_tempco_line_says_what_the_runs_measured_or_why_it_is_kept():
    # The runs' information on alpha against the stated prior's (rsp_inertia.estimation
    # .tempco): var_post = 1 / (1 / var_prior + 1 / var_data).
    from types import SimpleNamespace

    from rsp_inertia.estimation.reading import tempco_line
    from rsp_inertia.estimation.tempco import TempcoFit

    t = np.arange(4) * 1e-3
    logs = SimpleNamespace(runs={(1, "f"): (
        Log(t=t, phi=t, torque=np.zeros(4), temperature=np.full(4, 24.0)),
        Log(t=t, phi=t, torque=np.zeros(4), temperature=np.full(4, 29.0)),
    )})

    class Stated(Motor):
        torque_constant_tempco_std = 1e-4

    def fit(data_std):
        post = 1.0 / math.sqrt(1.0 / 1e-4**2 + 1.0 / data_std**2)
        return TempcoFit(stated=-0.0011, stated_std=1e-4, estimate=-0.0009, std=post)

    measured = fit(2e-5)
    assert measured.informed and measured.data_std == pytest.approx(2e-5, rel=1e-9)
    line = tempco_line(Stated, [logs], measured)
    assert "\n" not in line
    for part in ("measured by the calibration runs", f"alpha = -0.0009 +- {measured.std:.2g} /K",
                 "5.00 K of magnet temperature", "device.toml's -0.0011 +- 0.0001 /K"):
        assert part in line, line
    # Information equal to the prior's: the posterior variance half the prior's, not enough.
    weak = fit(1e-4)
    assert not weak.informed
    line = tempco_line(Stated, [logs], weak)
    would = "would determine it to +- 0.0001 /K against device.toml's +- 0.0001 /K"
    for part in ("span only 5.00 K", would, "-0.0011 /K is kept"):
        assert part in line, line


def test_a_reverses_magnets_start_where_its_braking_left_them():
    # The braking's temperature a ramp from rest: its magnets end -r tau (1 - exp(-t/tau))
    # behind it; a reverse after a pause d starts that times exp(-d / tau) behind its own first
    # temperature, and through a held temperature the lag decays as exp(-t / tau).
    from types import SimpleNamespace

    from rsp_inertia.plant.logs import reverse_start_lag

    t = irregular_stamps(300)
    r = 0.04
    braking = Log(t=t, phi=t.copy(), torque=np.zeros_like(t), temperature=30.0 + r * t)
    end = -r * TAU * (1.0 - math.exp(-t[-1] / TAU))
    for delay, decay in ((None, 1.0), (0.0, 1.0), (7.0, math.exp(-7.0 / TAU))):
        motor = SimpleNamespace(temperature_lag=TAU, reverse_delay=delay)
        assert reverse_start_lag(braking, motor) == pytest.approx(end * decay, abs=1e-11)
    assert reverse_start_lag(braking, SimpleNamespace(temperature_lag=None, reverse_delay=None)) == 0.0
    held = np.full(t.size, 31.0)
    np.testing.assert_allclose(
        magnet_temperature(held, t, TAU, start_lag=end), 31.0 + end * np.exp(-t / TAU),
        rtol=0, atol=1e-12,
    )
