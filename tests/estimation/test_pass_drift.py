"""A torque scale that differs between the braking and the reverse pass (issue 37).

The default experiment's braking and ideal reverse on the virtual device (exact mirror,
ideal drive), the rig's imperfections made by the virtual device itself: a motor that warms
through the passes (virtual.toml ``[rig]`` thermal keys), a drive that loses power by its
direction of flow. The model tests must name each for its own cause, and a drift's stated std
must reach the stds as what a scaled reverse pass really does to the fit.
"""

import dataclasses

import numpy as np
import pytest

from rsp_inertia.estimation.balance import stage_balance
from rsp_inertia.estimation.calibration import device_known_terms
from rsp_inertia.estimation.gls import DRIFT_SOURCE, solve_blocks, speed_noise_scales
from rsp_inertia.estimation.model_tests import DRIVE_PROBE, SCALE_PROBES, WARMING_PROBE
from rsp_inertia.estimation.passes import estimate_pass
from rsp_inertia.estimation.tensor_fit import _equations, fit_tensor
from rsp_inertia.plant.geometry import ENTRY_KEYS
from rsp_inertia.virtual import device as vd

STAGES = (1, 2)


def _balances(device, virtual, reverse_scale=(1.0, 1.0)):
    """Both stages' balances, braking and ideal reverse; the reverse's logged torque divided
    by ``reverse_scale[stage - 1]`` (the body received that times the logged torque)."""
    q = device.encoder.quantum
    out = []
    for stage in STAGES:
        braking = vd.simulate_braking(device, stage, virtual)
        reverse = vd.simulate_ideal_reverse(device, stage, virtual, braking)
        log = dataclasses.replace(
            reverse.log, torque=reverse.log.torque / reverse_scale[stage - 1]
        )
        b = estimate_pass(braking.log, q, "braking", constant_torque=True)
        r = estimate_pass(log, q, "reverse", sigma_torque=b.sigma_torque)
        out.append(stage_balance(device, stage, b, r, slope_prior=False))
    return out


def _named(fit) -> set[str]:
    return {t.kind for t in fit.tests if t.significant}


def _rig(virtual, **changes):
    return dataclasses.replace(virtual, rig=dataclasses.replace(virtual.rig, **changes))


@pytest.fixture(scope="module")
def warming(default_virtual):
    """A NdFeB motor whose winding (14.65 ohm, 4 K/W, 60 s) warms its magnets (5 s behind)
    by about 1 K through stage 2's passes: a drift of about 1e-3 between them."""
    return _rig(
        default_virtual,
        torque_constant_tempco=-0.0011,
        torque_constant=0.5,
        winding_resistance=14.65,
        thermal_resistance=4.0,
        winding_time_constant=60.0,
        magnet_lag=5.0,
    )


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_a_warming_motor_is_named_and_a_lossy_drive_is_not_taken_for_one(
    default_device, warming, default_virtual, seed
):
    def seeded(v):
        return dataclasses.replace(v, run=dataclasses.replace(v.run, seed=seed))

    known = device_known_terms(default_device)[0]
    warm = fit_tensor(_balances(default_device, seeded(warming)), known)
    assert WARMING_PROBE in _named(warm) and DRIVE_PROBE not in _named(warm), _named(warm)
    test = next(t for t in warm.tests if t.kind == WARMING_PROBE)
    # The reverse's scale fell against the braking's (a warmer motor gives less torque).
    assert test.estimate[0] < -3 * np.sqrt(test.estimate_cov[0, 0])
    lossy = _rig(seeded(default_virtual), efficiency_driving=0.998)
    loss = fit_tensor(_balances(default_device, lossy), known)
    assert DRIVE_PROBE in _named(loss) and WARMING_PROBE not in _named(loss), _named(loss)
    clean = fit_tensor(_balances(default_device, seeded(default_virtual)), known)
    assert not _named(clean) & {DRIVE_PROBE, WARMING_PROBE, SCALE_PROBES}


def test_a_drifts_std_is_what_a_scaled_reverse_does_to_the_fit(default_device, default_virtual):
    """The budget line against the fit's own response to each run's reverse torque scaled by
    1 + s (the same weights): the balances are linear in the reverse's torque scale, so the
    two agree to first order, run by run independent."""
    s = 2e-4
    known = device_known_terms(default_device)[0]
    balances = _balances(default_device, default_virtual)
    eq = _equations(balances, known)
    scales = speed_noise_scales(eq)
    base = solve_blocks(eq, scales)
    idx = [base.index(k) for k in ENTRY_KEYS]
    shifts = []
    for k in range(len(STAGES)):
        scale = [1.0, 1.0]
        scale[k] = 1.0 + s
        moved = solve_blocks(_equations(_balances(default_device, default_virtual, scale), known),
                             scales)
        shifts.append(moved.x[idx] - base.x[idx])
    expected = np.sqrt(np.sum(np.square(shifts), axis=0))
    drifted = solve_blocks(_equations(balances, known, drift_std=s), scales)
    line = np.sqrt(np.diag(drifted.cov_parts[DRIFT_SOURCE])[idx])
    np.testing.assert_allclose(line, expected, rtol=0.02)
    # It adds to the covariance and changes nothing else.
    np.testing.assert_array_equal(drifted.x, base.x)
    others = {k: v for k, v in drifted.cov_parts.items() if k != DRIFT_SOURCE}
    for k, v in others.items():
        np.testing.assert_array_equal(v, base.cov_parts[k])
    # A drift of 2e-4 moves the moments by far more than their noise: the line dominates.
    assert np.all(line[:3] > 3 * np.sqrt(np.diag(base.cov)[idx][:3]))
