"""Passes of the default experiment on the virtual device, simulated once per session.

The truth (PassTruth) rides beside every log, so estimates can be compared with what the
virtual body really did, never with numbers from an earlier run.
"""

import pytest

from rsp_inertia.estimation.balance import stage_balance
from rsp_inertia.estimation.passes import estimate_pass
from rsp_inertia.virtual import device as vd

STAGES = (1, 2)


@pytest.fixture(scope="session")
def default_brakings(default_device, default_virtual):
    """The braking pass of each default stage (~0.3 s for both)."""
    return {s: vd.simulate_braking(default_device, s, default_virtual) for s in STAGES}


@pytest.fixture(scope="session")
def default_ideal_reverses(default_device, default_virtual, default_brakings):
    """The ideal reverse (exact mirror, ideal drive) of each default stage (~3.5 s for both)."""
    return {
        s: vd.simulate_ideal_reverse(default_device, s, default_virtual, default_brakings[s])
        for s in STAGES
    }


@pytest.fixture(scope="session")
def default_balances(default_device, default_brakings, default_ideal_reverses):
    """The default stages' balances (braking and ideal reverse), without priors."""
    q = default_device.encoder.quantum
    out = []
    for stage in (1, 2):
        b = estimate_pass(default_brakings[stage].log, q, "braking", constant_torque=True)
        r = estimate_pass(default_ideal_reverses[stage].log, q, "reverse",
                          sigma_torque=b.sigma_torque)
        out.append(stage_balance(default_device, stage, b, r, slope_prior=False))
    return out
