"""Logs as a drive's logger writes them: jittered time stamps, dropped rows, wrapped counts.

The time stamps are the drive's sampling instants (rsp_inertia.plant.logs.JITTER_LIMIT): the
smoother and the work sums use them as they are, a gap's missing torques are interpolated
with their uncertainty (rsp_inertia.estimation.passes.gap_work), and a gap near a node too
long for the smoother to bridge is refused (rsp_inertia.estimation.balance.check_node_gaps). Against the virtual truth,
never against an earlier run's numbers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import tomlkit
from scipy.stats import chi2

from rsp_inertia.estimation.balance import check_node_gaps
from rsp_inertia.estimation.passes import gap_work
from rsp_inertia.estimation.smoothing import (
    Smoothed,
    gap_speed_excess,
    largest_bridged_gap,
    smoother_bandwidth,
)
from rsp_inertia.identifying import identify
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.logs import Log, dropped_samples, motor_work, read_log, write_log
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import load_virtual


def _smoothed(t, phi, omega) -> Smoothed:
    n = t.size
    return Smoothed(
        t=t, phi=phi, omega=omega, eps=np.zeros(n), omega_std=np.ones(n), jerk_density=0.0,
        bandwidth=100.0,
    )


def test_gap_work_restores_the_work_of_a_torque_that_is_linear_across_the_gap():
    """A motion at constant acceleration (Hermite exact) under a torque linear in time: the
    zero-order-hold sum over the rows kept, plus the gap correction, is the full log's sum
    to rounding, and the interpolation's variance, measured on the log's own rows, is 0. So
    is its back-driven part, for a torque that changes sign (0.05 - 0.5 t: the motor drives
    the body until t = 0.1 s, then brakes it, the gap of three rows inside the braking)."""
    dt = 1e-3
    t = np.arange(200) * dt
    omega = 5.0 + 3.0 * t
    phi = 5.0 * t + 1.5 * t**2
    keep = np.ones(t.size, bool)
    keep[[50, 120, 121, 122]] = False  # a single row and a gap of three
    for torque in (0.2 - 0.5 * t, 0.05 - 0.5 * t):
        full = Log(t=t, phi=phi, torque=torque)
        log = Log(t=t[keep], phi=phi[keep], torque=torque[keep])
        smoothed = _smoothed(t[keep], phi[keep], omega[keep])
        dropped = dropped_samples(log.t, 1 / dt)
        correction, correction_back, variance = gap_work(log, smoothed, dropped)
        work = log.motor_work() + correction
        np.testing.assert_allclose(work, full.motor_work()[keep], rtol=0, atol=1e-15)
        np.testing.assert_allclose(variance, 0.0, atol=1e-30)
        _, back, _, _ = motor_work(log.torque, log.phi, False)
        _, full_back, _, _ = motor_work(full.torque, full.phi, False)
        np.testing.assert_allclose(back + correction_back, full_back[keep], rtol=0, atol=1e-15)
        assert (full_back[-1] < 0) == (torque[-1] < 0)


def test_gap_work_variance_is_the_interpolation_error_of_white_noise():
    """Torque of white noise sigma: a single row interpolated from its neighbours is off by
    u_k - (u_k-1 + u_k+1)/2, of variance 3/2 sigma^2; each gap then adds that times the
    squared angle the missing row held (to the sampling error of the mean square, a few
    percent over 20,000 rows)."""
    rng = np.random.default_rng(3)
    dt, sigma, speed = 1e-3, 1e-3, 10.0
    t = np.arange(20_000) * dt
    keep = np.ones(t.size, bool)
    keep[1000:19000:1000] = False
    phi, u = speed * t[keep], rng.normal(0.0, sigma, t.size)[keep]
    log = Log(t=t[keep], phi=phi, torque=u)
    smoothed = _smoothed(t[keep], phi, np.full(phi.size, speed))
    _, _, variance = gap_work(log, smoothed, dropped_samples(log.t, 1 / dt))
    expected = 18 * 1.5 * sigma**2 * (speed * dt) ** 2
    assert variance[-1] == pytest.approx(expected, rel=0.05)


@pytest.fixture(scope="module")
def experiments(tmp_path_factory):
    """The default experiment identified from its ideal reverse twice: as clean logs, and as
    a drive's logger writes them (stamps jittered by up to 0.2 of a period, one row in a
    thousand dropped, integer counts of a 16-bit counter). ~25 s."""
    out = {}
    for name, logger in (("clean", None), ("real", (0.2, 0.001, True))):
        root = create_default_experiment(tmp_path_factory.mktemp(name))
        if logger is not None:
            device = tomlkit.parse((root / "device.toml").read_text())
            device["encoder"]["counter_bits"] = 16
            (root / "device.toml").write_text(tomlkit.dumps(device))
            virtual = tomlkit.parse((root / "virtual.toml").read_text())
            virtual["logger"] = dict(zip(("time_jitter", "dropped_fraction", "counts"), logger))
            (root / "virtual.toml").write_text(tomlkit.dumps(virtual))
        simulate(root, part="braking")
        simulate(root, part="reverse", ideal=True)
        out[name] = (root, identify(root))
    return out


def test_real_logs_identify_as_the_clean_ones(experiments):
    """The logs really are a logger's (counts, jittered stamps, gaps); identified, they give
    the true tensor within its uncertainty (the six entries' chi^2 with their covariance
    under its 0.1% quantile, 22.5 for 6 degrees of freedom: a joint test, as the entries are
    correlated), without a warning, with stds at most 1.5 times the clean logs' (what the
    gaps' interpolated torques cost)."""
    root, real = experiments["real"]
    _, clean = experiments["clean"]
    header = (root / "stage1" / "reverse.csv").read_text().split("\n", 1)[0]
    assert header == "t,counts,torque"
    log = read_log(root / "stage2" / "braking.csv", _encoder(root), "braking")
    periods = np.diff(log.t) * 1000.0
    assert np.any(periods > 1.5) and np.abs(periods - np.rint(periods)).max() > 0.2
    true = np.asarray(load_virtual(root / "virtual.toml").body.inertia)
    for result in (clean, real):
        error = result.entries - true
        assert error @ np.linalg.solve(result.entries_cov, error) < chi2.ppf(0.999, 6), (
            error / np.sqrt(np.diag(result.entries_cov))
        )
    assert real.warnings == clean.warnings == []
    ratio = np.sqrt(np.diag(real.entries_cov) / np.diag(clean.entries_cov))
    assert np.all(ratio < 1.5), ratio


def _encoder(root):
    from rsp_inertia.plant.config import load_device

    return load_device(root / "device.toml").encoder


def _cut(path, rows: slice, encoder, kind):
    """Rewrite the log at ``path`` without the rows ``rows`` (a logger's gap)."""
    log = read_log(path, encoder, kind)
    keep = np.ones(len(log), bool)
    keep[rows] = False
    write_log(path, Log(t=log.t[keep], phi=log.phi[keep], torque=log.torque[keep]))
    return log


def test_a_long_gap_near_a_node_is_refused_with_its_line_and_time(experiments, tmp_path):
    """Thirty rows missing where the braking passes node 120 deg in its second turn, more
    than the smoother bridges there (14 on the default stage 1): identify refuses the log,
    naming the line after the gap, its size and times and the most it would bridge; the same
    gap half a turn away is accepted, and the balance angles inside it are left out."""
    source, _ = experiments["clean"]
    root = tmp_path / "exp"
    root.mkdir()
    for path in source.rglob("*"):
        target = root / path.relative_to(source)
        if path.is_dir():
            target.mkdir(exist_ok=True)
        elif path.name != "result.json":
            target.write_bytes(path.read_bytes())
    encoder = _encoder(root)
    path = root / "stage1" / "braking.csv"
    log = read_log(path, encoder, "braking")
    node = math.radians(120.0) + 2 * math.pi
    k = int(np.searchsorted(log.phi, node))
    gap = slice(k - 15, k + 15)
    _cut(path, gap, encoder, "braking")
    with pytest.raises(InputError) as error:
        identify(root)
    message = str(error.value)
    assert message.startswith(f"{path}, line {gap.start + 2}: 30 samples dropped")
    assert f"t = {log.t[gap.start - 1]:.6g} s and t = {log.t[gap.stop]:.6g} s" in message
    assert "node 120 deg" in message
    accepted = int(message.split("at most ")[1].split()[0])
    assert 10 < accepted < 30
    # Half a turn later the gap is far from every node (they are 120 deg apart).
    write_log(path, log)
    k = int(np.searchsorted(log.phi, node + math.pi / 3))
    _cut(path, slice(k, k + 30), encoder, "braking")
    result = identify(root)
    assert result.warnings == []


def test_check_node_gaps_refuses_only_gaps_too_long_to_bridge_at_balanced_nodes(default_device):
    """A gap at a node's passage one sample longer than the smoother bridges there is refused,
    saying how many it bridges; not when the passage lies outside the balanced range [lo, hi]
    (the slow end of a braking, say: the gap itself spans 0.24 rad); and a gap of that many is bridged, with its share of
    the balance's speed variance at most 1."""
    node = default_device.stages[0].nodes[1] + 2 * math.pi

    def log_without(missing: int) -> Log:
        k = np.arange(400)
        k = k[(k < 200) | (k >= 200 + missing)]
        t = k * 1e-3
        return Log(t=t, phi=node + 20.0 * (t - 0.2), torque=np.zeros(t.size))

    h = smoother_bandwidth(20.0) * 1e-3  # the log's top speed, 1 kHz
    largest = largest_bridged_gap(h, 2.0)
    assert gap_speed_excess(largest, h) <= 2.0 < gap_speed_excess(largest + 1, h)
    long_gap = log_without(largest + 1)
    with pytest.raises(
        InputError,
        match=rf"b\.csv, line 202: {largest + 1} samples .* at most {largest} samples in a row",
    ):
        check_node_gaps(default_device, 1, long_gap, "b.csv")
    assert check_node_gaps(default_device, 1, long_gap, "b.csv", lo=node + 0.4) == []
    assert check_node_gaps(default_device, 1, long_gap, "b.csv", hi=node - 0.2) == []
    (bridged,) = check_node_gaps(default_device, 1, log_without(largest), "b.csv")
    assert (bridged.missing, bridged.node_deg, bridged.largest) == (largest, 120.0, largest)
    assert 0.5 < bridged.ratio <= 1.0
