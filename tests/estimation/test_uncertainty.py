"""The reported uncertainty against a Monte Carlo of the virtual device.

Each realisation is the default experiment (both stages, ideal reverse) with its own
torque-noise seed and a release angle moved by a random fraction of a degree, so that the
encoder's quantization pattern changes too. Errors are taken against the virtual body; a
reported standard deviation is honest when the errors scatter like it.
"""

import re
from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import chi2

from rsp_inertia.identifying import identify
from rsp_inertia.plant.config import load_device, write_device
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.geometry import tensor_from_entries
from rsp_inertia.plant.logs import read_log, write_log
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import experiment_virtual
from tests.conftest import copy_experiment

RELEASE_JITTER_DEG = 0.5
"""Release angles are drawn uniformly within this of the default (up to ~90 counts away)."""


def _set(text: str, key: str, value) -> str:
    text, count = re.subn(rf"(?m)^{key}\s*=\s*\S+", f"{key} = {value!r}", text)
    assert count == 1, f"virtual.toml has no single {key}"
    return text


def realisation(root, seed: int, release_deg: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Identify one realisation; its errors and reported stds, by family of estimates."""
    create_default_experiment(root)
    path = root / "virtual.toml"
    text = _set(path.read_text(), "seed", seed)
    path.write_text(_set(text, "release_angle_deg", release_deg))
    simulate(root, part="braking")
    simulate(root, part="reverse", ideal=True)
    result = identify(root)
    body = experiment_virtual(open_experiment(root)).body
    J = tensor_from_entries(body.inertia)
    true_axes = np.array([a.direction @ J @ a.direction for a in result.axes])
    return {
        "tensor entries": (result.entries - body.inertia, result.entries_std),
        "centre of mass": (result.com - body.com[:2], result.com_std),
        "axial moments": (
            np.array([a.J for a in result.axes]) - true_axes,
            np.array([a.J_std for a in result.axes]),
        ),
        "node formula": (
            np.array([a.J_node for a in result.axes]) - true_axes,
            np.array([a.J_node_std for a in result.axes]),
        ),
    }


def draws(n: int, entropy: int, virtual) -> list[tuple[int, float]]:
    """n (seed, release angle) pairs around ``virtual``'s run settings, reproducible."""
    rng = np.random.default_rng(entropy)
    default = virtual.run.release_angle_deg
    return [
        (int(rng.integers(1, 2**31)), default + float(rng.uniform(-1, 1)) * RELEASE_JITTER_DEG)
        for _ in range(n)
    ]


def test_errors_stay_within_five_std(tmp_path, default_virtual):
    # Two realisations only (~13 s): a gross check that the reported
    # uncertainty is not overconfident. 5 std: probability 6e-7 per number for honest stds.
    for k, (seed, release) in enumerate(draws(2, entropy=20240611, virtual=default_virtual)):
        families = realisation(tmp_path / f"r{k}", seed, release)
        for name, (err, std) in families.items():
            assert np.all(np.abs(err) < 5 * std), (name, seed, release, err / std)


N_REALISATIONS = 10


@pytest.fixture(scope="module")
def monte_carlo(tmp_path_factory, default_virtual):
    """{family: (errors, stds)} stacked over N_REALISATIONS realisations (~8 s each)."""
    pairs = draws(N_REALISATIONS, entropy=7, virtual=default_virtual)
    runs = [
        realisation(tmp_path_factory.mktemp(f"mc{k}"), seed, release)
        for k, (seed, release) in enumerate(pairs)
    ]
    return {
        name: (np.array([r[name][0] for r in runs]), np.array([r[name][1] for r in runs]))
        for name in runs[0]
    }


def honest_band(n: int, tail: float = 1e-3) -> tuple[float, float]:
    """Band that holds the mean of n independent (error/std)^2 with probability 1 - 2 tail.

    For honest standard deviations and Gaussian errors the mean is chi^2_n / n.
    """
    return chi2.ppf(tail, n) / n, chi2.ppf(1 - tail, n) / n


@pytest.mark.slow
@pytest.mark.parametrize("family", ["tensor entries", "centre of mass", "axial moments"])
def test_least_squares_std_matches_the_scatter(family, monte_carlo):
    err, std = monte_carlo[family]
    mean_sq = float(np.mean((err / std) ** 2))
    # Within a realisation the numbers of a family are correlated (the six axial moments
    # come from one tensor, stage 1's three axes share Jz). The least favourable case, full
    # correlation, leaves one independent square per realisation: n = N_REALISATIONS, a band
    # of [0.15, 2.96] for 10. Less correlation only narrows the true spread.
    lo, hi = honest_band(N_REALISATIONS)
    assert lo < mean_sq < hi, (family, mean_sq)


@pytest.mark.slow
def test_node_formula_std_matches_the_scatter(monte_carlo):
    err, std = monte_carlo["node formula"]
    mean_sq = float(np.mean((err / std) ** 2))
    # The node formula's std is almost all speed noise (the torque-noise part is under one
    # per cent of its variance), sampled at nodes 60 deg or more apart, where the smoother's
    # errors (correlated over 1 / w_c, a few hundredths of a radian) are independent: each
    # number is its own square, n = 6 N_REALISATIONS, a band of [0.55, 1.65] for 60.
    lo, hi = honest_band(err.size)
    assert lo < mean_sq < hi, mean_sq


@pytest.mark.parametrize("logged_gain, current", [(1.0, False), (1.01, False), (1.01, True)])
def test_a_stated_torque_gain_std_is_propagated_not_fitted(
    tmp_path, default_logs, logged_gain, current
):
    """Without a calibration, a torque gain known to 1% (device.toml's torque_gain_std, tares
    exact): the balances are homogeneous in the tensor and the torque's scale, so the runs
    cannot measure the gain; the tensor must come out as the logged torque says (1% high when
    the logs read 1% high) with a std of about 1%, never pulled toward zero (a fit with fixed
    weights took it 23% low, 22 stds, before the common scale was propagated instead). With
    ``current``, the drive logs its current and device.toml states the torque constant 1%
    high with a std of 1% of it (torque_constant_std), and no torque_gain_std."""
    root = copy_experiment(default_logs, tmp_path / "exp")
    device = load_device(root / "device.toml")
    stages = tuple(replace(st, tare_inertia_std=0.0) for st in device.stages)
    motor = replace(device.motor, torque_gain_std=0.01)
    constant = 0.05  # N m/A
    if current:
        motor = replace(
            device.motor, torque_constant=constant * logged_gain, torque_constant_std=0.01 * constant
        )
        device = replace(device, log=replace(device.log, torque_unit="A"))
    write_device(root / "device.toml", replace(device, motor=motor, stages=stages))
    for path in sorted(root.glob("stage*/*.csv")):  # the rig logs logged_gain x its torque
        if path.name.startswith(("braking", "reverse")):
            kind = path.stem.split("_")[0]
            log = read_log(path, device.encoder, kind)
            if current:  # the true current; read with the stated constant, logged_gain x it
                write_log(path, replace(log, torque=log.torque / constant),
                          layout=device.log, encoder=device.encoder, torque_constant=1.0)
            else:
                write_log(path, replace(log, torque=log.torque * logged_gain))
    result = identify(root)
    body = experiment_virtual(open_experiment(root)).body
    expected = body.inertia * logged_gain
    err = result.entries - expected
    std = np.asarray(result.entries_std)
    assert np.all(np.abs(err) < 3 * std), err / std
    # The std is the gain's: 1% of each product of inertia (the noise adds a few 1e-6); a
    # moment's a little more, as the gain scales the whole reduced inertia, the exact tare's
    # share too, and the tare is taken off it.
    relative = std / np.abs(expected)
    assert np.allclose(relative[3:], 0.01, rtol=0.02), relative
    assert np.all((relative[:3] > 0.01) & (relative[:3] < 0.013)), relative
    assert "calibration: drive gains" in result.std_budget
