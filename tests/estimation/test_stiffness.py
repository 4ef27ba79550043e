"""The torsion element's stiffness from the calibration folders' pendulum runs
(rsp_inertia.estimation.stiffness, the added-known-inertia method)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rsp_inertia.estimation.runs import ExperimentLogs
from rsp_inertia.estimation.stiffness import _two_period, calibrate_stiffness
from rsp_inertia.plant.config import load_reference, placed_reference
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.logs import read_log
from rsp_inertia.scenarios import create_rig_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import experiment_virtual
from rsp_inertia.virtual.device import true_parameters


def test_two_period_formula_is_the_textbook_one_without_gravity():
    """With no gravity and no change of the empty inertia between the equilibria, the
    elimination is c = M_r w_e^2 w_r^2 / (w_e^2 - w_r^2); and it inverts the forward model
    with gravity: frequencies made from a known c give c back."""
    c, M_e, M_r = 2.0, 0.012, 0.03
    w_e, w_r = math.sqrt(c / M_e), math.sqrt(c / (M_e + M_r))
    textbook = M_r * w_e**2 * w_r**2 / (w_e**2 - w_r**2)
    assert _two_period(w_e, w_r, np.zeros(2), np.zeros(2), 0.1, 0.2, 0.0, M_r) == pytest.approx(
        textbook, rel=1e-12
    )
    assert textbook == pytest.approx(c, rel=1e-12)
    Gf, Gr, phi_e, phi_r, d = np.array([0.01, -0.02]), np.array([0.03, 0.05]), 0.1, 0.13, 2e-4

    def k(G, phi):
        return -(G[0] * math.sin(phi) + G[1] * math.cos(phi))

    w_e = math.sqrt((c + k(Gf, phi_e)) / M_e)
    w_r = math.sqrt((c + k(Gf, phi_r) + k(Gr, phi_r)) / (M_e + d + M_r))
    assert _two_period(w_e, w_r, Gf, Gr, phi_e, phi_r, d, M_r) == pytest.approx(c, rel=1e-12)


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    """The demo rig's calibration folders with their pendulum runs (the torsion element is
    0.5% stiffer than device.toml's nominal 2 N m/rad)."""
    _, empty, reference = create_rig_experiment(tmp_path_factory.mktemp("rig") / "exp")
    for folder in (empty, reference):
        simulate(folder, part="pendulum")
    return open_experiment(empty), open_experiment(reference)


def _pendulum_logs(exp) -> ExperimentLogs:
    """The pendulum logs of a folder (it has no braking and reverse runs)."""
    device = exp.device
    nodes = [(s, k) for s, st in enumerate(device.stages, 1) for k in range(1, len(st.nodes) + 1)]
    return ExperimentLogs(
        device=device,
        runs={},
        pendulum={
            (s, k): read_log(exp.pendulum_path(s, k), device.encoder, "pendulum") for s, k in nodes
        },
    )


def test_calibrated_stiffness_recovers_the_rigs(rig):
    """From the true fixture gravity and empty harmonics (what the RSP calibration gives):
    the rig's true c within 3 of its std and 1e-3, every node's c within 3 of its own std,
    and the nominal value (0.5% off) excluded."""
    empty, reference = rig
    virtual = experiment_virtual(empty)
    device = empty.device
    fixture = virtual.fixture
    g = device.gravity
    G_f = np.array([fixture.mass * g * fixture.com[0], fixture.mass * g * fixture.com[1]])
    harmonics = np.array([
        true_parameters(device, s, virtual).inertia_harmonics
        for s in range(1, len(device.stages) + 1)
    ])
    # The reference as it sits on the rig: its folder's [mounting] turns it (calibrate's).
    body = placed_reference(
        load_reference(reference.root / "reference.toml").body, reference.device.mounting
    )
    cal = calibrate_stiffness(
        _pendulum_logs(empty), _pendulum_logs(reference), body, G_f, np.zeros((2, 2)), harmonics
    )
    truth = virtual.rig.pendulum_stiffness
    assert truth == 2.01
    assert len(cal.per_node) == 6
    assert abs(cal.stiffness - truth) <= 3 * cal.stiffness_std
    assert abs(cal.stiffness / truth - 1) < 1e-3
    assert abs(cal.stiffness - device.pendulum.stiffness) > 5 * cal.stiffness_std
    for _, _, c, std in cal.per_node:
        assert abs(c - truth) <= 3 * std


@pytest.mark.slow
def test_calibrate_writes_the_stiffness_and_identify_uses_it(rig, capsys):
    """End to end on the demo rig (ideal reverse for speed): calibrate measures c from the
    calibration folders' pendulum runs into calibration.toml [pendulum]; identify's best
    practice then takes it (result.json ``best_stiffness``), no longer warns about it, and
    its J_best are within 3 of their stds of the truth (device.toml's nominal c, 0.5% off,
    gave a warning and errors of about 0.5%)."""
    import json
    import tomllib

    from rsp_inertia.cli import main
    from rsp_inertia.identifying import identify
    from rsp_inertia.plant.geometry import tensor_from_entries

    empty, reference = rig
    root = empty.root.parent.parent
    for folder in (empty.root, reference.root, root):
        simulate(folder, part="braking")
        simulate(folder, part="reverse", ideal=True)
    simulate(root, part="pendulum")
    before = identify(root)
    assert any("no stiffness_std and no calibrated stiffness" in w for w in before.warnings)
    args = ["calibrate", str(root), "--empty", str(empty.root), "--reference", str(reference.root)]
    assert main(args) == 0
    assert "pendulum stiffness: 2.0" in capsys.readouterr().out
    with open(root / "calibration.toml", "rb") as file:
        table = tomllib.load(file)["pendulum"]
    assert abs(table["stiffness"] - 2.01) <= 3 * table["stiffness_std"]
    after = identify(root)
    assert not any("stiffness" in w for w in after.warnings)
    saved = json.loads((root / "result.json").read_text())["pendulum"]["best_stiffness"]
    assert saved == {"value": table["stiffness"], "std": table["stiffness_std"],
                     "source": "calibration.toml"}
    pend = after.pendulum
    exp = open_experiment(root)
    tensor = tensor_from_entries(experiment_virtual(exp).body.inertia)
    axes = pend.best_axes(exp.device)
    J_true = np.einsum("ij,jk,ik->i", axes, tensor, axes)
    assert np.all(np.abs(pend.J_best - J_true) <= 3 * pend.J_best_std)
