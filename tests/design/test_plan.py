"""Experiment planning: predicted stds, the planner's limits, and the plan command."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest

from rsp_inertia.cli import main
from rsp_inertia.design.candidates import NOMINAL_COULOMB_SHARE, TORQUE_MARGIN, StageModel, evaluate
from rsp_inertia.estimation.axes import axis_values
from rsp_inertia.estimation.predict import (
    PlannedPass,
    combine_information,
    predicted_balance,
    run_information,
)
from rsp_inertia.estimation.reading import identify_experiment
from rsp_inertia.estimation.tensor_fit import predict_tensor
from rsp_inertia.plant.config import load_device
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.geometry import device_design
from rsp_inertia.plant.model import acceleration, dissipation, motor_torque, reduced_inertia
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.virtual.config import load_virtual
from rsp_inertia.virtual.device import integrate_to_stop, true_parameters
from tests.conftest import copy_experiment

DEFAULTS = Path(__file__).parents[2] / "plant" / "defaults"

PLAN_TABLE = """
[plan]                       # rough guesses for plan
inertia = [0.02, 0.025, 0.03]      # kg m^2
friction = [1e-4, 1e-4, 1e-3]      # a1, a2, a3
com_offset = 0.0035                # m
torque_noise = 1e-4                # N m
"""


@pytest.fixture(scope="module")
def paper():
    return load_device(DEFAULTS / "device.toml"), load_virtual(DEFAULTS / "virtual.toml")


def _planned(device, stage, model, speed, torque):
    """The exact braking of a stage on ``model`` and its mirror (the planner's passes)."""
    st = device.stages[stage - 1]
    t, traj, _, _ = integrate_to_stop(
        np.array([math.radians(-30.0), speed]), -torque, 1.0, model.vector, device.encoder.dt, 600
    )
    phi, omega = traj[:, 0], traj[:, 1]
    u = np.full(t.size, -torque)
    eps = np.asarray(acceleration(phi, omega, u, model, np.ones_like(omega))).ravel()
    braking = PlannedPass(t, phi, omega, eps, u)
    shape = braking.mirrored(np.zeros(t.size))
    ur = np.asarray(motor_torque(shape.phi, shape.omega, shape.eps, model, -np.ones_like(omega)))
    return braking, braking.mirrored(ur.ravel()), st


def test_structured_information_equals_the_least_squares_covariance(paper):
    """Two computations of the predicted J_k stds: the dense GLS (predict_tensor)
    and the per-run information with the banded factor and its Schur complements.

    They differ only in the reduced inertia weighting the speed noise: the GLS takes it from
    its first unweighted fit of the planned balances (whose mirror sits up to a sample off
    the exact one), the information from the model itself; measured 2.6e-5 apart."""
    device, virtual = paper
    balances, infos = [], []
    for stage in (1, 2):
        model = true_parameters(device, stage, virtual, 1.0)
        st = device.stages[stage - 1]
        b, r, _ = _planned(device, stage, model, st.launch_speed, st.braking_torque)
        bal = predicted_balance(device, stage, b, r, 1e-4)
        balances.append(bal)
        infos.append(run_information(device, bal, np.ravel(reduced_inertia(bal.phi, model))))
    fit = predict_tensor(balances)
    _, dense = axis_values(fit.entries, fit.entries_cov, device_design(device).directions)
    fast = combine_information(device, infos)
    np.testing.assert_allclose(fast, dense, rtol=1e-4)


def test_mirror_torque_is_braking_torque_plus_twice_friction(paper):
    """Subtracting the braking's equation of motion from the mirror's at the same angle
    leaves u' = -(u_b + 2 D(|Omega|)): inertia, gravity and spring cancel (rsp_inertia.design.plan)."""
    device, virtual = paper
    model = dataclasses.replace(true_parameters(device, 1, virtual, 1.0), stiffness=0.02)
    b, r, _ = _planned(device, 1, model, 10.0, 0.01)
    D = np.ravel(dissipation(np.abs(b.omega), model, np.ones_like(b.omega)))[::-1]
    np.testing.assert_allclose(-r.torque, 0.01 + 2 * D, rtol=1e-9, atol=1e-12)
    c = evaluate(device, StageModel(1, model, 1e-4, "test"), 10.0, 0.01)
    assert c.peak_torque == pytest.approx(0.01 + 2 * float(np.max(D)), rel=1e-3)


def test_prediction_matches_identify_on_an_ideal_reverse(tmp_path, paper, default_logs):
    """The predicted std is the one identify reports for the same protocol (its noise model,
    speed-noise scale near 1 on an ideal reverse): within 20% on every axis."""
    device, virtual = paper
    root = copy_experiment(default_logs, tmp_path / "exp")
    result = identify_experiment(open_experiment(root))
    infos = []
    for stage in (1, 2):
        model = true_parameters(device, stage, virtual, 1.0)
        c = evaluate(device, StageModel(stage, model, 1e-4, "truth"),
                     device.stages[stage - 1].launch_speed, device.stages[stage - 1].braking_torque)
        assert c.feasible, c.violations
        infos.append(c.information)
    predicted = combine_information(device, infos)
    reported = np.array([a.J_std for a in result.axes])
    np.testing.assert_allclose(reported / predicted, 1.0, atol=0.2)


def test_limits_are_reported_with_numbers(paper):
    device, virtual = paper
    model = true_parameters(device, 1, virtual, 1.0)
    sm = StageModel(1, model, 1e-4, "truth")
    too_fast = evaluate(device, sm, 20.0, 0.0)  # 2 a3 W^2 = 0.8 N m > 0.4 N m
    assert any("the reverse needs" in v and "motor.torque_limit" in v for v in too_fast.violations)
    assert too_fast.peak_torque > (1 - TORQUE_MARGIN) * device.motor.torque_limit
    short = evaluate(device, sm, 3.0, 0.02)
    assert any("too few turns: 0.33 in all" in v for v in short.violations)
    assert not short.feasible
    # 0.26 N m from the hold to the mirror at 20 N m/s: 13 ms of a 0.46 s pass at the limit.
    step = evaluate(device, sm, 3.0, 0.2)
    assert any("at the torque-rate limit going from the hold" in v for v in step.violations)


def test_braking_torque_must_dominate_coulomb_friction_for_program(paper):
    """program's nominal model cannot tell a1 from the braking torque (rsp_inertia.ocp.nominal), so a
    braking torque under a1 / NOMINAL_COULOMB_SHARE is refused, naming a1 and the share;
    a spring's known torque fixes the model's scale as well, and the same torque passes."""
    device, virtual = paper
    model = true_parameters(device, 1, virtual, 1.0)  # a1 = 1e-4 N m
    sm = StageModel(1, model, 1e-4, "truth")
    weak = evaluate(device, sm, 8.0, 0.5 * model.coulomb / NOMINAL_COULOMB_SHARE)
    assert any("program's nominal model" in v and "a1 (up to 0.0001 N m)" in v
               for v in weak.violations), weak.violations
    assert not any("nominal" in v for v in evaluate(device, sm, 8.0, 0.002).violations)
    # A pilot's loose a1 raises the bound: the same 2 mN m is then refused.
    loose = dataclasses.replace(sm, coulomb_bound=5e-4)
    assert any("program's nominal model" in v for v in evaluate(device, loose, 8.0, 0.002).violations)
    sprung = StageModel(1, dataclasses.replace(model, stiffness=0.02), 1e-4, "truth")
    assert not any("nominal" in v for v in evaluate(device, sprung, 8.0, 0.0).violations)


def _plan_experiment(tmp_path) -> Path:
    root = create_default_experiment(tmp_path / "exp")
    text = (root / "device.toml").read_text() + PLAN_TABLE
    (root / "device.toml").write_text(text)
    return root


def test_plan_writes_the_protocol_keeping_comments(tmp_path, capsys):
    root = _plan_experiment(tmp_path)
    before = (root / "device.toml").read_text()
    assert main(["plan", str(root), "--max-duration", "100"]) == 0
    out = capsys.readouterr().out
    after = (root / "device.toml").read_text()
    device = load_device(root / "device.toml")
    # The release the plan assumed is added per stage: 30 deg before the first node.
    assert [st.release_angle_deg for st in device.stages] == [-30.0, 30.0]
    assert "release_angle_deg -30 (was not stated)" in out
    kept = [line for line in after.splitlines() if not line.startswith("release_angle_deg")]
    assert len(kept) == len(after.splitlines()) - 2
    # Comments and every other line kept; the two keys per stage changed in place.
    changed = [(a, b) for a, b in zip(before.splitlines(), kept) if a != b]
    assert len(before.splitlines()) == len(kept)
    assert all(a.split("=")[0] == b.split("=")[0] for a, b in changed)
    assert all(k in ("launch_speed ", "braking_torque ") for k, _ in (c[0].split("=", 1) for c in changed))
    assert "# rad/s" in after and "# N m" in after
    assert "(was 12)" in out and "(was 3.5)" in out
    assert (root / "plan.png").stat().st_size > 10_000
    assert all(st.launch_speed > 0 and st.braking_torque >= 0 for st in device.stages)
    assert "predicted std of J_k" in out
    assert "from a closed-loop rehearsal on the nominal model" in out


def _without_protocol(root: Path) -> str:
    """device.toml of ``root`` with every stage's launch_speed and braking_torque taken out (a
    new rig's, before plan); its text."""
    text = re.sub(r"(?m)^(launch_speed|braking_torque) = .*\n", "", (root / "device.toml").read_text())
    (root / "device.toml").write_text(text)
    return text


def test_plan_chooses_the_protocol_a_new_rig_leaves_out(tmp_path, capsys):
    """A device.toml without launch_speed and braking_torque: plan chooses them from the
    motor's limits and the [plan] guesses alone, and adds them to each stage (with their
    units); every other line is kept."""
    root = _plan_experiment(tmp_path)
    before = _without_protocol(root)
    assert main(["plan", str(root), "--max-duration", "100", "--no-rehearsal"]) == 0
    out = capsys.readouterr().out
    after = (root / "device.toml").read_text()
    assert "launch_speed" not in before and "launch_speed" in after
    added = [line for line in after.splitlines() if line not in before.splitlines()]
    assert sorted(line.split(" =")[0] for line in added) == sorted(
        ["launch_speed", "braking_torque", "release_angle_deg"] * 2
    )
    assert all(
        line.endswith("# rad/s") for line in added if line.startswith("launch_speed")
    ) and all(line.endswith("# N m") for line in added if line.startswith("braking_torque"))
    device = load_device(root / "device.toml")
    for k, st in enumerate(device.stages, 1):
        assert st.launch_speed > 0 and 0 <= st.braking_torque <= device.motor.torque_limit
        assert f"stage {k} (model: device.toml [plan]): launch_speed {st.launch_speed:g} rad/s " \
            f"(was not stated), braking_torque {st.braking_torque:g} N m (was not stated)" in out
    assert "device.toml's protocol before" not in out  # there was none to compare


def test_infeasible_plan_is_one_line_and_writes_nothing(tmp_path, capsys):
    """A new rig (no protocol yet) whose motor cannot mirror any braking."""
    root = _plan_experiment(tmp_path)
    text = _without_protocol(root).replace("torque_limit = 0.5 ", "torque_limit = 0.0002 ")
    (root / "device.toml").write_text(text)
    assert main(["plan", str(root)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "stage 1: no feasible protocol" in err, err
    assert (root / "device.toml").read_text() == text
    assert not (root / "plan.png").exists()


def test_plan_without_guess_or_pilot_says_what_is_missing(tmp_path, capsys):
    root = create_default_experiment(tmp_path / "exp")
    assert main(["plan", str(root)]) == 2
    err = capsys.readouterr().err
    assert "[plan]" in err and "pilot" in err


def test_bad_plan_table_is_one_line(tmp_path, capsys):
    root = _plan_experiment(tmp_path)
    text = (root / "device.toml").read_text().replace(
        "friction = [1e-4, 1e-4, 1e-3]", "friction = [1e-4, -1e-4, 1e-3]"
    )
    (root / "device.toml").write_text(text)
    assert main(["plan", str(root)]) == 2
    assert "plan.friction[2]: must be >= 0" in capsys.readouterr().err


def test_plan_from_pilot_runs(tmp_path, capsys):
    """Pilot runs replace the guesses: the model printed is the pilot's fit."""
    root = create_default_experiment(tmp_path / "exp")
    assert main(["simulate", str(root), "--part", "pilot"]) == 0
    assert main(["plan", str(root), "--max-duration", "100", "--no-rehearsal"]) == 0
    out = capsys.readouterr().out
    assert "model from" in out and "pilot.csv" in out
    assert "for an ideal reverse (no closed-loop rehearsal)" in out
    device = load_device(root / "device.toml")
    assert device.stages[0].launch_speed != 12.0 or device.stages[0].braking_torque != 0.005


def test_program_serves_a_two_second_spring_pass(paper):
    """A planned braking against a spring (c = 0.02 N m/rad, 13.8 rad/s, no braking torque):
    2 s, ending at the turning point. The nominal model's windows shorten to the pass
    (rsp_inertia.ocp.nominal): M0 within 2%; the program starts from the hold torque there."""
    from rsp_inertia.ocp.program import make_program
    from rsp_inertia.plant.model import static_torque
    from rsp_inertia.virtual.device import run_program, simulate_braking

    device, virtual = paper
    spring = dataclasses.replace(device.spring, stiffness=0.02)
    stage = dataclasses.replace(device.stages[0], launch_speed=13.8, braking_torque=0.0)
    device = dataclasses.replace(device, spring=spring, stages=(stage, *device.stages[1:]))
    braking = simulate_braking(device, 1, virtual)
    assert 1.5 < braking.truth.end_time < 2.5
    result = make_program(device, 1, braking.log)
    truth = true_parameters(device, 1, virtual, 1.0)
    assert result.nominal.inertia_harmonics[0] == pytest.approx(truth.inertia_harmonics[0], rel=0.02)
    hold = float(static_torque(braking.truth.end_phi, truth))
    assert abs(hold) > 0.2  # the spring is wound: a real hold
    assert result.ocp.torque[0] == pytest.approx(hold, rel=0.05)
    # The regulator's reference leaves the mirror as the OCP does while the torque steps from
    # the hold at the drive's rate, so the closed loop does not fight its own feedforward:
    # the drive rides its rate limit for under 1% of the pass (the step itself takes 15 ms).
    prog = result.program
    assert prog.phi_ref[0] == pytest.approx(result.mirror.phi[0], abs=1e-12)
    run = run_program(device, 1, virtual, prog, (braking.truth.end_phi, 0.0))
    du = np.abs(np.diff(run.truth.torque * virtual.rig.torque_gain))  # the drive's command
    at_rate = np.mean(du >= device.motor.torque_rate_limit * device.encoder.dt * (1 - 1e-9))
    assert at_rate <= 0.01


def test_a_stage_the_closed_loop_costs_is_named_with_what_its_encoder_allows(default_device):
    """plan's note on a stage whose rehearsal exceeds its ideal prediction: the regulator's
    bandwidth the encoder allows (rsp_inertia.ocp.regulator.bandwidth) against the braking's 2 Omega
    at the balances' slowest speed, and the counts per sample there."""
    from rsp_inertia.planning import _closed_loop_note

    def note(bits, stage, M0, launch):
        device = dataclasses.replace(
            default_device,
            encoder=dataclasses.replace(default_device.encoder, counts_per_rev=2**bits),
        )
        model = true_parameters(default_device, stage, load_virtual(DEFAULTS / "virtual.toml"))
        model = dataclasses.replace(
            model, inertia_harmonics=np.r_[M0, model.inertia_harmonics[1:]]
        )
        sm = StageModel(stage=stage, model=model, torque_noise=1e-4, source="test")
        chosen = dataclasses.make_dataclass("C", ["launch_speed"])(launch)
        return _closed_loop_note(device, sm, chosen, 2.0)

    slow = note(10, 2, 0.9, 3.5)  # w 0.085 rad/s against 2 x 0.2 x 3.5 = 1.4 rad/s
    assert "2.0x the ideal reverse's std" in slow and "cannot follow" in slow
    assert "0.085 rad/s" in slow and "0.11 counts per sample" in slow
    middle = note(14, 1, 0.03, 12.0)  # w 26 rad/s against 4.8 rad/s
    assert "holds the regulator to 26 rad/s, which follows" in middle
    fine = note(16, 1, 0.03, 12.0)  # w 45 rad/s: the ceiling, not the encoder
    assert "ceiling of 45 rad/s" in fine and "encoder is not what limits it" in fine
