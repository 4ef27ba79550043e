"""A torque scale that differs between the passes, identified with a two-level braking.

The virtual device's braking switches its torque once (device.toml ``braking_torque_2``,
``braking_switch_turns``); the braking's estimate finds the switch in the logged torque; the
tensor fit takes one pass gain d per two-level run. Checked against the virtual truth and, for
the identifiability, against a design built here by hand from the balance's closed form.
"""

import dataclasses
import math

import numpy as np
import pytest

from rsp_inertia.design.candidates import StageModel, evaluate
from rsp_inertia.estimation.axes import axis_values
from rsp_inertia.estimation.balance import stage_balance
from rsp_inertia.estimation.passes import estimate_pass
from rsp_inertia.estimation.predict import combine_information
from rsp_inertia.estimation.tensor_fit import PASS_GAIN_SOURCE, fit_tensor
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import load_device, write_device
from rsp_inertia.plant.geometry import device_design
from rsp_inertia.plant.logs import switch_row
from rsp_inertia.virtual import device as vd
from rsp_inertia.virtual.config import placed_body
from rsp_inertia.virtual.integrate import true_parameters

PROTOCOL = ((1.0, 20.0, 2.0), (0.0, 2.0, 9.0))
"""Per stage (A, B, TURNS): A x the stage's braking_torque for TURNS turns, then B x it
(benchmarks/pass_gain.py, the protocol its study found best)."""

DRIFT = 1e-3
"""The reverse pass's torque scale over the braking's, minus one, in the tests."""


def two_level(device, protocol=PROTOCOL):
    stages = tuple(
        dataclasses.replace(
            st, braking_torque=a * st.braking_torque, braking_torque_2=b * st.braking_torque,
            braking_switch_turns=turns,
        )
        for st, (a, b, turns) in zip(device.stages, protocol)
    )
    return dataclasses.replace(device, stages=stages)


@pytest.fixture(scope="module")
def two_level_device(default_device):
    return two_level(default_device)


@pytest.fixture(scope="module")
def two_level_brakings(two_level_device, default_virtual):
    return {s: vd.simulate_braking(two_level_device, s, default_virtual) for s in (1, 2)}


def test_the_keys_round_trip_and_come_together(two_level_device, tmp_path):
    path = tmp_path / "device.toml"
    write_device(path, two_level_device)
    assert load_device(path) == two_level_device
    text = path.read_text().replace("braking_switch_turns", "# braking_switch_turns", 1)
    path.write_text(text)
    with pytest.raises(InputError, match=r"stage\[1\]\.braking_torque_2.*braking_switch_turns"):
        load_device(path)


def test_the_virtual_braking_switches_at_the_first_sample_past_the_turns(
    two_level_device, two_level_brakings
):
    for stage, sim in two_level_brakings.items():
        st = two_level_device.stages[stage - 1]
        truth = sim.truth
        travelled = truth.phi - truth.phi[0]
        first_past = int(np.argmax(travelled >= 2 * math.pi * st.braking_switch_turns))
        levels = np.abs(truth.torque)
        assert np.all(levels[:first_past] == levels[0])
        assert np.all(levels[first_past:] == levels[-1])
        # The rig's transmission is ideal by default: the body receives the commands.
        assert levels[0] == pytest.approx(st.braking_torque, abs=1e-15)
        assert levels[-1] == pytest.approx(st.braking_torque_2, rel=1e-12)


def test_the_switch_and_the_levels_are_found_in_the_logged_torque(
    two_level_device, two_level_brakings
):
    q = two_level_device.encoder.quantum
    for stage, sim in two_level_brakings.items():
        st = two_level_device.stages[stage - 1]
        est = estimate_pass(sim.log, q, "braking", constant_torque=True, two_levels=True)
        true_switch = int(np.flatnonzero(np.diff(np.abs(sim.truth.torque)))[0]) + 1
        assert est.switch == true_switch
        sigma = est.sigma_torque
        for mean, level, rows in (
            (est.torque_mean, st.braking_torque, est.switch),
            (est.torque_mean_2, st.braking_torque_2, len(sim.log) - est.switch),
        ):
            assert abs(abs(mean) - level) < 4 * sigma / math.sqrt(rows)
        # The held levels' work is the truth's to the means' errors.
        n = min(len(sim.truth.t), len(sim.log))
        true_work = np.concatenate([[0.0], np.cumsum(sim.truth.torque[: n - 1] * np.diff(
            est.smoothed.phi[:n]))])
        assert np.max(np.abs(est.work[:n] - true_work)) < 4 * sigma * 2 * math.pi * 10 / math.sqrt(
            est.switch
        )


def test_switch_row_finds_a_step_in_noise():
    rng = np.random.default_rng(7)
    u = np.where(np.arange(3000) < 1234, 0.0, 0.01) + rng.normal(0.0, 0.002, 3000)
    assert switch_row(u) == 1234


def test_a_two_level_braking_identifies_a_warming_reverse(
    two_level_device, default_virtual, two_level_brakings
):
    """The reverse pass's torque 1 + DRIFT times the braking's scale: the pass gain found within
    3 of its stds in every run, every entry within 3 stds of the virtual truth; plan's
    prediction for the same protocol (rsp_inertia.design.candidates.evaluate, d marginalised)
    within 20% of the stds reported."""
    q = two_level_device.encoder.quantum
    balances = []
    for stage, braking in two_level_brakings.items():
        reverse = vd.simulate_ideal_reverse(two_level_device, stage, default_virtual, braking)
        log = dataclasses.replace(reverse.log, torque=reverse.log.torque / (1.0 + DRIFT))
        b = estimate_pass(braking.log, q, "braking", constant_torque=True, two_levels=True)
        assert b.torque_mean_2 is not None  # each level passed its constancy test
        r = estimate_pass(log, q, "reverse", sigma_torque=b.sigma_torque)
        balances.append(stage_balance(two_level_device, stage, b, r))
    fit = fit_tensor(balances)
    assert np.all(np.abs(fit.pass_gain - DRIFT) < 3 * fit.pass_gain_std)
    truth = placed_body(two_level_device, default_virtual).inertia
    std = np.sqrt(np.diag(fit.entries_cov))
    assert np.all(np.abs(fit.entries - truth) < 3 * std)
    assert np.all(std < 1e-4 * np.max(truth))
    # The balances about the switch, where the smoothed speed rounds the acceleration's step
    # off, are left out: the model tests see nothing.
    assert not [test.label for test in fit.tests if test.significant]
    infos = []
    for stage in (1, 2):
        st = two_level_device.stages[stage - 1]
        model = true_parameters(two_level_device, stage, default_virtual, 1.0)
        c = evaluate(
            two_level_device, StageModel(stage, model, 1e-4, "truth"), st.launch_speed,
            st.braking_torque, braking_torque_2=st.braking_torque_2,
            switch_turns=st.braking_switch_turns,
        )
        assert c.feasible, c.violations
        infos.append(c.information)
    predicted = combine_information(two_level_device, infos)
    _, reported = axis_values(
        fit.entries, fit.entries_cov, device_design(two_level_device).directions
    )
    np.testing.assert_allclose(np.asarray(reported) / predicted, 1.0, atol=0.2)
    # The budget's line of the pass gains: what freeing them adds; the lines add up.
    share = fit.cov_parts[PASS_GAIN_SOURCE]
    assert np.allclose(sum(fit.cov_parts.values()), fit.cov, rtol=1e-9, atol=0.0)
    fixed = fit_tensor([dataclasses.replace(bal, pass_gain=False) for bal in balances])
    assert np.all(np.diag(share) > 0.0)
    assert np.allclose(
        np.diag(share)[:6],
        np.diag(fit.cov)[:6] - np.diag(fixed.cov)[:6] * max(fit.chi2_dof, 1.0)
        / max(fixed.chi2_dof, 1.0),
        rtol=1e-6,
    )


def closed_form_design(switch_turns: float | None, friction=(1e-4, 1e-4, 1e-3)) -> np.ndarray:
    """The balance's design in (J, d) of a body of constant inertia braked from 3.5 rad/s,
    built here from the closed form: per stretch i of a fifth of a turn,
    2 J de_i - d W_r,i = W_b,i + W_r,i, with W_r = 2 J de - W_b and the friction's work
    W_f = J de - W_b. The braking: 0.12 N m throughout (one level), or none for
    ``switch_turns`` turns and 0.24 N m after (two levels)."""
    J, omega, dphi = 0.2, 3.5, 1e-4
    a, b, c = friction
    e, wb, phi = [0.5 * omega**2], [0.0], 0.0
    while omega > 0.3:
        if switch_turns is None:
            tau = 0.12
        else:
            tau = 0.0 if phi < 2 * math.pi * switch_turns else 0.24
        loss = tau + a + b * omega + c * omega**2
        omega = math.sqrt(max(omega**2 - 2 * loss * dphi / J, 0.0))
        phi += dphi
        e.append(0.5 * omega**2)
        wb.append(wb[-1] + tau * dphi)
    stretch = round(2 * math.pi / 5 / dphi)
    e, wb = np.array(e[::stretch]), np.array(wb[::stretch])
    de, dwb = -np.diff(e), np.diff(wb)
    wr = 2 * J * de - dwb
    return np.column_stack([2 * de, -wr])


def _condition(A: np.ndarray) -> float:
    sv = np.linalg.svd(A / np.linalg.norm(A, axis=0), compute_uv=False)
    return float(sv[0] / sv[-1])


def test_the_closed_form_needs_friction_and_prefers_two_levels():
    """Without friction d and J are one column (W_r = 2 J de - W_b = J de): whatever the
    braking; with friction, two levels condition the design far better than one."""
    for protocol in (None, 9.0):
        sv = np.linalg.svd(closed_form_design(protocol, (0.0, 0.0, 0.0)), compute_uv=False)
        assert sv[-1] < 1e-9 * sv[0]
    one, two = _condition(closed_form_design(None)), _condition(closed_form_design(9.0))
    assert two < one / 3


@pytest.mark.slow
def test_the_fit_agrees_with_the_closed_form_on_which_protocol_identifies_d(
    default_device, default_virtual
):
    """The tensor fit's std of each run's d: the two-level protocol's well below the
    one-level's, as the closed form's conditions say (stage 2, the closed form's case)."""
    q = default_device.encoder.quantum
    stds = []
    for device in (default_device, two_level(default_device)):
        balances = []
        for stage in (1, 2):
            braking = vd.simulate_braking(device, stage, default_virtual)
            reverse = vd.simulate_ideal_reverse(device, stage, default_virtual, braking)
            two = device.stages[stage - 1].braking_torque_2 is not None
            b = estimate_pass(braking.log, q, "braking", constant_torque=True, two_levels=two)
            r = estimate_pass(reverse.log, q, "reverse", sigma_torque=b.sigma_torque)
            bal = stage_balance(device, stage, b, r)
            balances.append(dataclasses.replace(bal, pass_gain=True))
        stds.append(fit_tensor(balances, tests=False).pass_gain_std)
    one, two = stds
    ratio = _condition(closed_form_design(None)) / _condition(closed_form_design(9.0))
    assert np.all(two < one / 2)
    assert one[1] / two[1] > 2 and ratio > 2


@pytest.mark.slow
def test_closed_loop_two_level_runs_identify_a_warming_reverse(
    two_level_device, default_virtual, two_level_brakings
):
    """``program`` on a two-level braking (its mirror's need follows each level), run in
    closed loop with the reverse's torque 1 + DRIFT times the braking's scale: d within 3 of
    its stds, every entry within 3 stds of the truth, no model test fires."""
    from rsp_inertia.ocp.program import make_program

    q = two_level_device.encoder.quantum
    balances = []
    for stage, braking in two_level_brakings.items():
        made = make_program(two_level_device, stage, braking.log)
        assert made.warnings == ()
        start = (braking.truth.end_phi, 0.0)
        reverse = vd.run_program(two_level_device, stage, default_virtual, made.program, start)
        log = dataclasses.replace(reverse.log, torque=reverse.log.torque / (1.0 + DRIFT))
        b = estimate_pass(braking.log, q, "braking", constant_torque=True, two_levels=True)
        r = estimate_pass(log, q, "reverse", sigma_torque=b.sigma_torque)
        balances.append(stage_balance(two_level_device, stage, b, r))
    fit = fit_tensor(balances)
    assert np.all(np.abs(fit.pass_gain - DRIFT) < 3 * fit.pass_gain_std)
    truth = placed_body(two_level_device, default_virtual).inertia
    std = np.sqrt(np.diag(fit.entries_cov))
    assert np.all(np.abs(fit.entries - truth) < 3 * std)
    assert not [test.label for test in fit.tests if test.significant]


def test_plan_proposes_two_level_brakings_that_identify_the_pass_gain(
    default_device, default_virtual
):
    """make_plan(two_level=True) on the stages' true models: every stage's chosen protocol
    coasts, then brakes; each is feasible and its information finite (the pass gain
    marginalised), and worse than the one-level plan's on the same models (d costs
    information)."""
    from rsp_inertia.design.plan import make_plan

    models = [
        StageModel(stage, true_parameters(default_device, stage, default_virtual, 1.0), 1e-4,
                   "truth")
        for stage in (1, 2)
    ]
    two = make_plan(default_device, models, 120.0, two_level=True)
    one = make_plan(default_device, models, 120.0)
    for c in two.chosen:
        assert c.braking_torque == 0.0 and c.braking_torque_2 > 0.0
        assert c.braking_switch_turns in (1.0, 2.0, 4.0, 8.0)
        assert c.feasible and np.all(np.isfinite(c.information))
    assert all(c.braking_torque_2 is None for c in one.chosen)
    assert two.worst > one.worst
