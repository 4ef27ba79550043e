"""A motor that warms with the heat its logged torque dissipates, no temperature logged
(device.toml ``[motor] winding_time_constant``, issue 37).

The fit's model: the torque's scale 1 + c m(t), m the magnets' rise that the logged torque's
squares drive through the winding's time constant and the magnets' lag, one c for the
experiment. Checked against the virtual device's own thermal model (its closed form, written
independently in rsp_inertia.virtual.thermal) and against the truth: c = alpha R_th R / k_t^2
of the virtual motor, and the tensor.
"""

import dataclasses

import numpy as np
import pytest

from rsp_inertia.estimation.balance import stage_balance, warming_work
from rsp_inertia.estimation.passes import estimate_pass
from rsp_inertia.estimation.tensor_fit import PASS_GAIN_SOURCE, fit_tensor
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import load_device, write_device
from rsp_inertia.plant.transducers import motor_rises
from rsp_inertia.virtual import device as vd
from rsp_inertia.virtual.config import placed_body
from rsp_inertia.virtual.thermal import MotorState, advance_motor

STAGES = (1, 2)
QUANTUM = None
"""Set from the default device (its encoder's quantum) by the runs' fixture."""
TAU_W, TAU_M = 60.0, 5.0
"""s, the virtual motor's winding time constant and magnets' lag (stated as such)."""


def _rig(virtual, **changes):
    return dataclasses.replace(virtual, rig=dataclasses.replace(virtual.rig, **changes))


def _modelled(device, tau_w=TAU_W, tau_m=TAU_M):
    motor = dataclasses.replace(
        device.motor, winding_time_constant=tau_w, temperature_lag=tau_m
    )
    return dataclasses.replace(device, motor=motor)


@pytest.mark.parametrize("tau_m", [None, 5.0, 60.0])
def test_the_fits_thermal_model_is_the_virtual_motors_closed_form(default_virtual, tau_m):
    # Uneven steps and a power that changes from step to step; the double root at 60 s.
    rng = np.random.default_rng(7)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.5e-3, 40.0, 60))])
    power = rng.uniform(0.0, 3.0, t.size - 1)
    rig = _rig(
        default_virtual, thermal_resistance=1.0, winding_time_constant=TAU_W,
        magnet_lag=tau_m or 0.0,
    )
    state = MotorState(0.3, 0.1)
    winding, magnet = [state.winding], [state.magnet]
    for p, h in zip(power, np.diff(t)):
        state = MotorState(*advance_motor(rig.rig, state, float(p), float(h)))
        winding.append(state.winding)
        magnet.append(state.magnet)
    w, m = motor_rises(power, t, TAU_W, tau_m, (0.3, 0.3 if not tau_m else 0.1))
    assert w == pytest.approx(winding, rel=1e-12, abs=1e-14)
    if tau_m:
        assert m == pytest.approx(magnet, rel=1e-9, abs=1e-12)
    else:
        assert np.array_equal(m, w)


def test_the_keys_round_trip_and_refuse_a_logged_temperatures_tempco(default_device, tmp_path):
    path = tmp_path / "device.toml"
    device = _modelled(default_device)
    device = dataclasses.replace(
        device, motor=dataclasses.replace(device.motor, reverse_delay=30.0)
    )
    write_device(path, device)
    assert load_device(path) == device
    text = path.read_text()
    path.write_text(
        text.replace("winding_time_constant", "# winding_time_constant", 1).replace(
            "temperature_lag", "# temperature_lag", 1
        )
    )
    with pytest.raises(InputError, match=r"motor\.reverse_delay.*winding_time_constant or"):
        load_device(path)
    path.write_text(
        text.replace("[motor]\n", "[motor]\ntorque_constant_tempco = -0.0011\n", 1)
    )
    with pytest.raises(InputError, match=r"motor\.winding_time_constant.*tempco"):
        load_device(path)


def _runs(device, virtual):
    global QUANTUM
    q = QUANTUM = device.encoder.quantum
    out = []
    for stage in STAGES:
        braking = vd.simulate_braking(device, stage, virtual)
        reverse = vd.simulate_ideal_reverse(device, stage, virtual, braking)
        b = estimate_pass(braking.log, q, "braking", constant_torque=True)
        r = estimate_pass(reverse.log, q, "reverse", sigma_torque=b.sigma_torque)
        out.append((b, r))
    return out


def _warming_motor(virtual, resistance):
    """NdFeB (-0.0011/K), 0.5 N m/A at phi, 4 K/W: a stage-2 drift of about 1e-3 at 14.65
    ohm (benchmarks.experiments.warming_motor)."""
    return _rig(
        virtual, torque_constant_tempco=-0.0011, torque_constant=0.5,
        winding_resistance=resistance, thermal_resistance=4.0,
        winding_time_constant=TAU_W, magnet_lag=TAU_M,
    )


@pytest.fixture(scope="module")
def warming_runs(default_device, default_virtual):
    virtual = _warming_motor(default_virtual, 14.65)
    return virtual, _runs(_modelled(default_device), virtual)


def test_the_warming_column_is_what_the_warmed_torque_adds_to_the_work(warming_runs):
    # The work is linear in the torque: the reverse's logged torque scaled by 1 + eps m over
    # each step (m the modelled rise, from where the braking left the motor) moves its work
    # at every angle by eps times its weighted work (up to eps^2: m itself moves with u^2).
    _, runs = warming_runs
    b, r = runs[1]
    phi = np.linspace(r.log.phi[-1], r.log.phi[0], 400)[5:-5]
    _, _, end = warming_work(b, b.sample_at(phi), (0.0, 0.0), TAU_W, TAU_M)
    a = r.sample_at(phi)
    parts, _, _ = warming_work(r, a, end, TAU_W, TAU_M)
    u = np.asarray(r.log.torque, dtype=float)
    heat = np.maximum(u[:-1] ** 2 - r.sigma_torque**2, 0.0)
    _, m = motor_rises(heat, r.log.t, TAU_W, TAU_M, end)
    eps = 1e-4
    scaled = u.copy()
    scaled[:-1] *= 1.0 + eps * 0.5 * (m[:-1] + m[1:])
    r2 = estimate_pass(
        dataclasses.replace(r.log, torque=scaled), QUANTUM, "reverse", sigma_torque=r.sigma_torque
    )
    moved = (r2.sample_at(phi).work - a.work) / eps
    column = parts.sum(axis=1)
    assert moved == pytest.approx(column, rel=1e-3, abs=1e-3 * np.abs(column).max())
    # Its back-driven part: the rows where the body drives the motor (none in a reverse).
    assert np.allclose(parts[:, 1], 0.0)


def test_a_warming_motor_is_measured_through_without_a_temperature_log(
    default_device, warming_runs
):
    virtual, runs = warming_runs
    device = _modelled(default_device)
    fit = fit_tensor([stage_balance(device, s, b, r) for s, (b, r) in zip(STAGES, runs)])
    rig = virtual.rig
    c_true = (
        rig.torque_constant_tempco * rig.thermal_resistance * rig.winding_resistance
        / rig.torque_constant**2
    )
    c, c_std = fit.warming
    assert abs(c - c_true) < 3 * c_std
    assert c_std < 0.05 * abs(c_true)
    truth = placed_body(device, virtual).inertia
    std = np.sqrt(np.diag(fit.entries_cov))
    assert np.all(np.abs(fit.entries - truth) < 3 * std)
    assert np.all(np.abs(fit.entries - truth) < 1e-4 * truth[:3].max())
    # The drift it implies in stage 2 (the benchmark's 1e-3 between the passes' means).
    assert -1.6e-3 < fit.warming_drift[1, 0] < -1.0e-3
    assert PASS_GAIN_SOURCE in fit.cov_parts
    # The fitted line: what fitting c adds to the noise's share, most of Jx's and Jy's stds
    # here (stage 2's axes, the hot stage, carry them); on an entry c barely touches (a product) it may dip below zero by a fraction of
    # that entry's variance, which the budget shows as 0.
    fitted = np.diag(fit.cov_parts[PASS_GAIN_SOURCE])[:6]
    total = np.diag(fit.cov)[:6]
    assert np.all(fitted[:2] > 0.5 * total[:2])
    assert np.all(fitted > -0.2 * total)
    assert not any(t.significant for t in fit.tests if t.kind)


def test_a_clean_motor_modelled_as_warming_gives_c_zero_and_the_tensor(
    default_device, default_virtual
):
    device = _modelled(default_device)
    runs = _runs(device, default_virtual)
    fit = fit_tensor([stage_balance(device, s, b, r) for s, (b, r) in zip(STAGES, runs)])
    c, c_std = fit.warming
    assert abs(c) < 3 * c_std
    truth = placed_body(device, default_virtual).inertia
    std = np.sqrt(np.diag(fit.entries_cov))
    assert np.all(np.abs(fit.entries - truth) < 3 * std)


@pytest.mark.slow
def test_the_calibrated_rig_with_a_warming_motor_measures_it_in_every_folder(tmp_path):
    """The demo's rig (every imperfection, closed loop), its empty, reference and body folders
    all with the virtual warming motor (1e-3), no temperature logged, the time constants
    stated: calibrate and identify each fit c, each within 3 stds of the motor's, and the
    tensor within 3 stds and 1e-4 of the largest moment."""
    from benchmarks.experiments import closed_loop, load, warming_motor, write
    from rsp_inertia import api
    from rsp_inertia.infra.progress import drop, lines_to
    from rsp_inertia.plant.experiment import open_experiment
    from rsp_inertia.scenarios import create_rig_experiment
    from rsp_inertia.virtual.config import experiment_virtual

    folders = create_rig_experiment(tmp_path / "rig")
    for folder in folders:
        device, virtual = load(folder)
        write(folder, _modelled(device), warming_motor(virtual, 1e-3))
    with lines_to(drop):
        for folder in folders:
            closed_loop(folder)
        calibration = api.calibrate(*folders)
        result = api.identify(folders[0])
    exp = open_experiment(folders[0])
    rig = experiment_virtual(exp).rig
    c_true = (
        rig.torque_constant_tempco * rig.thermal_resistance * rig.winding_resistance
        / rig.torque_constant**2
    )
    for c, std in (calibration.calibration.warming, result.identification.warming):
        assert abs(c - c_true) < 3 * std
    truth = placed_body(exp.device, experiment_virtual(exp)).inertia
    err = np.asarray(result.entries) - truth
    assert np.all(np.abs(err) < 3 * np.asarray(result.entries_std))
    assert np.all(np.abs(err) < 1e-4 * truth[:3].max())
