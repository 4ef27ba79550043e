"""The closed-loop rehearsal of a plan (rsp_inertia.design.rehearsal) and the pieces it stands on."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from rsp_inertia.cli import main
from rsp_inertia.design.candidates import StageModel
from rsp_inertia.design.plan import map_stages
from rsp_inertia.design.rehearsal import consistent_models
from rsp_inertia.estimation.reading import read_run
from rsp_inertia.estimation.runs import estimate_run
from rsp_inertia.ocp.program import make_program
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.geometry import axis_direction, design_matrix, entries_from_tensor
from rsp_inertia.plant.model import inertia_harmonics
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import ControllerSettings, Friction, RunSettings, Virtual
from rsp_inertia.virtual.device import integrate_to_stop, simulate_braking, true_parameters


def _square(a: float, b: float) -> float:
    return a * a + b


def test_map_stages_is_the_plain_map():
    jobs = [(float(k), 0.5) for k in range(5)]
    assert map_stages(_square, jobs) == [_square(*job) for job in jobs]


def test_consistent_models_keep_a_consistent_body(default_device, default_virtual):
    """Models of one body (the virtual device's) come back unchanged; a stage whose
    harmonics are off alone is pulled to the one tensor that fits all stages."""
    device = default_device
    models = [
        StageModel(s, true_parameters(device, s, default_virtual), 1e-4, "truth") for s in (1, 2)
    ]
    for sm, back in zip(models, consistent_models(device, models)):
        np.testing.assert_allclose(back.inertia_harmonics, sm.model.inertia_harmonics, atol=1e-15)
        assert back.gravity_sin == pytest.approx(sm.model.gravity_sin, rel=1e-12)
    off = dataclasses.replace(
        models[0].model, inertia_harmonics=models[0].model.inertia_harmonics * 1.01,
        gravity_sin=models[0].model.gravity_sin * 1.2,
    )
    pulled = consistent_models(device, [dataclasses.replace(models[0], model=off), models[1]])
    # One tensor behind both: solving each stage's harmonics for it gives the same entries.
    rows = np.vstack([
        np.column_stack([inertia_harmonics(e, st.gear_ratio, 0.0) for e in np.eye(6)])
        for st in device.stages
    ])
    rhs = np.concatenate([
        m.inertia_harmonics - inertia_harmonics(np.zeros(6), 0.0, st.tare_inertia)
        for m, st in zip(pulled, device.stages)
    ])
    tensor, *_ = np.linalg.lstsq(rows, rhs, rcond=None)
    assert np.linalg.norm(rows @ tensor - rhs) <= 1e-12 * np.linalg.norm(rhs)
    assert pulled[0].gravity_sin == pulled[1].gravity_sin


def test_virtual_models_replace_the_truth(default_device, default_virtual):
    """A Virtual with ``models`` simulates those models: the braking stops where the model
    integrated alone stops."""
    model = dataclasses.replace(true_parameters(default_device, 1, default_virtual), quadratic=2e-3)
    virtual = Virtual(
        body=None, friction=Friction(0.0, 0.0, 0.0), run=RunSettings(), controller=ControllerSettings(),
        models=(model, true_parameters(default_device, 2, default_virtual)),
    )
    assert true_parameters(default_device, 1, virtual, -1) is model
    braking = simulate_braking(default_device, 1, virtual)
    st = default_device.stages[0]
    x0 = np.array([math.radians(virtual.run.release_angle_deg), st.launch_speed])
    u = -st.braking_torque
    _, _, end_time, end_phi = integrate_to_stop(x0, u, 1.0, model.vector, default_device.encoder.dt, 600)
    assert braking.truth.end_time == pytest.approx(end_time, abs=1e-9)
    assert braking.truth.end_phi == pytest.approx(end_phi, abs=1e-9)


def test_estimate_run_reuses_the_programs_smoothing(tmp_path):
    """estimate_run with program's smoothed braking gives what reading the logs gives."""
    root = create_default_experiment(tmp_path / "exp")
    simulate(root, part="braking", stage=1)
    simulate(root, part="reverse", stage=1, ideal=True)
    exp = open_experiment(root)
    braking, reverse = read_run(exp, 1, Direction.FORWARD)
    b_read, r_read = estimate_run(exp.device, braking, reverse, Direction.FORWARD, [])
    made = make_program(exp.device, 1, braking)
    b_mem, r_mem = estimate_run(
        exp.device, braking, reverse, Direction.FORWARD, [], braking_smoothed=made.smoothed
    )
    np.testing.assert_array_equal(b_mem.smoothed.omega, b_read.smoothed.omega)
    np.testing.assert_array_equal(b_mem.work, b_read.work)
    np.testing.assert_array_equal(r_mem.work, r_read.work)


@pytest.mark.slow
def test_rehearsal_predicts_the_closed_loop_std(tmp_path, capsys):
    """Pilots, plan (with its rehearsal), braking, program, closed loop and identify on the
    paper's scenario: the std identify reports is within 1.5x of the rehearsal's on every
    axis, and the errors within 3 of identify's stds (benchmarks/results/plan.md has the
    five scenarios)."""
    root = create_default_experiment(tmp_path / "exp")
    assert main(["simulate", str(root), "--part", "pilot"]) == 0
    from rsp_inertia.planning import plan

    report = plan(root)
    assert report.rehearsal is not None, report.rehearsal_error
    assert main(["simulate", str(root), "--part", "braking"]) == 0
    assert main(["program", str(root)]) == 0
    assert main(["simulate", str(root), "--part", "reverse"]) == 0
    assert main(["identify", str(root)]) == 0
    capsys.readouterr()
    result = json.loads((root / "result.json").read_text())
    std = np.array([a["J_std"] for a in result["axes"]])
    J = np.array([a["J"] for a in result["axes"]])
    ratio = std / report.rehearsal.axis_std
    assert np.all((ratio > 1 / 1.5) & (ratio < 1.5)), ratio
    exp = open_experiment(root)
    from rsp_inertia.virtual.config import load_virtual

    body = load_virtual(root / "virtual.toml").body
    dirs = [
        axis_direction(math.radians(n), st.gear_ratio)
        for st in exp.device.stages for n in st.nodes_deg
    ]
    truth = design_matrix(np.array(dirs)) @ entries_from_tensor(body.tensor)
    assert np.all(np.abs(J - truth) < 3 * std)
