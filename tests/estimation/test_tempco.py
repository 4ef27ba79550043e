"""Temperature compensation of the torque constant in identify (issue 37, item 1).

The default experiment's logs (braking and ideal reverse) are the torques the body received;
each is rewritten as a logger at another magnet temperature would have logged it: the torque
the body received divided by 1 + alpha (T_mag - T_ref), with a temperature trace whose lagged
T_mag has a closed form (a ramp), so the truth of the compensation is known independently of
rsp_inertia.plant.transducers. The reverse runs warmer than the braking, as a motor that warms
up does: uncompensated, the passes' torque scales differ by about 3e-4.
"""

import dataclasses

import numpy as np
import pytest

from rsp_inertia.estimation.identify import TEMPCO_SOURCE
from rsp_inertia.estimation.reading import read_run
from rsp_inertia.identifying import identify
from rsp_inertia.plant.config import write_device
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.log_files import read_log_columns, write_log_file
from rsp_inertia.plant.log_layout import LogLayout
from rsp_inertia.plant.logs import read_device_log
from rsp_inertia.virtual.config import experiment_virtual
from tests.conftest import copy_experiment

ALPHA = -0.0011
"""1/K, NdFeB."""
ALPHA_STD = 1e-4
"""1/K."""
T_REF = 23.0
"""deg C, the torque's scale holds here (the calibration's temperature)."""
LAG = 5.0
"""s, the magnets behind the logged temperature."""
BRAKING_RISE = (0.0, 0.0)
"""K: the braking's logged temperature over T_REF at its start, and its rise over the pass:
none. A braking's drive holds its logged torque (the current) constant, and the body receives
it times the factor: the body's constant torque of these logs cannot be rewritten so, so the
braking runs at T_REF here (the warming braking: tests/plant/test_logs.py's constant work
with a factor, and the virtual motor's, benchmarks.warming)."""
REVERSE_RISE = (0.2, 0.1)
"""K: the reverse's, warmer: the motor works harder in it."""

N_STD = 4.0
"""Every entry within this many of its reported stds (as tests/estimation/test_identify.py)."""


def ramp_magnets(t: np.ndarray, start: float, rise: float) -> tuple[np.ndarray, np.ndarray]:
    """(T, T_mag): a logged temperature rising linearly by ``rise`` over the log from
    ``T_REF + start``, and its magnets' closed-form response through the lag
    (T_mag = T - r tau (1 - exp(-t / tau)), from T_mag = T at the first row)."""
    r = rise / t[-1]
    T = T_REF + start + r * t
    return T, T - r * LAG * (1.0 - np.exp(-t / LAG))


def warm_logs(root, tempco: bool) -> None:
    """Rewrite the experiment's logs at the warm motor's temperatures and its device.toml
    with a temperature column, and with the tempco's keys when ``tempco``."""
    exp = open_experiment(root)
    device = exp.device
    layout = LogLayout(temperature_column="T")
    for stage, st in enumerate(device.stages, 1):
        for direction in st.directions:
            for path, (start, rise) in (
                (exp.braking_path(stage, direction), BRAKING_RISE),
                (exp.reverse_path(stage, direction), REVERSE_RISE),
            ):
                columns = read_log_columns(path, LogLayout(), device.encoder)
                T, T_mag = ramp_magnets(columns.t, start, rise)
                logged = columns.torque / (1.0 + ALPHA * (T_mag - T_REF))
                write_log_file(path, columns.t, columns.phi, logged, layout, device.encoder,
                               temperature=T)
    motor = device.motor
    if tempco:
        motor = dataclasses.replace(
            motor, torque_constant_tempco=ALPHA, torque_constant_tempco_std=ALPHA_STD,
            temperature_lag=LAG, reference_temperature=T_REF,
        )
    write_device(exp.device_path, dataclasses.replace(device, motor=motor, log=layout))


@pytest.fixture(scope="module")
def warm(tmp_path_factory, default_logs):
    """(compensated, uncompensated, as logged by the body's torque, truth): the default
    experiment identified from the warm motor's logs with and without the tempco, and from
    its own logs."""
    results = {}
    for name, tempco in (("compensated", True), ("uncompensated", False)):
        root = copy_experiment(default_logs, tmp_path_factory.mktemp(name) / "exp")
        warm_logs(root, tempco)
        results[name] = identify(root)
    root = copy_experiment(default_logs, tmp_path_factory.mktemp("cold") / "exp")
    truth = experiment_virtual(open_experiment(root)).body.inertia
    return results["compensated"], results["uncompensated"], identify(root), truth


def test_the_compensated_warm_logs_give_the_true_tensor_within_its_stds(warm):
    compensated, _, _, truth = warm
    err = compensated.entries - truth
    assert np.all(np.abs(err) <= N_STD * compensated.entries_std), err / compensated.entries_std


def test_the_compensation_gives_the_body_torques_identification(warm):
    # The compensated logs are the body's torques again (to the written digits): the same
    # tensor as identified from the body's own logs, far within the noise.
    compensated, _, cold, _ = warm
    np.testing.assert_allclose(compensated.entries, cold.entries, rtol=0,
                               atol=1e-3 * cold.entries_std.min())


def test_uncompensated_the_tensor_is_off_by_the_tempcos_predicted_amount(warm):
    compensated, uncompensated, _, truth = warm
    # The balances are linear in alpha: leaving it out (alpha -> 0) moves every entry by
    # alpha / alpha_std times the budget line's response to one std of it.
    line = compensated.std_budget[TEMPCO_SOURCE]["tensor"]
    shift = np.abs(uncompensated.entries - compensated.entries)
    np.testing.assert_allclose(shift, abs(ALPHA / ALPHA_STD) * line, rtol=0.02,
                               atol=0.02 * line.max())
    # And it is far off: many reported stds on the largest entry.
    err = (uncompensated.entries - truth) / uncompensated.entries_std
    assert np.max(np.abs(err)) > 3 * N_STD, err


def test_the_tempcos_std_is_a_budget_line_that_adds_up(warm):
    compensated, _, cold, _ = warm
    line = compensated.std_budget[TEMPCO_SOURCE]["tensor"]
    assert np.all(line > 0)
    total = np.sqrt(sum(part["tensor"] ** 2 for part in compensated.std_budget.values()))
    np.testing.assert_allclose(total, compensated.entries_std, rtol=1e-9)
    # The rest of the budget is the body's own logs' budget.
    np.testing.assert_allclose(
        np.sqrt(compensated.entries_std**2 - line**2), cold.entries_std, rtol=1e-3
    )
    assert TEMPCO_SOURCE not in cold.std_budget


def test_without_a_tempco_the_logs_are_read_bit_for_bit(tmp_path, default_logs):
    # A temperature logged but no tempco stated: the estimators read the torque as logged.
    root = copy_experiment(default_logs, tmp_path / "exp")
    warm_logs(root, tempco=False)
    exp = open_experiment(root)
    for stage, st in enumerate(exp.device.stages, 1):
        for direction in st.directions:
            braking, reverse = read_run(exp, stage, direction)
            for log, path in ((braking, exp.braking_path(stage, direction)),
                              (reverse, exp.reverse_path(stage, direction))):
                as_read = read_device_log(path, exp.device, log_kind(path), direction)
                np.testing.assert_array_equal(log.torque, as_read.torque)
                assert log.temperature is not None


def log_kind(path) -> str:
    """"braking" or "reverse", from a run's log's file name."""
    return "braking" if path.name.startswith("braking") else "reverse"
