"""The node formula and the least squares on exact data (estimation/balance.py, tensor_fit.py).

The smoother is left out: each pass is handed to the balances with the virtual device's true
angle, speed and acceleration and its true (noise-free) torque, so whatever error is left is
the formulas' own plus the simulator's. The reverse pass is the ideal reverse, the exact
mirror of the braking (docs/method.md §4); with it the identified tensor of the virtual body must be
that body's tensor.
"""

import math

import numpy as np
import pytest

from rsp_inertia.estimation import columns, tensor_fit
from rsp_inertia.estimation.balance import stage_balance
from rsp_inertia.estimation.known_terms import KnownTerms
from rsp_inertia.estimation.nodes import node_formula
from rsp_inertia.estimation.passes import PassEstimate
from rsp_inertia.estimation.smoothing import Smoothed
from rsp_inertia.estimation.tensor_fit import fit_tensor, tensor_block
from rsp_inertia.plant.geometry import ENTRY_KEYS, relative_errors
from rsp_inertia.plant.logs import Log, dropped_samples, motor_work
from rsp_inertia.plant.model import acceleration, gravity_basis, reduced_inertia, tensor_basis
from rsp_inertia.virtual import device as vd
from tests.estimation.conftest import STAGES

EXACT_REL = 1e-6
"""Relative tolerance on exact data. What is left: the integrator (energy conserved to 1e-9,
tests/plant), the ideal reverse's speed mismatch (~1e-6 rad/s at several rad/s; the RSP
formula removes its first-order effect, the plain formula does not), the Hermite
interpolation between 1 ms rows (O(dphi^4), dphi ~ 1e-2 rad at stage 1's top speed). Together
of order 1e-7 at the fastest stage; 1e-6 stays a decade below the smoother-limited accuracy
(~1e-5) that the other tests check."""


def exact_pass(
    sim: vd.SimulatedPass, params, direction: float, sample_rate: float
) -> PassEstimate:
    """A pass as estimate_pass would give it, but from the true states (no encoder, no noise).

    Parameters
    ----------
    sim : SimulatedPass
        The virtual device's pass, with its truth.
    params : np.ndarray
        The true model parameters (rsp_inertia.virtual.device.true_parameters).
    direction : float
        The sign of the pass's motion (+1 braking, -1 reverse), for the acceleration.
    sample_rate : float
        Hz, the encoder's: finds the pass's dropped samples.

    Returns
    -------
    PassEstimate
        The exact pass.
    """
    truth = sim.truth
    n = len(truth.t)
    eps = np.asarray(
        acceleration(truth.phi, truth.omega, truth.torque, params, direction=np.full(n, direction))
    ).ravel()
    smoothed = Smoothed(
        t=truth.t,
        phi=truth.phi,
        omega=truth.omega,
        eps=eps,
        omega_std=np.full(n, 1e-6),  # any small constant: it only weights the equations
        jerk_density=0.0,
        bandwidth=100.0,  # sets the spacing of the balance angles (1 / w_c at top speed)
        noise_density=12e-12 / 100.0**3,  # speed error variance r w_c^3 / 12 = (1e-6)^2
    )
    log = Log(t=truth.t, phi=truth.phi, torque=truth.torque)
    # Exact: the torque is held over each row (ZOH), summed over the true angle.
    work, back, steps, _ = motor_work(log.torque, log.phi)
    return PassEstimate(
        log=log,
        smoothed=smoothed,
        work=work,
        work_back=back,
        work_var_steps=steps,
        sigma_torque=0.0,
        source="exact",
        dropped=dropped_samples(truth.t, sample_rate),
    )


@pytest.fixture(scope="module")
def exact_passes(default_device, default_virtual, default_brakings, default_ideal_reverses):
    """{stage: (braking, reverse)} as exact PassEstimates."""
    out = {}
    for s in STAGES:
        p = vd.true_parameters(default_device, s, default_virtual).vector
        rate = default_device.encoder.sample_rate
        out[s] = (
            exact_pass(default_brakings[s], p, +1.0, rate),
            exact_pass(default_ideal_reverses[s], p, -1.0, rate),
        )
    return out


@pytest.mark.parametrize("stage", STAGES)
def test_node_formula_gives_the_true_reduced_inertia(
    stage, default_device, default_virtual, exact_passes
):
    braking, reverse = exact_passes[stage]
    p = vd.true_parameters(default_device, stage, default_virtual).vector
    nodes = node_formula(
        default_device, stage, braking, reverse, default_device.stages[stage - 1].nodes_deg
    )
    assert [n.node_deg for n in nodes] == list(default_device.stages[stage - 1].nodes_deg)
    for n in nodes:
        true_M = float(reduced_inertia(math.radians(n.node_deg), p))
        assert n.pairs >= 1
        assert n.M == pytest.approx(true_M, rel=EXACT_REL), n.node_deg
        # On the exact mirror the paper's plain formula (6) holds as well.
        assert n.M_plain == pytest.approx(true_M, rel=EXACT_REL), n.node_deg


def test_least_squares_gives_the_true_tensor_and_centre_of_mass(
    default_device, default_virtual, exact_passes
):
    balances = [stage_balance(default_device, s, *exact_passes[s]) for s in STAGES]
    fit = fit_tensor(balances)
    body = default_virtual.body
    np.testing.assert_array_less(np.abs(relative_errors(fit.entries, body.inertia)), EXACT_REL)
    # Gravity terms m g (x_c, y_c): the same relative tolerance on the torque m g |r_c|.
    weight = body.mass * default_device.gravity
    np.testing.assert_allclose(
        fit.gravity / weight, body.com[:2], rtol=0, atol=EXACT_REL * np.linalg.norm(body.com[:2])
    )


def test_the_least_squares_rows_are_the_models_bases(default_device, exact_passes, monkeypatch):
    """tensor_block's inertia and gravity columns are rsp_inertia.plant.model's tensor_basis
    and gravity_basis (twice: two passes); replaced, the columns follow."""
    bal = stage_balance(default_device, 1, *exact_passes[1])
    known = KnownTerms.from_tares([st.tare_inertia for st in default_device.stages])
    block = tensor_block(bal, "0", known, False)
    v = tensor_basis(bal.phi, bal.gear_ratio)
    for i, name in enumerate(ENTRY_KEYS):
        np.testing.assert_array_equal(block.inertia_columns[name], v[:, i])
    np.testing.assert_array_equal(
        np.column_stack([block.columns["Gs"], block.columns["Gc"]]), 2 * gravity_basis(bal.phi)
    )
    monkeypatch.setattr(tensor_fit, "tensor_basis", lambda phi, lam: np.ones((len(phi), 6)))
    monkeypatch.setattr(columns, "gravity_basis", lambda phi: np.ones((len(phi), 2)))
    block = tensor_block(bal, "0", known, False)
    assert all(np.all(block.inertia_columns[name] == 1.0) for name in ENTRY_KEYS)
    assert np.all(block.columns["Gs"] == 2.0) and np.all(block.columns["Gc"] == 2.0)
