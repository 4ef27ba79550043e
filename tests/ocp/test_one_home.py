"""Every formula of docs/method.md has one home; its consumers in rsp_inertia.ocp call it.

Per formula, the function named in docs/method.md and the ocp modules that use it: each must
import that very function (not a copy of its own) and call it; a behavioural test replaces a
home in a consumer's namespace and sees the result follow. (The RK4 step's consumers:
tests/plant/test_model.py; the estimation's: tests/estimation/test_one_home.py.)
"""

from __future__ import annotations

import numpy as np
import pytest

from rsp_inertia.design import candidates
from rsp_inertia.ocp import regulator
from rsp_inertia.plant.model import ModelParameters
from tests.one_home import assert_calls_home, home_cases

# (formula, home module, function, consumer modules)
HOMES = [
    ("M(phi)", "plant.model", "reduced_inertia",
     ["design.candidates", "ocp.regulator", "ocp.program"]),
    ("dPi/dphi, the hold torque", "plant.model", "static_torque",
     ["design.candidates", "ocp.feedforward"]),
    ("Lagrange's equation solved for u", "plant.model", "motor_torque",
     ["design.candidates", "ocp.feedforward"]),
    ("Lagrange's equation solved for eps", "plant.model", "acceleration", ["design.candidates"]),
    ("D(Omega)", "plant.model", "dissipation", ["design.candidates"]),
    ("RK4 step", "plant.model", "rk4_step", ["ocp.feedforward"]),
    ("M's harmonics from the entries", "plant.model", "harmonics_matrix", ["design.rehearsal"]),
    ("smoothed braking", "estimation.smoothing", "smooth_log", ["ocp.program", "design.pilot"]),
    ("cubic Hermite between states", "estimation.smoothing", "hermite",
     ["ocp.reference", "design.candidates"]),
    ("mirrored coordinate of a backward run", "plant.logs", "mirror_log", ["ocp.program"]),
    ("torque noise level", "plant.logs", "torque_noise", ["design.pilot"]),
    ("modulated least squares", "estimation.modulated", "fit_modulated",
     ["ocp.nominal", "design.pilot"]),
    ("the rest point", "ocp.reference", "rest_fit", ["ocp.reference"]),
    ("the time mirror", "ocp.reference", "mirror", ["ocp.program"]),
    ("the mirror's torque on the nominal model", "ocp.feedforward", "required_torque",
     ["ocp.feedforward", "ocp.program"]),
    ("the regulator's bandwidth", "ocp.regulator", "bandwidth",
     ["ocp.regulator", "ocp.program"]),
    ("LQR gains", "ocp.regulator", "lqr_gains", ["ocp.program"]),
    ("the planned release", "design.candidates", "planned_release",
     ["design.candidates", "design.rehearsal"]),
    ("a candidate protocol", "design.candidates", "evaluate", ["design.candidates", "design.plan"]),
    ("the stage balance", "estimation.balance", "stage_balance", ["design.rehearsal"]),
    ("predicted information of a run", "estimation.predict", "run_information",
     ["design.candidates"]),
    ("predicted J_k stds", "estimation.predict", "axis_stds", ["design.plan"]),
    ("identify's least squares", "estimation.tensor_fit", "fit_tensor", ["design.rehearsal"]),
]


@pytest.mark.parametrize("home, name, consumer", home_cases(HOMES), ids=str)
def test_consumers_call_the_one_home(home, name, consumer):
    assert_calls_home(home, name, consumer)


MODEL = ModelParameters(
    inertia_harmonics=np.array([0.1, 0.002, 0.0, 0.001, 0.0]),
    coulomb=1e-4, viscous=1e-4, quadratic=1e-3,
)


def test_regulator_gains_follow_the_model_reduced_inertia(monkeypatch, default_device):
    """The regulator's bandwidth and gains take M from the model's one M(phi)."""
    t = np.arange(0.0, 0.2, default_device.encoder.dt)
    phi, omega, torque = 1.0 - 5.0 * t, -5.0 * np.ones_like(t), np.zeros_like(t)
    k_phi, _ = regulator.lqr_gains(default_device, t, phi, omega, torque, MODEL)
    real = regulator.reduced_inertia
    monkeypatch.setattr(regulator, "reduced_inertia", lambda phi, p: 2 * np.asarray(real(phi, p)))
    k_phi_2, _ = regulator.lqr_gains(default_device, t, phi, omega, torque, MODEL)
    assert not np.allclose(k_phi_2, k_phi)


def test_candidate_friction_is_the_model_dissipation(monkeypatch):
    """A candidate's friction D(|Omega|) is the model's dissipation."""
    before = candidates._friction(MODEL, [3.0])
    assert before[0] == pytest.approx(1e-4 + 3e-4 + 9e-3)
    monkeypatch.setattr(candidates, "dissipation", lambda w, p, d: 7.0 * np.ones_like(w))
    np.testing.assert_allclose(candidates._friction(MODEL, [3.0]), [7.0])
