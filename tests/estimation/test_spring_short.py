"""A short, fast braking against a torsion spring: the smoother's block length and honest stds.

The scenario of a user's report. Spring c = 0.02 N m/rad zeroed at phi = 0, release at
-30 deg; each stage is launched so that its braking pass winds the spring over 3.1 turns in
2.0 s and ends at the spring's turning point (the speed reaches zero with an acceleration of
~10 rad/s^2); ideal reverse, the paper's friction, a 16-bit encoder at 1 kHz, torque noise
1e-4 N m. The launch speeds (~20 rad/s) set the smoother's bandwidth to w_c = 2 x 10 x 20 =
~390 rad/s, and the braking's jerk reaches 300-800 rad/s^3. With the former fixed 10-sample
block (w_c T = 3.9) the block model biased the speed by kappa j ~ 1e-4 rad/s over the whole
pass and aliased the reading noise into low frequencies: J_k errors of 6-18 std (the worst
axis over eight realisations), the speed noise's calibrated scale 2-3, and the balances'
closure warnings. With the block length of
rsp_inertia.estimation.smoothing (w_c T <= 2) both are gone.

Launch speeds and braking torques: root-finding on the virtual device (the launch speed for
3.1 turns at a given braking torque, the braking torque for a 2.0 s pass), rounded. Not to a
pass of exactly 2000 samples: then the ideal reverse, the braking's time mirror, reads the
encoder at the braking's very angles, both passes' quantization errors coincide, and their
speed errors add coherently in Omega^2 + Omega'^2 instead of independently (the speed-error
model's assumption) while cancelling from the tracking mismatch's regressors; a real rig's
reverse starts at no such instant.
"""

import math
import re

import numpy as np
import pytest

from rsp_inertia.estimation import smoothing
from rsp_inertia.estimation.smoothing import block_length, block_speed_bias, smooth_log
from rsp_inertia.identifying import identify
from rsp_inertia.plant.experiment import DEVICE_FILE, VIRTUAL_FILE, open_experiment
from rsp_inertia.plant.logs import Log
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import experiment_virtual
from rsp_inertia.virtual.device import simulate_braking
from tests.estimation.conftest import STAGES

STIFFNESS = 0.02
"""N m/rad, the torsion spring."""

PROTOCOL = {1: (19.56, 0.0131), 2: (19.74, 7.716)}
"""Stage: (launch_speed rad/s, braking_torque N m) for 3.1 turns in 2.0 s (module docstring)."""

TORQUE_LIMIT = 10.0
"""N m, the motor's limit in this scenario: above stage 2's braking torque."""

REALISATIONS = ((1, -30.0), (2, -29.6))
"""(seed, release angle deg): two torque-noise streams and two encoder quantization patterns."""

N_STD = 3.0
"""Every J_k within 3 of its reported standard deviations (the report's target)."""


def _set(text: str, key: str, values) -> str:
    """Set every ``key = ...`` line of a TOML text, in order, to the given values."""
    values = iter(values)
    text, count = re.subn(rf"(?m)^{key}\s*=\s*\S+", lambda _: f"{key} = {next(values)!r}", text)
    assert count > 0, key
    return text


def build(root, seed: int, release_deg: float):
    """The default experiment with the spring, the short protocol and one realisation.

    Parameters
    ----------
    root : pathlib.Path
        The experiment's folder.
    seed : int
        The virtual device's seed.
    release_deg : float
        deg, the release angle of the virtual run.

    Returns
    -------
    pathlib.Path
        ``root``.
    """
    create_default_experiment(root)
    device = root / DEVICE_FILE
    text = re.sub(
        r"(?m)^(\[spring\][^\n]*\n)stiffness\s*=\s*\S+",
        rf"\g<1>stiffness = {STIFFNESS!r}",
        device.read_text(),
    )
    text = _set(text, "launch_speed", [PROTOCOL[s][0] for s in STAGES])
    # Stage 2 brakes with 7.7 N m: a motor that can (the default's 0.5 N m limit cannot, and
    # the log readers refuse a torque beyond 10 x the limit as a logging fault).
    text = _set(text, "torque_limit", [TORQUE_LIMIT])
    device.write_text(_set(text, "braking_torque", [PROTOCOL[s][1] for s in STAGES]))
    virtual = root / VIRTUAL_FILE
    text = _set(virtual.read_text(), "seed", [seed])
    virtual.write_text(_set(text, "release_angle_deg", [release_deg]))
    return root


@pytest.fixture(scope="module")
def spring_experiment(tmp_path_factory):
    """(device, virtual) of the first realisation, no logs written."""
    exp = open_experiment(build(tmp_path_factory.mktemp("spring"), *REALISATIONS[0]))
    assert exp.device.spring.stiffness == STIFFNESS
    return exp.device, experiment_virtual(exp)


@pytest.fixture(scope="module")
def brakings(spring_experiment):
    """Each stage's braking pass with the simulator's truth (~0.2 s)."""
    device, virtual = spring_experiment
    return {s: simulate_braking(device, s, virtual) for s in STAGES}


@pytest.mark.parametrize("stage", STAGES)
def test_the_scenario_is_the_reported_one(stage, spring_experiment, brakings):
    device, virtual = spring_experiment
    truth = brakings[stage].truth
    assert truth.end_time == pytest.approx(2.0, abs=0.01)
    assert (truth.end_phi - truth.phi[0]) / (2 * math.pi) == pytest.approx(3.1, abs=0.01)
    # It ends at the spring's turning point: held there with the motor off, the spring would
    # turn the body back (its torque beats static friction, docs/method.md §4).
    assert STIFFNESS * truth.end_phi > virtual.friction.coulomb
    q = device.encoder.quantum
    sm = smooth_log(brakings[stage].log, q)
    assert sm.bandwidth == pytest.approx(390.0, rel=0.02)
    dt = device.encoder.dt
    block = block_length(sm.bandwidth, dt)
    assert block == 5
    assert sm.bandwidth * block * dt <= smoothing.BLOCK_BANDWIDTH


def _bias_and_jerk(sim, quantum):
    """The smoother's speed error on noise-free readings, and the true jerk, mid-pass.

    The readings are the true angle less half a count (what the smoother's z = y + q/2 turns
    back into the truth), so the error is the smoother's own bias on this motion. The first
    and last tenth are left out (start-up at both ends).
    """
    truth = sim.truth
    log = Log(t=truth.t, phi=truth.phi - quantum / 2, torque=truth.torque)
    error = smooth_log(log, quantum).omega - truth.omega
    jerk = np.gradient(np.gradient(truth.omega, truth.t), truth.t)
    n = len(truth.t)
    mid = slice(n // 10, n - n // 10)
    return error[mid], jerk[mid]


@pytest.mark.parametrize("stage", STAGES)
def test_the_block_models_speed_bias_is_the_derived_one(
    stage, spring_experiment, brakings, monkeypatch
):
    device, _ = spring_experiment
    q, dt = device.encoder.quantum, device.encoder.dt
    bandwidth = smooth_log(brakings[stage].log, q).bandwidth
    # The former fixed 10-sample block: the bias is kappa j with the derived kappa (smoothing
    # module docstring). Measured 3-4 % above it (the jerk is not constant over a block).
    monkeypatch.setattr(smoothing, "BLOCK_BANDWIDTH", 100.0)
    error, jerk = _bias_and_jerk(brakings[stage], q)
    kappa = block_speed_bias(10, bandwidth, dt)
    assert kappa == pytest.approx(6.9e-7, rel=0.05)
    measured = float(np.dot(error, jerk) / np.dot(jerk, jerk))
    assert measured == pytest.approx(kappa, rel=0.1)
    assert np.sqrt(np.mean(error**2)) > 5e-5  # the harm: 1e-4 rad/s that follows the jerk
    # The block length of the rule: kappa 200 times smaller, the bias under 1e-5 rad/s
    # (measured 0.6-1.2e-6; what is left is no longer the jerk's).
    monkeypatch.undo()
    block = block_length(bandwidth, dt)
    assert block_speed_bias(block, bandwidth, dt) < kappa / 200
    error, _ = _bias_and_jerk(brakings[stage], q)
    assert np.sqrt(np.mean(error**2)) < 1e-5


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """[(result, truth J_k)] per realisation: simulate braking and ideal reverse, identify (~6 s
    each)."""
    out = []
    for seed, release in REALISATIONS:
        root = build(tmp_path_factory.mktemp(f"spring{seed}"), seed, release)
        simulate(root, part="braking")
        simulate(root, part="reverse", ideal=True)
        result = identify(root)
        J = experiment_virtual(open_experiment(root)).body.tensor
        out.append((result, np.array([a.direction @ J @ a.direction for a in result.axes])))
    return out


def test_axial_moments_are_within_three_std(identified):
    for (result, true_J), (seed, release) in zip(identified, REALISATIONS):
        J = np.array([a.J for a in result.axes])
        std = np.array([a.J_std for a in result.axes])
        z = (J - true_J) / std
        assert np.all(np.abs(z) <= N_STD), (seed, release, z)
        # The reported std is of the right size, not inflated to pass: the errors are
        # ~1e-5 relative (the default experiment's level), the stds alike.
        assert np.all(std < 2e-5 * true_J), (seed, release, std / true_J)


def test_the_speed_noise_model_describes_the_residuals(identified):
    # On the ideal reverse the smoother's derived speed-error covariance is the whole story:
    # its calibrated scale stays near 1 (measured 0.9-1.2; 2-3 with the former block).
    for (result, _), (seed, release) in zip(identified, REALISATIONS):
        scales = np.array(result.speed_noise_scale)
        assert np.all((scales > 0.5) & (scales < 2.0)), (seed, release, scales)
        assert result.warnings == [], (seed, release)
