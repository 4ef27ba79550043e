"""Pilot runs (rsp_inertia.virtual.device.simulate_pilot) and their fit (rsp_inertia.design.pilot.fit_pilot).

Every estimate is compared with the virtual device's truth (true_parameters), at the default
friction and at 30x its Coulomb and viscous terms (the coast then stops in 10 s on stage 1).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rsp_inertia.design.pilot import PILOT_UNKNOWNS, fit_pilot
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.logs import Log, read_log, write_log
from rsp_inertia.plant.model import dissipation
from rsp_inertia.virtual import device as vd
from tests.conftest import DEFAULTS

STAGES = (1, 2)
FRICTIONS = ("paper", "x30")

M0_SIGMAS = 3.0
"""M0 within this many of its stated std."""
M0_RELATIVE = 0.02
"""M0 within 2% of the truth: what experiment planning needs (measured: 0.03% or better)."""
A3_RELATIVE = 0.10
"""a3 within 10% (measured: 0.3% on stage 1, 2-4% on stage 2, whose 30 s coast covers only
3.2-3.5 rad/s, too narrow a speed range to split the friction torque among a1, a2 and a3
more finely: the stated std of a3 there is 17-24%, the scatter over release angles 2-3%)."""
NOISE_RELATIVE = 0.15
"""The torque noise within 15% of virtual.toml's (measured: within 3%)."""
FRICTION_TORQUE_RELATIVE = 0.01
"""The friction torque D over the coast's speeds within 1% of its value at the coast's top
speed: the combination of a1-a3 that the coast determines well even where their split is
loose (measured: within 0.03-0.3%). Not 1% of D at each speed: on stage 1 at the paper's
friction, D at 0.6 rad/s (5e-4 N m, mostly a1 and a2) comes out 5% low, as a1 and a2 are
only known to 135% and 42% (the coast spends its slow seconds below the fitted rows' 5%
of the top speed)."""


def _virtual(default_virtual, friction: str):
    if friction == "paper":
        return default_virtual
    f = default_virtual.friction
    scaled = dataclasses.replace(f, coulomb=30 * f.coulomb, viscous=30 * f.viscous)
    return dataclasses.replace(default_virtual, friction=scaled)


@pytest.fixture(scope="module")
def pilots(default_device, default_virtual):
    """(stage, friction) -> (virtual, SimulatedPass, PilotFit); ~8 s for the four."""
    out = {}
    for friction in FRICTIONS:
        virtual = _virtual(default_virtual, friction)
        for stage in STAGES:
            run = vd.simulate_pilot(default_device, stage, virtual)
            out[stage, friction] = (virtual, run, fit_pilot(default_device, stage, run.log))
    return out


@pytest.mark.parametrize("friction", FRICTIONS)
@pytest.mark.parametrize("stage", STAGES)
def test_pilot_protocol(stage, friction, default_device, pilots):
    virtual, run, _ = pilots[stage, friction]
    tr, log = run.truth, run.log
    st = default_device.stages[stage - 1]
    dt = default_device.encoder.dt
    command = vd.PILOT_TORQUE_FRACTION * default_device.motor.torque_limit
    np.testing.assert_allclose(log.t, np.arange(len(log)) * dt, rtol=0, atol=1e-12)
    assert tr.phi[0] == pytest.approx(math.radians(virtual.run.release_angle_deg))
    assert tr.omega[0] == 0.0
    # Powered until the first sample at the launch speed, then the motor is off.
    switch = int(np.argmax(tr.omega >= st.launch_speed))
    assert switch > 0 and tr.omega[switch - 1] < st.launch_speed
    np.testing.assert_array_equal(tr.torque[:switch], command / virtual.rig.torque_gain)
    np.testing.assert_array_equal(tr.torque[switch:], 0.0)
    assert np.std(log.torque[switch:]) == pytest.approx(virtual.run.torque_noise, rel=0.05)
    assert np.mean(log.torque[:switch]) == pytest.approx(command, abs=1e-5)
    # The coast: to rest (the log ends before the stop) or PILOT_MAX_COAST seconds.
    if tr.end_omega == 0.0:
        assert tr.t[-1] < tr.end_time <= tr.t[-1] + dt
        assert (tr.end_time - switch * dt) <= vd.PILOT_MAX_COAST
    else:
        assert tr.t[-1] - tr.t[switch] == pytest.approx(vd.PILOT_MAX_COAST)
        assert tr.end_time == tr.t[-1]
    assert np.all(tr.omega[1:] > 0.0)


def test_a_pilot_without_a_launch_speed_is_powered_for_its_turns(default_device, default_virtual):
    """A new rig's stage (no launch_speed before plan): the drive's known torque for
    PILOT_TURNS turns, then the coast; the fit still recovers M0 (the work, not the speed
    reached, fixes its scale)."""
    stage = dataclasses.replace(default_device.stages[0], launch_speed=None, braking_torque=None)
    device = dataclasses.replace(default_device, stages=(stage, *default_device.stages[1:]))
    run = vd.simulate_pilot(device, 1, default_virtual)
    tr = run.truth
    turns = (tr.phi - tr.phi[0]) / (2 * math.pi)
    switch = int(np.argmax(turns >= vd.PILOT_TURNS))
    assert switch > 0 and turns[switch - 1] < vd.PILOT_TURNS
    assert np.all(tr.torque[:switch] > 0.0) and np.all(tr.torque[switch:] == 0.0)
    M0 = vd.true_parameters(device, 1, default_virtual, 1.0).inertia_harmonics[0]
    assert fit_pilot(device, 1, run.log).M0 == pytest.approx(M0, rel=M0_RELATIVE)


def test_pilot_is_deterministic(default_device, default_virtual, pilots):
    again = vd.simulate_pilot(default_device, 1, default_virtual)
    first = pilots[1, "paper"][1].log
    for name in ("t", "phi", "torque"):
        np.testing.assert_array_equal(getattr(again.log, name), getattr(first, name))
    other = dataclasses.replace(
        default_virtual, run=dataclasses.replace(default_virtual.run, seed=1)
    )
    moved = vd.simulate_pilot(default_device, 1, other)
    assert not np.array_equal(moved.log.torque, first.torque)
    np.testing.assert_array_equal(moved.log.phi, first.phi)  # the noise is only the torque's


def test_pilot_file_round_trip(tmp_path, default_device, pilots):
    exp_dir = tmp_path / "exp"
    exp_dir.mkdir()
    (exp_dir / "device.toml").write_text((DEFAULTS / "device.toml").read_text())
    exp = open_experiment(exp_dir)
    path = exp.pilot_path(2)
    assert path == exp_dir / "stage2" / "pilot.csv"
    path.parent.mkdir()
    log = pilots[2, "paper"][1].log
    write_log(path, log)
    back = read_log(path, default_device.encoder, "braking")
    for name in ("t", "phi", "torque"):
        np.testing.assert_array_equal(getattr(back, name), getattr(log, name))


@pytest.mark.parametrize("friction", FRICTIONS)
@pytest.mark.parametrize("stage", STAGES)
def test_fit_pilot_recovers_the_inertia(stage, friction, default_device, pilots):
    virtual, _, fit = pilots[stage, friction]
    M0 = vd.true_parameters(default_device, stage, virtual, 1.0).inertia_harmonics[0]
    assert fit.M0_std > 0.0
    assert abs(fit.M0 - M0) <= M0_SIGMAS * fit.M0_std
    assert fit.M0 == pytest.approx(M0, rel=M0_RELATIVE)
    assert fit.model().inertia_harmonics[0] == fit.M0


@pytest.mark.parametrize("friction", FRICTIONS)
@pytest.mark.parametrize("stage", STAGES)
def test_fit_pilot_recovers_the_friction(stage, friction, default_device, pilots):
    virtual, run, fit = pilots[stage, friction]
    true = vd.true_parameters(default_device, stage, virtual, 1.0)
    assert fit.a3 == pytest.approx(true.quadratic, rel=A3_RELATIVE)
    assert min(fit.a1_std, fit.a2_std, fit.a3_std) > 0.0
    model = fit.model()
    assert (fit.a1, fit.a2, fit.a3) == (model.coulomb, model.viscous, model.quadratic)
    # The friction torque at the coast's speeds, whatever its split among a1, a2 and a3.
    tr = run.truth
    coast = tr.omega[tr.torque == 0.0]
    omega = np.linspace(max(0.05 * fit.top_speed, coast.min()), coast.max(), 50)
    D_true = dissipation(omega, true)
    np.testing.assert_allclose(
        dissipation(omega, model), D_true, rtol=0, atol=FRICTION_TORQUE_RELATIVE * D_true.max()
    )


@pytest.mark.parametrize("friction", FRICTIONS)
@pytest.mark.parametrize("stage", STAGES)
def test_fit_pilot_summary(stage, friction, default_device, pilots):
    virtual, run, fit = pilots[stage, friction]
    tr = run.truth
    assert fit.torque_noise == pytest.approx(virtual.run.torque_noise, rel=NOISE_RELATIVE)
    assert fit.top_speed == pytest.approx(tr.omega.max(), rel=1e-3)
    switch = int(np.argmax(tr.torque == 0.0))
    assert fit.coast_turns == pytest.approx((tr.phi[-1] - tr.phi[switch]) / (2 * math.pi), abs=1e-3)
    assert fit.duration == pytest.approx(tr.t[-1])
    model = fit.model()
    assert (model.stiffness, model.zero_angle) == (
        default_device.spring.stiffness,
        default_device.spring.zero_angle,
    )
    # Every unknown is fitted on a pilot this long: the harmonics and gravity are not left at 0.
    assert len(PILOT_UNKNOWNS) == 10
    assert np.all(model.inertia_harmonics != 0.0)
    assert model.gravity_sin != 0.0 and model.gravity_cos != 0.0


def _log(t, phi, torque) -> Log:
    return Log(t=t, phi=phi, torque=torque)


def test_a_free_spin_down_is_refused(default_device, pilots):
    log = pilots[1, "paper"][1].log
    zero = _log(log.t, log.phi, np.zeros(len(log)))
    with pytest.raises(InputError, match="stage1/pilot.csv: no powered part"):
        fit_pilot(default_device, 1, zero)
    switch = int(np.argmax(pilots[1, "paper"][1].truth.torque == 0.0))
    coast_only = _log(log.t[: len(log) - switch], log.phi[switch:], log.torque[switch:])
    with pytest.raises(InputError, match="powered"):
        fit_pilot(default_device, 1, coast_only, "coast.csv")


def test_a_short_coast_is_refused(default_device, pilots):
    run = pilots[1, "paper"][1]
    switch = int(np.argmax(run.truth.torque == 0.0))
    n = switch + 100  # 0.1 s of coast at 12 rad/s: 0.19 turns
    log = _log(run.log.t[:n], run.log.phi[:n], run.log.torque[:n])
    with pytest.raises(InputError, match=r"pilot.csv: the coast .* covers 0.19 turns"):
        fit_pilot(default_device, 1, log)


def test_a_drive_torque_of_the_wrong_sign_is_refused(default_device, pilots):
    log = pilots[1, "paper"][1].log
    flipped = _log(log.t, log.phi, -log.torque)
    with pytest.raises(InputError, match="not positive"):
        fit_pilot(default_device, 1, flipped)
