"""Gaps of dropped samples bridged by the smoother (docs/method.md §5, the balance at common
angles; rsp_inertia.estimation.smoothing.gap_speed_covariance,
rsp_inertia.estimation.balance.check_node_gaps).

The added variance is checked against the smoother's actual errors (a Monte Carlo over white
readings), and identify against the virtual truth, never against an earlier run's numbers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2

from rsp_inertia.cli import main
from rsp_inertia.estimation.smoothing import (
    _chain_speed_covariance,
    _gap_chain,
    gap_speed_covariance,
    gap_speed_excess,
    hermite,
    largest_bridged_gap,
    median_step,
    smooth_log,
)
from rsp_inertia.identifying import identify
from rsp_inertia.plant.config import load_device
from rsp_inertia.plant.logs import Log, read_log
from rsp_inertia.virtual.config import load_virtual
from tests.conftest import copy_experiment

NODE_DEG = 120.0
"""The node of stage 1 whose passage the gaps are cut at (its second turn)."""


# --- the smoother over a gap ------------------------------------------------------------------


@pytest.mark.parametrize("h, tolerance", [(0.24, 0.07), (0.07, 0.01), (0.024, 1e-3), (0.007, 1e-3)])
def test_the_gap_chain_without_a_gap_is_the_derived_stationary_smoother(h, tolerance):
    """The batch form of the block smoother's model away from its ends: the speed's error
    from the readings' noise is r w_c^3 / 12 (the derived R(0)) and the model's own
    r w_c^3 / 6, at the default stages' w_c dt (0.24, 0.07) and at 10 kHz (0.024, 0.007).
    Where a block spans w_c T = 1.9 (8 samples at 0.24) both move with the instant's place in
    its block, by up to 7 %, about the derived value (the block model's; the log's own speed
    errors: 0.75-1.05 of it, tests/estimation/test_smoothing.py)."""
    at = np.array([-20 / h, 0.5, 0.77, 3 + 20 / h])
    noise, model = _chain_speed_covariance(_gap_chain(3, h, 0, True), at)
    np.testing.assert_allclose(np.diag(noise), 1 / 12, rtol=tolerance)
    np.testing.assert_allclose(np.diag(model), 1 / 6, rtol=tolerance)


def test_a_gap_adds_nothing_far_from_it_and_more_the_longer_it_is():
    """The added covariance dies out beyond GAP_REACH / w_c; the smoother's own added
    variance grows with the gap, and largest_bridged_gap is where it crosses the allowance."""
    noise, model = gap_speed_covariance(5, 0.24, np.array([-20 / 0.24, 6 + 20 / 0.24]))
    assert np.abs(noise).max() < 1e-5 / 12 and np.abs(model).max() < 1e-5 / 6
    excess = [gap_speed_excess(n, 0.24) for n in (1, 3, 5, 10, 20)]
    assert np.all(np.diff(excess) > 0), excess
    largest = largest_bridged_gap(0.24, 2.0)
    assert gap_speed_excess(largest, 0.24) <= 2.0 < gap_speed_excess(largest + 1, 0.24)


def _speed_errors(missing: int, runs: int, harmonic: float):
    """The smoothed speed's errors at instants about a gap of ``missing`` samples after row
    1000 of a 2 s braking at 12 rad/s and 1 kHz (the default stage 1: w_c = 240 rad/s), with
    and without the gap, over ``runs`` draws of white readings of variance q^2 / 12 (the
    smoother's noise model), the speed rippling by ``harmonic`` of itself at 2 Omega.

    Returns (errors with the gap, errors without, the instants' offsets in periods from
    row 1000, the unit r w_c^3, w_c dt)."""
    rng = np.random.default_rng(11)
    q, dt = 2 * math.pi / 65536, 1e-3
    t = np.arange(2000) * dt
    w0, decel = 12.0, 2.0
    ripple = harmonic * w0

    def motion(time, offset):
        phi = offset + w0 * time - decel * time**2 / 2 + ripple * (1 - np.cos(2 * w0 * time)) / (2 * w0)
        return phi, w0 - decel * time + ripple * np.sin(2 * w0 * time)

    keep = np.ones(t.size, dtype=bool)
    keep[1001 : 1001 + missing] = False
    errors = {True: [], False: []}
    for _ in range(runs):
        offset = rng.uniform(0.0, 1000 * q)
        phi, _ = motion(t, offset)
        readings = phi - q / 2 + rng.normal(0.0, q / math.sqrt(12), t.size)
        for gap, rows in ((True, keep), (False, np.ones(t.size, dtype=bool))):
            sm = smooth_log(Log(t=t[rows], phi=readings[rows], torque=np.zeros(rows.sum())), q)
            at = t[1000] + np.arange(-6.0, (missing + 1) * dt * sm.bandwidth + 6.0, 0.5) / sm.bandwidth
            k = np.searchsorted(sm.t, at, side="right") - 1
            omega = hermite(
                sm.t[k], sm.t[k + 1], sm.omega[k], sm.eps[k], sm.omega[k + 1], sm.eps[k + 1], at
            )
            errors[gap].append(omega - motion(at, offset)[1])
    unit = sm.noise_density * sm.bandwidth**3
    return (
        np.array(errors[True]), np.array(errors[False]), (at - t[1000]) / dt, unit,
        sm.bandwidth * dt,
    )


def test_the_added_variance_is_the_smoothers_actual_one():
    """Five samples dropped: the speed's error variance about the gap grows as
    gap_speed_covariance's noise part says. 300 draws of white readings, with and without the
    gap on the same draws; over the instants where the prediction is above a third of its
    peak (about 4 / w_c of them), the measured added variance sums to 0.7-1.4 of the
    predicted (the draws' own scatter is about 10 %; measured: 1.10 here, 1.07 for 14
    samples)."""
    with_gap, without, offsets, unit, h = _speed_errors(5, 300, 0.0)
    measured = (np.mean(with_gap**2, axis=0) - np.mean(without**2, axis=0)) / unit
    predicted, _ = gap_speed_covariance(5, h, offsets)
    peak = np.diag(predicted) > np.diag(predicted).max() / 3
    ratio = measured[peak].sum() / np.diag(predicted)[peak].sum()
    assert 0.7 < ratio < 1.4, ratio


def test_a_bridged_gap_leaves_no_bias_on_a_rippling_speed():
    """A 2 % speed ripple at 2 Omega (M's harmonics) across the largest gap bridged on the
    default stage 1 (14 samples): the smoother's mean error about the gap stays within 0.3
    of the speed's stationary error std (r w_c^3 / 12), as no filter block spans the gap (a
    block across a 20-sample gap biased the speed by 1.3 times that, the module docstring of
    rsp_inertia.estimation.smoothing). The mean over 200 draws scatters by 0.07-0.1 of it at
    each instant, so the largest of the ~60 instants reaches 0.2 by chance (measured: 0.13)."""
    missing = largest_bridged_gap(0.24, 2.0)
    with_gap, _, _, unit, _ = _speed_errors(missing, 200, 0.02)
    bias = np.abs(with_gap.mean(axis=0)) / math.sqrt(unit / 12)
    assert bias.max() < 0.3, bias.max()


# --- identify with a gap at a node's passage -----------------------------------------------


@pytest.fixture(scope="module")
def clean(tmp_path_factory, default_logs):
    """(root, result): the default experiment identified as simulated."""
    root = copy_experiment(default_logs, tmp_path_factory.mktemp("clean") / "exp")
    return root, identify(root)


def _drop_at_node(root, rows: int, after: int) -> tuple[int, int]:
    """``rows`` rows of stage 1's braking dropped so that the last row missing lies ``after``
    rows before the braking passes NODE_DEG in its second turn (from its logged angle).
    Returns (the row before the gap, the node's row) in the log as cut."""
    path = root / "stage1" / "braking.csv"
    header, *data = path.read_text().splitlines()
    phi = np.array([float(row.split(",")[1]) for row in data])
    node = int(np.searchsorted(phi, math.radians(NODE_DEG + 360.0)))
    stop = node - after
    del data[stop - rows : stop]
    path.write_text("\n".join([header, *data]) + "\n")
    return stop - rows - 1, node - rows


def test_five_samples_dropped_at_a_node_are_bridged(clean, tmp_path):
    """Five rows of the braking lost just before it passes node 120 deg (the passage 1.5 / w_c
    after the gap, where the gap's added variance peaks): identify accepts the run; its tensor
    holds the truth within its uncertainty (the six entries' chi^2 with their covariance
    under the 0.1% quantile, 22.5 on 6 degrees of freedom, and each axial moment within 3
    stds); the node formula at that node is less sure than without the gap; and the budget
    carries the gap's own line, which the clean logs do not have. The least squares' stds
    grow, by less than 1 % (the gap is one passage of ~20 turns; each run's speed-noise
    scale is fitted again, and moves them by about as much as the gap)."""
    root_clean, base = clean
    root = copy_experiment(root_clean, tmp_path / "exp")
    (root / "result.json").unlink(missing_ok=True)
    _drop_at_node(root, 5, 6)
    result = identify(root)
    truth = np.asarray(load_virtual(root / "virtual.toml").body.inertia)
    error = result.entries - truth
    assert error @ np.linalg.solve(result.entries_cov, error) < chi2.ppf(0.999, 6)
    J = np.zeros((3, 3))
    J[np.diag_indices(3)] = truth[:3]
    J[0, 1] = J[1, 0] = truth[3]
    J[1, 2] = J[2, 1] = truth[4]
    J[0, 2] = J[2, 0] = truth[5]
    for a in result.axes:
        assert abs(a.J - a.direction @ J @ a.direction) <= 3 * a.J_std, (a.stage, a.phi_deg)
    (gapped,) = [a for a in result.axes if (a.stage, a.phi_deg) == (1, NODE_DEG)]
    (whole,) = [a for a in base.axes if (a.stage, a.phi_deg) == (1, NODE_DEG)]
    assert gapped.J_node_std > whole.J_node_std
    assert "dropped samples (speed)" in result.std_budget
    assert "dropped samples (speed)" not in base.std_budget
    assert np.all(result.std_budget["dropped samples (speed)"]["tensor"] > 0)
    assert np.all(result.entries_std > base.entries_std)
    assert np.all(result.entries_std < 1.01 * base.entries_std)


def test_a_gap_at_a_node_too_long_to_bridge_is_refused(clean, tmp_path, capsys):
    """One row more than the smoother bridges there (the largest whose added variance of
    the speed stays within the balance's, computed here from the logs' own smoothers: their
    w_c dt and noise levels), at the node's passage: identify exits 2 with one line naming the
    braking log, the line after the gap, its size and the most it would bridge, and writes
    no result."""
    root_clean, _ = clean
    root = copy_experiment(root_clean, tmp_path / "exp")
    (root / "result.json").unlink(missing_ok=True)
    encoder = load_device(root / "device.toml").encoder
    logs = [read_log(root / "stage1" / f"{kind}.csv", encoder, kind) for kind in ("braking", "reverse")]
    smoothed = [smooth_log(log, encoder.quantum) for log in logs]
    levels = [sm.noise_density * sm.bandwidth**3 for sm in smoothed]
    h = smoothed[0].bandwidth * median_step(smoothed[0].t)
    largest = largest_bridged_gap(h, 1.0 + levels[1] / levels[0])
    before, _ = _drop_at_node(root, largest + 1, 0)
    status = main(["identify", str(root)])
    err = capsys.readouterr().err.strip()
    assert status == 2 and len(err.splitlines()) == 1, err
    path = root / "stage1" / "braking.csv"
    assert f"{path}, line {before + 3}: {largest + 1} samples dropped" in err
    assert f"node {NODE_DEG:g} deg (stage 1)" in err
    assert f"at most {largest} samples in a row may be missing there" in err
    assert not (root / "result.json").exists()
