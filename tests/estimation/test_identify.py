"""Identification of the default experiment with the ideal reverse (estimation/identify.py).

The whole chain as a user runs it (create the experiment, simulate the braking and the ideal
reverse, identify from the files), compared with the virtual body of virtual.toml. Two bounds
on every number: the reported standard deviation (4 std: a 4-sigma excursion has probability
6e-5 per number, so over the ~20 numbers here a false alarm is a 1e-3 event), and the
issue's accuracy targets.
"""

import dataclasses
import io
import json
import math
import shutil

import numpy as np
import pytest

from rsp_inertia.design.mountings import best_cone_opening
from rsp_inertia.estimation.calibration import device_known_terms
from rsp_inertia.estimation.identify import identify_logs
from rsp_inertia.estimation.runs import ExperimentLogs
from rsp_inertia.identifying import identify
from rsp_inertia.plant.config import load_device, write_device
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.geometry import device_design, relative_errors, tensor_from_entries
from rsp_inertia.plant.logs import read_log, write_log
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual import device as vd
from rsp_inertia.virtual.config import experiment_virtual
from tests.conftest import copy_experiment

ENTRY_NAMES = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")

N_STD = 4.0
"""Every estimate within this many of its reported standard deviations (module docstring)."""

TARGET_AXIS_REL = 2e-5
"""Issue target: each axial moment J_k within 2e-5 relative."""

TARGET_ENTRY_REL = 2e-5
"""Issue target: each tensor entry within 2e-5 of the largest principal moment."""

TARGET_COM = 1e-4
"""Issue target: centre of mass within 0.1 mm."""


def axis(phi_deg: float, gear_ratio: float) -> np.ndarray:
    """Instantaneous axis e = (lam sin phi, lam cos phi, 1) / sqrt(1 + lam^2) (docs/method.md §1)."""
    phi = math.radians(phi_deg)
    lam = gear_ratio
    return np.array([lam * math.sin(phi), lam * math.cos(phi), 1.0]) / math.sqrt(1 + lam * lam)


@pytest.fixture(scope="module")
def ideal(tmp_path_factory, default_logs):
    """(root, result, truth): the default experiment identified from its ideal reverse."""
    root = copy_experiment(default_logs, tmp_path_factory.mktemp("ideal") / "exp")
    result = identify(root)
    exp = open_experiment(root)
    return root, result, experiment_virtual(exp)


def test_identify_logs_takes_the_logs_in_memory(ideal, monkeypatch):
    """identify_logs on the simulator's logs, handed over in memory with no file opened, is
    what identify finds from the folder the same simulator wrote."""
    root, result, virtual = ideal
    device = open_experiment(root).device
    runs = {}
    for stage in (1, 2):
        braking = vd.simulate_braking(device, stage, virtual)
        reverse = vd.simulate_ideal_reverse(device, stage, virtual, braking)
        runs[stage, Direction.FORWARD] = (braking.log, reverse.log)
    known, warnings = device_known_terms(device)

    def no_file(*args, **kwargs):
        raise AssertionError(f"identify_logs opened {args[:1]}")

    monkeypatch.setattr("builtins.open", no_file)
    monkeypatch.setattr(io, "open", no_file)
    in_memory = identify_logs(ExperimentLogs(device, runs), known, warnings=warnings)
    monkeypatch.undo()
    assert in_memory.provenance is None  # no files: nothing to record
    # identify records when and for what the result was made; identify_logs has no record.
    assert in_memory.to_dict() == {**result.to_dict(), "provenance": None, "record": None}


def test_a_locked_stage_gives_the_designs_one_z_axis(tmp_path):
    """A lambda = 0 stage listing three nodes turns about z at each: identify reports the
    device design's six axes and its cond(V) (rsp-inertia design's, 1.489), not the z axis
    once per node (eight axes, cond(V) 1.823 of the repeated rows)."""
    root = create_default_experiment(tmp_path / "cone")
    device = load_device(root / "device.toml")
    lam = math.tan(math.radians(best_cone_opening()[0]) / 2)
    cone = dataclasses.replace(
        device.stages[1], gear_ratio=lam, tare_inertia=(1 + lam**2) * 0.002 + lam**2 * 0.001,
        nodes_deg=(0.0, 72.0, 144.0, 216.0, 288.0), launch_speed=5.0, braking_torque=0.15,
    )
    locked = dataclasses.replace(
        device.stages[0], gear_ratio=0.0, tare_inertia=0.002, nodes_deg=(0.0, 120.0, 240.0)
    )
    device = dataclasses.replace(device, stages=(cone, locked), pendulum=None)
    write_device(root / "device.toml", device)
    simulate(root, part="braking")
    simulate(root, part="reverse", ideal=True)
    result = identify(root)
    design = device_design(device)
    assert result.condition_number == design.condition
    assert [(a.stage, a.phi_deg) for a in result.axes] == [
        (1, 0.0), (1, 72.0), (1, 144.0), (1, 216.0), (1, 288.0), (2, 0.0)
    ]
    np.testing.assert_array_equal([a.direction for a in result.axes], design.directions)
    Jz = experiment_virtual(open_experiment(root)).body.inertia[2]
    z = result.axes[-1]
    assert abs(z.J - Jz) <= N_STD * z.J_std
    assert abs(z.J_node - Jz) <= N_STD * z.J_node_std


def test_axial_moments_are_the_true_ones(ideal):
    root, result, truth = ideal
    device = open_experiment(root).device
    J = tensor_from_entries(truth.body.inertia)
    nodes = [(k, deg) for k, st in enumerate(device.stages, 1) for deg in st.nodes_deg]
    assert [(a.stage, a.phi_deg) for a in result.axes] == nodes
    for a in result.axes:
        e = axis(a.phi_deg, device.stages[a.stage - 1].gear_ratio)
        np.testing.assert_allclose(a.direction, e, rtol=0, atol=1e-15)
        true_J = e @ J @ e
        label = f"stage {a.stage} node {a.phi_deg}"
        assert abs(a.J - true_J) <= N_STD * a.J_std, label
        # The issue's target. The reported J_std of stage 1's axes is itself of order 2e-5
        # relative (torque-log noise), so this holds for the default realisation but the
        # noise level does not guarantee it for every seed (see test_uncertainty).
        assert abs(a.J - true_J) <= TARGET_AXIS_REL * true_J, label
        # The node formula (the paper's method) is right within its own uncertainty.
        assert abs(a.J_node - true_J) <= N_STD * a.J_node_std, label


def test_tensor_entries_are_the_true_ones(ideal):
    _, result, truth = ideal
    err = result.entries - truth.body.inertia
    assert np.all(np.abs(err) <= N_STD * result.entries_std), err / result.entries_std
    relative = relative_errors(result.entries, truth.body.inertia)
    assert np.all(np.abs(relative) <= TARGET_ENTRY_REL), relative
    node_std = np.sqrt(np.diag(result.node_entries_cov))
    node_err = result.node_entries - truth.body.inertia
    assert np.all(np.abs(node_err) <= N_STD * node_std), node_err / node_std


def test_centre_of_mass_is_the_true_one(ideal):
    _, result, truth = ideal
    err = result.com - truth.body.com[:2]
    assert np.all(np.abs(err) <= N_STD * result.com_std), err / result.com_std
    assert np.all(np.abs(err) <= TARGET_COM), err


def test_a_physical_body_raises_no_warning(ideal):
    _, result, _ = ideal
    assert result.warnings == []


def test_result_json_holds_the_interface(ideal):
    root, result, _ = ideal
    doc = json.loads((root / "result.json").read_text())
    assert set(doc["tensor"]) == set(ENTRY_NAMES)
    assert set(doc["tensor_std"]) == set(ENTRY_NAMES)
    np.testing.assert_array_equal([doc["tensor"][k] for k in ENTRY_NAMES], result.entries)
    np.testing.assert_array_equal([doc["tensor_std"][k] for k in ENTRY_NAMES], result.entries_std)
    assert len(doc["axes"]) == len(result.axes)
    for entry, a in zip(doc["axes"], result.axes, strict=True):
        assert {"stage", "phi_deg", "direction", "J", "J_std"} <= set(entry)
        assert (entry["stage"], entry["phi_deg"], entry["J"], entry["J_std"]) == (
            a.stage, a.phi_deg, a.J, a.J_std
        )
        assert entry["direction"] == pytest.approx(list(a.direction), abs=0)
    assert set(doc["com"]) == {"x", "y"}
    assert [doc["com"]["x"], doc["com"]["y"]] == list(result.com)
    assert doc["warnings"] == []
    # The icosahedron design (docs/method.md §5): cond(V) = sqrt(5/2). The gear ratios in
    # device.toml carry ten decimals, which moves it by far less than 1e-9.
    assert doc["condition_number"] == pytest.approx(math.sqrt(5 / 2), abs=1e-9)


def test_result_json_holds_the_joint_covariance_of_entries_and_gravity(ideal):
    """result.json's ``covariance``: the least squares' 8 x 8 of the entries and the gravity
    terms (what a combination of mountings needs), its diagonal the reported stds squared, its
    off-diagonal blocks their correlation (the fit solves them together)."""
    root, result, _ = ideal
    doc = json.loads((root / "result.json").read_text())
    assert "tensor_cov" not in doc
    cov = np.array(doc["covariance"])
    assert cov.shape == (8, 8)
    np.testing.assert_array_equal(cov, cov.T)
    std = [*(doc["tensor_std"][k] for k in ENTRY_NAMES), *doc["gravity_torque"]["std"]]
    np.testing.assert_allclose(np.diag(cov), np.square(std), rtol=1e-15, atol=0)
    np.testing.assert_array_equal(cov[:6, :6], result.entries_cov)
    np.testing.assert_array_equal(cov[6:, 6:], result.gravity_cov)
    assert np.all(np.linalg.eigvalsh(cov / np.outer(std, std)) > 0)


def test_principal_moments_and_axes_diagonalise_the_tensor(ideal):
    root, _, _ = ideal
    doc = json.loads((root / "result.json").read_text())
    J = tensor_from_entries([doc["tensor"][k] for k in ENTRY_NAMES])
    moments = np.array(doc["principal_moments"])
    axes = np.array(doc["principal_axes"])
    scale = np.abs(moments).max()
    # Rounding only: eigen-decomposition of a 3x3 symmetric matrix, relative 1e-14.
    np.testing.assert_allclose(np.sort(moments), np.linalg.eigvalsh(J), rtol=0, atol=1e-13 * scale)
    np.testing.assert_allclose(axes @ axes.T, np.eye(3), rtol=0, atol=1e-12)
    for m, v in zip(moments, axes, strict=True):
        np.testing.assert_allclose(J @ v, m * v, rtol=0, atol=1e-13 * scale)


def test_a_drifting_braking_torque_is_named_in_a_warning(ideal, tmp_path):
    # The constant-torque model of the braking pass is checked on the log (rsp_inertia.estimation.passes):
    # a drift of one noise std over stage 1's pass makes identify fall back to row sums and say
    # so. (Only the log drifts here, not the torque the simulator applied, so the log now
    # misstates the work by ~1e-4 of it: the numbers are not checked against the truth.)
    root, result, virtual = ideal
    copy = tmp_path / "exp"
    shutil.copytree(root, copy)
    exp = open_experiment(copy)
    path = exp.braking_path(1)
    log = read_log(path, exp.device.encoder, "braking")
    drift = virtual.run.torque_noise * np.linspace(-0.5, 0.5, len(log))
    path.unlink()
    write_log(path, dataclasses.replace(log, torque=log.torque + drift))
    drifted = identify(copy)
    assert any("stage1/braking.csv" in w and "not constant" in w for w in drifted.warnings)
    assert not any("not constant" in w for w in result.warnings)
    # Row sums carry the braking log's noise as a random walk: a larger uncertainty.
    assert drifted.axes[0].J_std > result.axes[0].J_std


def test_uncertainty_budget_adds_up_to_the_reported_std(ideal):
    # The sources are independent, so their variances add up to the total (rsp_inertia.estimation.tensor_fit).
    _, result, _ = ideal
    assert set(result.std_budget) == {
        "braking torque log", "reverse torque log", "encoder (speed)", "encoder (work)",
        "friction slopes",
    }
    total_axes = sum(part["axes"] ** 2 for part in result.std_budget.values())
    np.testing.assert_allclose(np.sqrt(total_axes), [a.J_std for a in result.axes], rtol=1e-6)
    total_entries = sum(part["tensor"] ** 2 for part in result.std_budget.values())
    np.testing.assert_allclose(np.sqrt(total_entries), result.entries_std, rtol=1e-6)
    # Every source of the logs' noise counts on the default experiment: none is below a tenth
    # of the total. The smoothed angle's error under a changing torque does not: the ideal
    # reverse's torque is smooth (passes.angle_work_variance), under 1% of the total; nor do
    # the friction slopes' priors: an ideal reverse's mismatch is speed noise, whose friction
    # work is tiny whatever the slopes.
    J_std = np.array([a.J_std for a in result.axes])
    for name, part in result.std_budget.items():
        if name in ("encoder (work)", "friction slopes"):
            assert np.all(part["axes"] < 0.01 * J_std)
        else:
            assert np.all(part["axes"] > 0.1 * J_std)
