"""The program in closed loop on the virtual device: the reverse pass holds the mirror.

At every passage of a node (docs/method.md §5), with the braking faster than 20% of its top, the
true reverse speed must equal the true braking speed to 1e-3 (the issue's target), on the
fitted nominal model and on nominal models far off (the regulator's job, issue's robustness
requirement). The device's own limits (torque, torque rate) hold throughout.
"""

import dataclasses
import math

import numpy as np
import pytest

from rsp_inertia.estimation.axes import axis_values
from rsp_inertia.estimation.balance import FRICTION_PRIOR_ALLOWANCE, stage_balance
from rsp_inertia.estimation.passes import estimate_pass
from rsp_inertia.estimation.tensor_fit import fit_tensor
from rsp_inertia.ocp.program import make_program
from rsp_inertia.plant.geometry import axis_direction
from rsp_inertia.plant.model import dissipation
from rsp_inertia.virtual import device as vd
from tests.ocp.conftest import STAGES, TARGET, node_passages, true_rest


def assert_within_the_motor(device, reverse):
    u = reverse.truth.torque
    motor, dt = device.motor, device.encoder.dt
    # The drive clips to the limits; 1e-12 is the rounding of u_prev +- rate dt.
    assert np.abs(u).max() <= motor.torque_limit * (1 + 1e-12)
    assert np.abs(np.diff(u)).max() <= motor.torque_rate_limit * dt * (1 + 1e-12)


@pytest.mark.parametrize("stage", STAGES)
def test_reverse_speed_is_the_braking_speed_at_the_nodes(stage, default_device, brakings, reverses):
    passages = node_passages(default_device, stage, brakings[stage], reverses[stage])
    # Non-vacuous: at least two turns' worth of node passages are compared.
    assert passages.angle.size >= 2 * len(default_device.stages[stage - 1].nodes_deg)
    assert np.all(np.isfinite(passages.reverse)), "the reverse did not reach every node"
    assert np.abs(passages.mismatch).max() <= TARGET


@pytest.mark.parametrize("stage", STAGES)
def test_reverse_stays_within_the_motor(stage, default_device, reverses):
    assert_within_the_motor(default_device, reverses[stage])


@pytest.mark.parametrize("stage", STAGES)
def test_reverse_runs_the_whole_braking_back(stage, default_device, brakings, reverses):
    # It starts at the rest and ends, at the program's end, near the release at speed.
    tr, rv = brakings[stage].truth, reverses[stage].truth
    assert rv.phi[0] == tr.end_phi
    top = tr.omega.max()
    # The state after the program's last sample is the braking's within two samples of the
    # release: two samples' travel and two samples' speed change, plus the tracking target.
    assert abs(rv.end_phi - tr.phi[0]) <= 2 * top * default_device.encoder.dt
    change = tr.omega[0] - tr.omega[1]
    assert -rv.end_omega == pytest.approx(top, abs=2 * change + TARGET * top)


PERTURBATIONS = [
    pytest.param(
        stage,
        inertia,
        friction,
        id=f"stage{stage}-M*{inertia}-D*{friction}",
        marks=() if (stage, inertia, friction) == (1, 0.7, 1.5) else pytest.mark.slow,
    )
    for stage in STAGES
    for inertia in (0.7, 1.3)
    for friction in (0.5, 1.5)
]
"""The issue's robustness cases: inertia harmonics x0.7 and x1.3, friction (a2, a3) x0.5
and x1.5, on both stages. One case runs by default (~3 s each; the sweep ~25 s)."""


@pytest.mark.parametrize(("stage", "inertia", "friction"), PERTURBATIONS)
def test_regulator_holds_the_mirror_with_a_wrong_nominal_model(
    stage, inertia, friction, default_device, default_virtual, brakings, programs
):
    fitted = programs[stage].nominal
    wrong = dataclasses.replace(
        fitted,
        inertia_harmonics=inertia * fitted.inertia_harmonics,
        viscous=friction * fitted.viscous,
        quadratic=friction * fitted.quadratic,
    )
    braking = brakings[stage]
    result = make_program(default_device, stage, braking.log, nominal=wrong)
    assert result.nominal is wrong
    reverse = vd.run_program(
        default_device, stage, default_virtual, result.program, true_rest(braking)
    )
    assert_within_the_motor(default_device, reverse)
    mismatch = np.abs(node_passages(default_device, stage, braking, reverse).mismatch)
    assert np.all(np.isfinite(mismatch)), "the reverse did not reach every node"
    # The regulator absorbs the model error: the typical node meets the target. A single
    # passage may see the encoder's jitter at that instant (one count through k_phi and the
    # speed observer moves the torque by up to a sample's rate limit), hence twice the target
    # for the worst one.
    assert np.median(mismatch) <= TARGET
    assert mismatch.max() <= 2 * TARGET


def test_identification_corrects_the_tracking_mismatch(
    default_device, default_virtual, brakings, reverses, closed_balances
):
    # The closed loop tracks to a few 1e-4, and friction then does different work on the two
    # passes: ~1e-4 of stage 1's kinetic energy, several times the noise floor. The least
    # squares fits the friction slope D'(Omega) = d1 + d2 Omega where the data ask for it
    # (rsp_inertia.estimation.balance, rsp_inertia.estimation.tensor_fit): stage 1 here. Its axes must then be within
    # 4 reported stds of the truth, and the slope must be the virtual bearing's own
    # (d1 = a2, d2 = 2 a3 for the paper's D), also within 4 stds.
    balances = closed_balances
    fit = fit_tensor(balances)
    assert fit.mismatch_terms[0]
    directions = np.array([
        axis_direction(math.radians(n), st.gear_ratio)
        for st in default_device.stages for n in st.nodes_deg
    ])
    values, stds = axis_values(fit.entries, fit.entries_cov, directions)
    J = default_virtual.body.tensor
    truth = np.einsum("ij,jk,ik->i", directions, J, directions)
    assert np.all(np.abs(values - truth) < 4 * stds), (values / truth - 1, stds / truth)
    friction = default_virtual.friction
    expected = np.array([friction.viscous, 2 * friction.quadratic])
    assert np.all(np.abs(fit.friction_slope[0] - expected) < 4 * fit.friction_slope_std[0])
    # And the fitted term is the friction work's true asymmetry, computed from the simulator's
    # states (trapezoid rule on the true D along each pass): F_b(phi) + F_r(phi) up to a
    # constant. The fit follows it to a third of its size or better.
    bal = balances[0]
    params = vd.true_parameters(default_device, 1, default_virtual)
    asymmetry = np.zeros_like(bal.phi)
    for sim in (brakings[1], reverses[1]):
        D = np.asarray(dissipation(sim.truth.omega, params)).ravel()
        work = np.concatenate([[0.0], np.cumsum(-0.5 * (D[:-1] + D[1:]) * np.diff(sim.truth.phi))])
        order = np.argsort(sim.truth.phi)
        asymmetry += np.interp(bal.phi, sim.truth.phi[order], work[order])
    fitted = bal.mismatch @ fit.friction_slope[0]
    asymmetry -= asymmetry.mean()
    fitted -= fitted.mean()
    assert np.std(fitted - asymmetry) < np.std(asymmetry) / 3, (np.std(fitted - asymmetry), np.std(asymmetry))


@pytest.fixture(scope="module")
def closed_balances(default_device, brakings, reverses):
    """The default stages' balances with the closed-loop reverses (forward runs)."""
    q = default_device.encoder.quantum
    out = []
    for s in STAGES:
        b = estimate_pass(brakings[s].log, q, "braking", constant_torque=True)
        r = estimate_pass(reverses[s].log, q, "reverse", sigma_torque=b.sigma_torque)
        out.append(stage_balance(default_device, s, b, r))
    return out


def test_the_passes_dynamics_give_the_virtual_bearings_friction_slopes(
    default_virtual, closed_balances
):
    # Both passes' equations of motion, fitted together, know the friction absolutely
    # (rsp_inertia.estimation.modulated): the prior's slopes are the virtual bearing's
    # d1 = a2, d2 = 2 a3 within 3 of the fit's own stds (the prior's covariance less its
    # allowance), and those stds are a small part of the slopes (measured: 4-10% of d1, well
    # under 1% of d2 on stage 1): a prior that tells.
    friction = default_virtual.friction
    expected = np.array([friction.viscous, 2 * friction.quadratic])
    for bal in closed_balances:
        mean, cov = bal.slope_prior
        fit_cov = cov - np.diag((FRICTION_PRIOR_ALLOWANCE * mean) ** 2)
        std = np.sqrt(np.diag(fit_cov))
        assert np.all(np.abs(mean - expected) < 3 * std), ((mean - expected) / std, std)
    std = np.sqrt(np.diag(closed_balances[0].slope_prior[1]))
    assert np.all(std <= 0.25 * expected)


def test_a_prior_the_balances_reject_is_dropped_with_a_warning(closed_balances):
    # The run's balances test its prior (rsp_inertia.estimation.gls): the passes' own slopes
    # pass; a prior ten times off with a tight covariance is rejected, named (and only it: the
    # other run's prior, pulled by it at first, is tested again without it), and the run's
    # slopes are then its balances' own, as without its prior.
    stage_1, stage_2 = closed_balances
    good = fit_tensor(closed_balances)
    assert good.prior_warnings == []
    mean, cov = stage_1.slope_prior
    wrong = dataclasses.replace(stage_1, slope_prior=(10 * mean, 1e-4 * cov))
    rejected = fit_tensor([wrong, stage_2])
    assert len(rejected.prior_warnings) == 1
    assert rejected.prior_warnings[0].startswith("stage 1 forward: the friction slopes")
    without = fit_tensor([dataclasses.replace(stage_1, slope_prior=None), stage_2])
    np.testing.assert_allclose(rejected.friction_slope, without.friction_slope, rtol=1e-9)
    # The prior narrows the slopes where it holds, and with them the tensor.
    free = fit_tensor([dataclasses.replace(b, slope_prior=None) for b in closed_balances])
    assert np.all(good.friction_slope_std < free.friction_slope_std)
    assert np.all(np.diag(good.entries_cov) <= np.diag(free.entries_cov) * (1 + 1e-9))
