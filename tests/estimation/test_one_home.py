"""Every formula of docs/method.md has one home; its consumers in rsp_inertia.estimation call it.

The table lists, per formula, the function named in docs/method.md and the estimation modules
that use it: each must import that very function (not a copy of its own) and call it. The
behavioural tests below replace a home in a consumer's namespace and see the consumer's result
follow it. (The model's M, Pi and the RK4 step: tests/plant/test_model.py,
tests/estimation/test_balance.py; the physical margins and the errors against the truth:
tests/plant/test_geometry.py; the OCP's consumers: tests/ocp/test_one_home.py.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from rsp_inertia.estimation import axes, best_practice, known_terms, pendulum, predict, smoothing
from rsp_inertia.estimation.best_practice import HalfCycleFit
from rsp_inertia.plant import geometry
from rsp_inertia.plant.logs import Log
from tests.one_home import assert_calls_home, home_cases

# (formula, home module, function, consumer modules)
HOMES = [
    ("J_e = (M - M_tare) / (1 + lambda^2)", "estimation.identify", "axial_moment",
     ["estimation.identify"]),
    ("M = c / w_n^2", "estimation.pendulum", "pendulum_inertia",
     ["estimation.pendulum", "estimation.best_practice"]),
    ("k_g = -(Gs sin phi + Gc cos phi)", "estimation.best_practice", "gravity_stiffness",
     ["estimation.best_practice", "estimation.stiffness"]),
    ("zero-crossing period", "estimation.pendulum", "crossing_period",
     ["estimation.pendulum", "estimation.stiffness"]),
    ("half-cycle fit", "estimation.best_practice", "half_cycle_fit",
     ["estimation.identify", "estimation.stiffness"]),
    ("M = (c + k_g) / w_n^2", "estimation.best_practice", "best_practice_inertia",
     ["estimation.identify", "estimation.stiffness"]),
    ("V (design matrix)", "plant.geometry", "design_matrix", ["estimation.axes", "estimation.predict"]),
    ("J from its entries", "plant.geometry", "tensor_from_entries",
     ["plant.reference_config", "estimation.coverage"]),
    ("d(a^T J b) / d(entries)", "plant.geometry", "bilinear_gradient", ["estimation.coverage"]),
    ("e(phi)", "plant.geometry", "axis_direction", ["estimation.identify", "estimation.results"]),
    ("identify's axes and cond(V)", "plant.geometry", "device_design",
     ["estimation.identify", "estimation.predict"]),
    ("M's basis functions", "plant.model", "inertia_basis",
     ["estimation.known_terms", "estimation.tensor_fit", "estimation.calibration",
      "estimation.stiffness"]),
    ("M's harmonics", "plant.model", "inertia_harmonics",
     ["estimation.conventions"]),
    ("a reference's terms in a balance", "estimation.conventions", "reference_terms",
     ["estimation.calibration", "estimation.stiffness"]),
    ("M's basis slopes", "plant.model", "inertia_basis_slope", ["estimation.calibration"]),
    ("M's slopes in the tensor", "plant.model", "tensor_basis_slope", ["estimation.tensor_fit"]),
    ("Pi (spring part)", "plant.model", "potential", ["estimation.balance"]),
    ("d(M Omega)/dp, the momentum form", "plant.model", "momentum_regressor",
     ["estimation.modulated"]),
    ("dF/dp, the momentum form's force", "plant.model", "force_regressor",
     ["estimation.modulated"]),
    ("2 Pi_spring of the balances", "estimation.balance", "spring_potential",
     ["estimation.balance", "estimation.nodes"]),
    ("w_c = 10 x 2 Omega_max", "estimation.smoothing", "smoother_bandwidth",
     ["estimation.smoothing", "estimation.predict"]),
    ("r = (q^2/12) dt", "estimation.smoothing", "noise_density",
     ["estimation.smoothing", "estimation.predict"]),
    ("R(tau)", "estimation.smoothing", "speed_error_autocovariance", ["estimation.smoothing"]),
    ("smoothed states", "estimation.smoothing", "smooth_log", ["estimation.passes"]),
    ("W_K, the zero-order-hold Stieltjes sum", "plant.logs", "motor_work",
     ["plant.logs", "estimation.passes", "estimation.predict"]),
    ("dropped samples of a log", "plant.logs", "dropped_samples",
     ["estimation.passes", "estimation.balance"]),
    ("mirrored coordinate of a backward run", "plant.logs", "mirror_log",
     ["estimation.runs"]),
    ("common range of the passes", "estimation.balance", "usable_range",
     ["estimation.balance", "estimation.nodes"]),
    ("tracking-mismatch regressors R1, R2", "estimation.balance", "mismatch_regressors",
     ["estimation.balance", "estimation.nodes"]),
    ("the stage balance", "estimation.balance", "stage_balance",
     ["estimation.runs", "estimation.predict"]),
    ("J_k = V_k . J with its std", "estimation.axes", "axis_values", ["estimation.identify"]),
    ("tensor through V", "estimation.axes", "tensor_from_axes", ["estimation.identify"]),
    ("one run's least-squares rows", "estimation.tensor_fit", "tensor_block",
     ["estimation.tensor_fit", "estimation.predict"]),
    ("2 dPi/d[Gs, Gc]", "estimation.columns", "gravity_rows",
     ["estimation.tensor_fit", "estimation.known_terms", "estimation.calibration"]),
    ("a run's own columns", "estimation.columns", "run_columns",
     ["estimation.tensor_fit", "estimation.calibration"]),
    ("the GLS", "estimation.gls", "solve_blocks", ["estimation.tensor_fit", "estimation.calibration"]),
    ("Cholesky whitening", "estimation.whitening", "whiten",
     ["estimation.gls", "estimation.whitening"]),
    ("weighted chi^2", "estimation.whitening", "weighted_chi2",
     ["estimation.gls", "estimation.model_tests"]),
    ("model-test warnings", "estimation.model_tests", "model_warnings",
     ["estimation.identify", "estimation.calibration"]),
    ("the node formula", "estimation.nodes", "node_estimates", ["estimation.identify"]),
]


@pytest.mark.parametrize("home, name, consumer", home_cases(HOMES), ids=str)
def test_consumers_call_the_one_home(home, name, consumer):
    assert_calls_home(home, name, consumer)


def _fit() -> HalfCycleFit:
    return HalfCycleFit(
        omega_n=5.0, omega_n_std=1e-4, omega_d=4.99, delta=0.05, kappa=0.0,
        kappa_fitted=False, centre=0.1, amplitude=0.05, half_cycles=10, residual_rms=1e-5,
    )


def test_pendulum_inertia_is_the_home_of_m_from_the_frequency(monkeypatch):
    t = np.arange(0.0, 20.0, 1e-3)
    log = Log(t=t, phi=0.05 * np.exp(-0.02 * t) * np.cos(3.0 * t), torque=np.zeros_like(t))
    gravity, cov = np.array([0.01, -0.02]), np.zeros((2, 2))
    classic = pendulum.estimate_pendulum(log, 2.0, 1, 0.0, "p.csv").M_classic
    best = best_practice.best_practice_inertia(_fit(), 2.0, 0.0, 0.1, gravity, cov).M
    assert best == pytest.approx((2.0 + best_practice.gravity_stiffness(gravity, 0.1)) / 25.0)
    for module in (pendulum, best_practice):
        monkeypatch.setattr(module, "pendulum_inertia", lambda c, w: 3 * c / w**2)
    assert pendulum.estimate_pendulum(log, 2.0, 1, 0.0, "p.csv").M_classic == pytest.approx(
        3 * classic
    )
    assert best_practice.best_practice_inertia(_fit(), 2.0, 0.0, 0.1, gravity, cov).M == (
        pytest.approx(3 * best)
    )


def test_gravity_stiffness_is_the_home_of_k_g(monkeypatch):
    gravity = np.array([0.01, -0.02])
    before = best_practice.best_practice_inertia(_fit(), 2.0, 0.0, 0.1, gravity, np.zeros((2, 2)))
    monkeypatch.setattr(best_practice, "gravity_stiffness", lambda g, phi: 1.0)
    after = best_practice.best_practice_inertia(_fit(), 2.0, 0.0, 0.1, gravity, np.zeros((2, 2)))
    assert after.gravity_stiffness == 1.0 != before.gravity_stiffness
    assert after.M == pytest.approx(3.0 / 25.0)


def test_design_matrix_is_the_home_of_v(monkeypatch, default_device):
    directions = geometry.device_design(default_device).directions
    entries, cov = np.arange(1.0, 7.0), np.eye(6)
    info = np.eye(8)[None] * 1e6
    before = (axes.axis_values(entries, cov, directions)[0],
              axes.tensor_from_axes(np.ones(6), np.ones(6), directions)[0],
              predict.axis_stds(default_device, info))
    for module in (axes, predict):
        monkeypatch.setattr(module, "design_matrix", lambda d: 2 * geometry.design_matrix(d))
    np.testing.assert_allclose(axes.axis_values(entries, cov, directions)[0], 2 * before[0])
    np.testing.assert_allclose(
        axes.tensor_from_axes(np.ones(6), np.ones(6), directions)[0], before[1] / 2
    )
    np.testing.assert_allclose(predict.axis_stds(default_device, info), 2 * before[2])


def test_tensor_from_entries_is_the_home_of_j(monkeypatch):
    entries = np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015])
    moments = geometry.principal(entries)[0]
    home = geometry.tensor_from_entries
    monkeypatch.setattr(geometry, "tensor_from_entries", lambda e: 2 * home(e))
    np.testing.assert_allclose(geometry.principal(entries)[0], 2 * moments)


def test_inertia_basis_is_the_home_of_m_empty(monkeypatch):
    known = known_terms.KnownTerms.from_tares([0.5, 1.5])
    assert known.empty_inertia(2, 0.3) == 1.5
    monkeypatch.setattr(known_terms, "inertia_basis", lambda phi: 2 * np.ones((len(phi), 5)))
    assert known.empty_inertia(2, 0.3) == 3.0


def test_smoother_bandwidth_is_the_home_of_w_c(monkeypatch):
    t = np.arange(0.0, 1.0, 1e-3)
    log = Log(t=t, phi=np.floor(10.0 * t / 1e-3) * 1e-3, torque=np.zeros_like(t))
    _, bandwidth = smoothing.jerk_density(log, 1e-3)
    # the top speed read off the quantized log: 10 rad/s to a count over BLOCK samples
    assert bandwidth == pytest.approx(smoothing.smoother_bandwidth(10.0), rel=0.02)
    monkeypatch.setattr(smoothing, "smoother_bandwidth", lambda omega: 123.0)
    q_j, bandwidth = smoothing.jerk_density(log, 1e-3)
    assert bandwidth == 123.0
    assert q_j == pytest.approx(smoothing.noise_density(1e-3, 1e-3) * 123.0**6)
    assert math.isfinite(q_j)
