"""Lagrange's equation fitted by modulating functions (rsp_inertia.estimation.modulated).

On the simulator's exact states and torques the modulated equations hold to Simpson's rule,
so the fit returns the virtual body's own model. A braking pass alone cannot tell Coulomb
friction from its constant torque (the nominal model's degeneracy, tests/ocp/test_nominal.py);
with its reverse it can: the fit of both passes gives a1 and the absolute M too.
"""

from __future__ import annotations

import numpy as np
import pytest

from rsp_inertia.estimation.modulated import fit_modulated
from rsp_inertia.estimation.smoothing import Smoothed
from rsp_inertia.plant.logs import Log
from rsp_inertia.plant.model import PARAMETER_NAMES
from rsp_inertia.virtual import device as vd

STAGES = (1, 2)
FITTED = ("M0", "a1", "a2", "a3", "Mc2", "Ms2", "Gs", "Gc", "Ms1", "Mc1")


def exact(sim: vd.SimulatedPass) -> tuple[Log, Smoothed]:
    """A pass's true states as a perfect smoother would give them, and its physical torque
    (the ideal drive's, which the body receives exactly)."""
    tr = sim.truth
    zero = np.zeros_like(tr.t)
    states = Smoothed(
        t=tr.t, phi=tr.phi, omega=tr.omega, eps=zero, omega_std=zero, jerk_density=0.0,
        bandwidth=0.0,
    )
    return Log(t=tr.t, phi=tr.phi, torque=tr.torque), states


@pytest.mark.parametrize("stage", STAGES)
def test_both_passes_give_the_true_model_coulomb_friction_included(
    stage, default_device, default_virtual, default_brakings, default_ideal_reverses
):
    passes = [exact(default_brakings[stage]), exact(default_ideal_reverses[stage])]
    values, cov = fit_modulated(default_device, passes, FITTED, "exact passes")
    true = vd.true_parameters(default_device, stage, default_virtual).vector
    fitted = np.array([values[name] for name in FITTED])
    expected = true[[PARAMETER_NAMES.index(name) for name in FITTED]]
    # Exact states leave Simpson's rule over 1 ms samples (~(2 Omega dt)^4 / 180, 1e-8 at the
    # top speed; the held torque is integrated exactly), amplified for the small friction
    # terms by their columns' collinearity (measured: a1 1.2e-5, a2 6e-6, the rest under
    # 1e-6). The scale a braking alone loses (1 - u_b / (u_b + a1), 2% on stage 1) is 200x
    # above the bound: every parameter, a1 (1e-4 N m against braking torques of 5e-3 and
    # 0.12 N m) included, within 1e-4 of its own size.
    np.testing.assert_allclose(fitted, expected, rtol=1e-4)
    assert np.all(np.isfinite(cov))
