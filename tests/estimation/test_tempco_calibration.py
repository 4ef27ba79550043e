"""calibrate measures the torque constant's tempco alpha when its runs span enough magnet
temperature, and says when they do not (issue 37, item 1; rsp_inertia.estimation.tempco).

The virtual rig's motor (virtual.toml ``[rig]``) is a small NdFeB servo that warms through the
passes, whose true alpha, -0.0008/K, is three stated stds off what device.toml states
(-0.0011 +- 1e-4 /K); its logger logs the winding's temperature and the magnets follow through
5 s, as device.toml says. With ``run_start_rise`` the runs start 5 K apart (a motor not left to
cool between them), so the reference runs' torque scale follows the magnets over about 5 K;
without it every run starts at the ambient and the magnets move by a fraction of a kelvin.
"""

import dataclasses
import re

import numpy as np
import pytest

from rsp_inertia import calibrate, identify
from rsp_inertia.estimation.calibration_file import read_calibration_file, write_calibration_file
from rsp_inertia.estimation.reading import read_experiment
from rsp_inertia.estimation.runs import balance_runs
from rsp_inertia.estimation.tempco import TEMPCO_INFORMED
from rsp_inertia.plant.experiment import open_experiment
from tests.estimation.test_conventions import _folder as conventions_folder

TRUE_ALPHA = -0.0008
"""1/K, the virtual motor's."""
STATED_ALPHA, STATED_STD = -0.0011, 1e-4
"""1/K, what device.toml states: the truth 3 stated stds off."""
RISE = 5.0
"""K, how much warmer each run starts than the one before (two runs per folder)."""

MOTOR = f"""torque_gain_std = 0.0
torque_constant_tempco = {STATED_ALPHA}
torque_constant_tempco_std = {STATED_STD}
temperature_lag = 5.0
reference_temperature = 25.0"""
"""device.toml's [motor] tempco keys (the lag the virtual magnets', the ambient as T_ref)."""


def _rig(rise: float, alpha: float = TRUE_ALPHA) -> str:
    """virtual.toml's [rig]: the warming motor (benchmarks.experiments.warming_motor's, its
    winding heated by the current to a drift of 2e-4 between the passes) with the true alpha."""
    return f"""torque_constant_tempco = {alpha}
torque_constant = 0.5
winding_resistance = 2.93
thermal_resistance = 4.0
winding_time_constant = 60.0
magnet_lag = 5.0
run_start_rise = {rise}"""


def _folder(root, role: str, rise: float, seed: int, alpha: float = TRUE_ALPHA):
    """The default experiment as the body's, the empty fixture's or the reference's folder on
    the warming rig (tests/estimation/test_conventions.py's folders, not turned), its
    temperature logged and device.toml's tempco keys stated."""

    def tempco(device: str) -> str:
        return re.sub(r"torque_gain_std = 0\.0 .*", MOTOR, device) + (
            '\n[log]\ntemperature_column = "T"\n'
        )

    return conventions_folder(root, role, _rig(rise, alpha), seed, turned=False, device_edit=tempco)


def _calibrated(base, rise: float, alpha: float = TRUE_ALPHA):
    """(body, empty, reference) folders of the rig, and calibrate's result."""
    empty = _folder(base / "empty", "empty", rise, 2, alpha)
    reference = _folder(base / "reference", "reference", rise, 3, alpha)
    exp = _folder(base / "exp", "body", rise, 1, alpha)
    return exp, empty, reference, calibrate(exp, empty, reference)


@pytest.fixture(scope="module")
def spanning(tmp_path_factory):
    """Runs 5 K apart (about 30 s)."""
    return _calibrated(tmp_path_factory.mktemp("spanning"), RISE)


def test_the_tempcos_column_is_the_balances_finite_difference(tmp_path):
    # The balances are linear in alpha (rsp_inertia.estimation.tempco): the work parts of the
    # logs compensated with alpha + d, balanced from scratch (smoothed again), are those at
    # alpha plus d times the column's parts, on every run, at the same angles.
    exp = open_experiment(_folder(tmp_path / "exp", "body", RISE, 1))
    d = 3e-4
    before, _ = balance_runs(read_experiment(exp), [])
    after, _ = balance_runs(read_experiment(exp, STATED_ALPHA + d), [])
    moved = []
    for b0, b1 in zip(before, after, strict=True):
        assert np.array_equal(b0.phi, b1.phi)
        change = b1.motor_work_parts - b0.motor_work_parts
        predicted = d * b0.tempco_work_parts
        moved.append(np.abs(change).max() / np.abs(b0.motor_work_parts).max())
        # Linear but for rounding: 1e-16 of the works (J), summed over 1e4 rows and more.
        rounding = 1e-12 * np.abs(b0.motor_work_parts).max()
        np.testing.assert_allclose(change, predicted, rtol=0, atol=rounding)
        # The column is the whole balance's response: the work's change is the parts' sum.
        np.testing.assert_allclose(b1.work - b0.work, change.sum(axis=1), rtol=0, atol=rounding)
    # The second run's magnets are 5 K over T_ref: its work moves by about d 5 K = 1.5e-3.
    assert max(moved) > 1e-3


@pytest.mark.slow
def test_calibrate_measures_the_tempco_of_runs_that_span_temperature(spanning):
    exp, _, _, result = spanning
    calibration = result.calibration
    found = calibration.tempco_fit
    assert found.informed
    assert (result.tempco, result.tempco_std) == (found.estimate, found.std)
    # The truth within 3 of its stds, and measured far better than device.toml states it.
    assert abs(found.estimate - TRUE_ALPHA) < 3 * found.std
    assert found.std < STATED_STD / 3
    assert found.std**2 < TEMPCO_INFORMED * STATED_STD**2
    # One line, with the estimate, its std, the runs' span and the stated value.
    line = calibration.tempco
    assert "\n" not in line and "measured by the calibration runs" in line
    assert f"{found.estimate:.4g} +- {found.std:.2g} /K" in line
    assert f"{STATED_ALPHA:g} +- {STATED_STD:g} /K" in line
    span = float(re.search(r"their ([0-9.]+) K of magnet temperature", line).group(1))
    assert RISE - 1.0 < span < RISE + 2.0  # the second run 5 K warmer, its own warming on top
    assert not any("tempco" in w for w in calibration.warnings)
    # calibration.toml carries it, its covariance with the calibrated terms of theta.
    written = read_calibration_file(exp / "calibration.toml")
    assert written.motor.torque_constant_tempco == pytest.approx(found.estimate, rel=1e-12)
    assert written.motor.torque_constant_tempco_std == pytest.approx(found.std, rel=1e-12)
    assert len(written.motor.covariance) == len(written.covariance.parameters)
    # The gains' scale and alpha share the runs' mean temperature: correlated.
    h_d = written.covariance.parameters.index("h_d")
    assert written.motor.covariance[h_d] != 0.0


@pytest.mark.slow
def test_identify_applies_the_calibrated_tempco(spanning, tmp_path):
    # calibration.toml's alpha over device.toml's: identify gives what it gives on a device.toml
    # that states the calibrated alpha and std with calibration.toml's [motor] taken out.
    exp, _, _, calibrated = spanning
    found = calibrated.calibration.tempco_fit
    result = identify(exp)
    path = exp / "calibration.toml"
    device_path = exp / "device.toml"
    kept = path.read_text(), device_path.read_text()
    try:
        write_calibration_file(path, dataclasses.replace(read_calibration_file(path), motor=None))
        device_path.write_text(
            kept[1]
            .replace(f"torque_constant_tempco = {STATED_ALPHA}",
                     f"torque_constant_tempco = {found.estimate!r}")
            .replace(f"torque_constant_tempco_std = {STATED_STD}",
                     f"torque_constant_tempco_std = {found.std!r}")
        )
        stated = identify(exp)
    finally:
        path.write_text(kept[0])
        device_path.write_text(kept[1])
    np.testing.assert_array_equal(result.entries, stated.entries)
    np.testing.assert_array_equal(result.entries_std, stated.entries_std)


@pytest.mark.slow
def test_runs_at_one_temperature_keep_device_tomls_tempco(tmp_path):
    # Every run from the ambient: the magnets move by the passes' own warming only, too
    # little to measure alpha against what device.toml states.
    exp, _, _, result = _calibrated(tmp_path, 0.0)
    assert result.tempco is None
    calibration = result.calibration
    found = calibration.tempco_fit
    assert not found.informed and found.data_std > STATED_STD / 2
    line = calibration.tempco
    assert "\n" not in line
    assert "the calibration runs span only" in line and "is kept" in line
    assert f"+- {found.data_std:.2g} /K against device.toml's +- {STATED_STD:g} /K" in line
    # Not a warning: nothing on stderr, --strict not tripped.
    assert not any("tempco" in w for w in calibration.warnings)
    assert read_calibration_file(exp / "calibration.toml").motor is None


def test_identify_takes_calibration_tomls_tempco_and_warns_on_another_reference_temperature():
    # calibrated over stated; device.toml's alone without a [motor] table or without a tempco
    # of its own (no compensation configured: nothing to apply it to).
    from types import SimpleNamespace

    from rsp_inertia.estimation.reading import tempco_in_use

    def exp(alpha, t_ref=25.0):
        motor = SimpleNamespace(torque_constant_tempco=alpha, torque_constant_tempco_std=STATED_STD,
                                reference_temperature=t_ref)
        return SimpleNamespace(device=SimpleNamespace(motor=motor), calibration_path="cal.toml")

    measured = SimpleNamespace(motor=SimpleNamespace(
        torque_constant_tempco=TRUE_ALPHA, torque_constant_tempco_std=2e-5,
        reference_temperature=25.0))
    assert tempco_in_use(exp(STATED_ALPHA), measured) == (TRUE_ALPHA, 2e-5, [])
    assert tempco_in_use(exp(STATED_ALPHA), SimpleNamespace(motor=None)) == (
        STATED_ALPHA, STATED_STD, [])
    assert tempco_in_use(exp(STATED_ALPHA), None) == (STATED_ALPHA, STATED_STD, [])
    assert tempco_in_use(exp(None), measured)[0] is None
    _, _, warnings = tempco_in_use(exp(STATED_ALPHA, 23.0), measured)
    assert len(warnings) == 1 and "reference_temperature = 25 C, device.toml states 23 C" in (
        warnings[0])


@pytest.mark.slow
def test_runs_that_reject_the_stated_tempco_measure_it_alone_and_warn(tmp_path):
    # A motor whose alpha is 7 stated stds off (-0.0004/K, SmCo-like, where NdFeB's is
    # stated): the runs reject the prior, say so, and measure alpha by themselves.
    truth = -0.0004
    _, _, _, result = _calibrated(tmp_path, RISE, truth)
    found = result.calibration.tempco_fit
    assert found.prior_rejected and found.informed
    assert abs(found.estimate - truth) < 3 * found.std and found.data_std == found.std
    rejected = [w for w in result.warnings if "disagree with device.toml's torque_constant_tempco"
                in w]
    assert len(rejected) == 1 and "\n" not in rejected[0]
