"""``rsp-inertia check``: an experiment folder's findings, one line each, and its verdict."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from rsp_inertia.cli import main
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from tests.conftest import copy_experiment
from tests.one_home import assert_calls_home, home_cases


@pytest.fixture(scope="module")
def ready(tmp_path_factory, default_logs):
    """The default experiment with its braking and (ideal) reverse logs."""
    return copy_experiment(default_logs, tmp_path_factory.mktemp("check") / "exp")


def _lines(capsys) -> list[str]:
    return capsys.readouterr().out.strip().splitlines()


def test_an_empty_experiment_lists_what_identify_needs(tmp_path, capsys):
    root = create_default_experiment(tmp_path / "exp")
    assert main(["check", str(root)]) == 1
    lines = _lines(capsys)
    for stage in (1, 2):
        for name in ("braking.csv", "program.csv", "reverse.csv"):
            assert any(
                line.startswith("missing: ") and f"stage{stage}/{name}" in line for line in lines
            ), name
    assert lines[-1].endswith("not ready for identify (0 error(s), 6 missing, 0 suspicious)")


def test_a_complete_experiment_is_ready(ready, capsys):
    assert main(["check", str(ready)]) == 0
    lines = _lines(capsys)
    assert lines[-1].endswith("ready for identify (0 error(s), 0 missing, 0 suspicious)")
    assert all(line.startswith("ok: ") for line in lines[:-1])


def test_broken_and_suspicious_files_each_get_their_line(ready, tmp_path, capsys):
    """A NaN in a reverse log is an error naming the file and line; a braking torque that is
    not device.toml's, a program older than its braking and constants stated nowhere are
    suspicious; identify would stop at the first of these, check lists them all."""
    import shutil

    root = tmp_path / "exp"
    shutil.copytree(ready, root)
    rows = (root / "stage1" / "reverse.csv").read_text().splitlines()
    t, phi, _ = rows[5].split(",")
    rows[5] = f"{t},{phi},nan"
    (root / "stage1" / "reverse.csv").write_text("\n".join(rows) + "\n")
    (root / "stage2" / "program.csv").write_text("t,torque\n0.0,0.0\n")
    braking = root / "stage2" / "braking.csv"
    os.utime(braking, (braking.stat().st_atime, (root / "stage2" / "program.csv").stat().st_mtime + 10))
    device = (root / "device.toml").read_text()
    device = device.replace("braking_torque = 0.12 ", "braking_torque = 0.2 ")
    device = device.replace("tare_inertia_std = 0.0 ", "")
    (root / "device.toml").write_text(device)
    assert main(["check", str(root)]) == 1
    lines = _lines(capsys)
    errors = [line for line in lines if line.startswith("error: ")]
    assert len(errors) == 1 and "stage1/reverse.csv" in errors[0] and "line 6" in errors[0]
    suspicious = [line for line in lines if line.startswith("suspicious: ")]
    assert any("stage2/braking.csv" in s and "braking_torque 0.2" in s for s in suspicious)
    assert any("stage2/program.csv: older than braking.csv" in s for s in suspicious)
    assert any("calibration.toml: not found" in s and "tare_inertia_std" in s for s in suspicious)


def test_a_missing_folder_is_one_line(tmp_path, capsys):
    assert main(["check", str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "nowhere" in err


def test_a_regulator_the_encoder_holds_below_the_speed_harmonics_is_suspicious(tmp_path, capsys):
    """On a 12-bit encoder the heavy stage 2's program gets gains for about 0.4 rad/s (one
    count must not step the torque beyond the rate limit, rsp_inertia.ocp.regulator), below
    the braking's 2 Omega of 1.4 rad/s over the balances: check says so for stage 2 only (stage
    1's regulator, at about 7 rad/s, follows its 4.8 rad/s)."""
    from benchmarks.experiments import vary, with_encoder_bits
    from rsp_inertia.programming import program

    root = create_default_experiment(tmp_path / "exp")
    vary(root, lambda d: with_encoder_bits(d, 12))
    simulate(root, part="braking")
    program(root)
    main(["check", str(root)])
    flagged = [line for line in _lines(capsys) if "regulator's bandwidth" in line]
    assert len(flagged) == 1 and flagged[0].startswith("suspicious: ")
    assert "stage2/program.csv" in flagged[0] and "below the braking's speed harmonics" in flagged[0]


def _copy(ready, tmp_path):
    import shutil

    root = tmp_path / "exp"
    shutil.copytree(ready, root)
    return root


def _keep_rows(path, rows: slice, restart: bool = False) -> None:
    """Keep only the data rows ``rows`` of a log; ``restart``: its time from 0 again (a
    logger that started late)."""
    header, *data = path.read_text().splitlines()
    data = data[rows]
    if restart:
        t0 = float(data[0].split(",", 1)[0])
        data = [f"{float(t) - t0!r},{rest}" for t, rest in (row.split(",", 1) for row in data)]
    path.write_text("\n".join([header, *data]) + "\n")


def _rows(path) -> int:
    return len(path.read_text().splitlines()) - 1


def _identify(root, capsys) -> tuple[int, str]:
    """identify's exit status and its stderr."""
    status = main(["identify", str(root)])
    return status, capsys.readouterr().err.strip()


def test_a_reverse_cut_to_its_first_half_is_an_error_of_check_and_identify_naming_it(
    ready, tmp_path, capsys
):
    """Issue 23: check said ready (one suspicious line on the duration) where identify then
    refused, blaming the braking. Half the rows of stage 2's reverse cover 1.6 of the
    braking's 6.2 turns (the reverse starts slowly), and the passes then share 1.4 turns at
    useful speed, fewer than the balances' 2: both name the reverse, and why."""
    root = _copy(ready, tmp_path)
    reverse = root / "stage2" / "reverse.csv"
    _keep_rows(reverse, slice(0, _rows(reverse) // 2))
    assert main(["check", str(root)]) == 1
    lines = _lines(capsys)
    errors = [line for line in lines if line.startswith("error: ")]
    assert len(errors) == 1 and errors[0].startswith(f"error: {reverse}: stage 2: covers ")
    assert "the reverse run stopped early" in errors[0]
    assert lines[-1].endswith("not ready for identify (1 error(s), 0 missing, 0 suspicious)")
    status, err = _identify(root, capsys)
    assert status == 2 and len(err.splitlines()) == 1, err
    assert err == f"rsp-inertia: error: {errors[0].removeprefix('error: ')}"
    assert "braking_torque" not in err and "launch_speed" not in err
    assert not (root / "result.json").exists()


def test_calibrate_names_a_cut_reverse_of_the_empty_fixture(ready, tmp_path, capsys):
    """calibrate balances the empty fixture's runs as identify balances the body's
    (rsp_inertia.estimation.runs.checked_run): the same refusal, naming the empty folder's
    reverse, and no calibration.toml."""
    root = _copy(ready, tmp_path)
    empty = tmp_path / "empty"
    import shutil

    shutil.copytree(ready, empty)
    reverse = empty / "stage1" / "reverse.csv"
    _keep_rows(reverse, slice(0, _rows(reverse) // 4))
    assert main(["calibrate", str(root), "--empty", str(empty)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(f"rsp-inertia: error: {reverse}: ")
    assert "the reverse run stopped early" in err
    assert not (root / "calibration.toml").exists()


def _cut_reverse(root):
    """Stage 2's reverse log cut to its first half: the reverse run stopped early."""
    path = root / "stage2" / "reverse.csv"
    _keep_rows(path, slice(0, _rows(path) // 2))


def _cut_braking(root):
    """Stage 1's braking log cut to its first half: still 3.9 turns past the last node, all
    at useful speed, which the reverse covers (the balances hold whatever a pass's start)."""
    path = root / "stage1" / "braking.csv"
    _keep_rows(path, slice(0, _rows(path) // 2))


def _stub_braking(root):
    """Stage 1's braking log cut to 0.4 s: it never reaches its last node."""
    _keep_rows(root / "stage1" / "braking.csv", slice(0, 400))


def _reversing_braking(root):
    """Ten rows of stage 1's braking one count back: the speed reverses inside the braking
    (one such row would be a glitch, left out: rsp_inertia.plant.log_glitches)."""
    path = root / "stage1" / "braking.csv"
    header, *data = path.read_text().splitlines()
    phi = float(data[999].split(",")[1]) - 2 * math.pi / 65536
    for k in range(1000, 1010):
        t, _, torque = data[k].split(",")
        data[k] = f"{t},{phi!r},{torque}"
    path.write_text("\n".join([header, *data]) + "\n")


def _drop_at_node(root, rows: int):
    """``rows`` rows of stage 1's reverse dropped where it passes node 120 deg, 3 turns on."""
    path = root / "stage1" / "reverse.csv"
    header, *data = path.read_text().splitlines()
    phi = np.array([float(row.split(",")[1]) for row in data])
    k = int(np.argmin(np.abs(phi - math.radians(120.0 + 3 * 360.0))))
    del data[k : k + rows]
    path.write_text("\n".join([header, *data]) + "\n")


def _gap_at_a_node(root):
    """Five rows of stage 1's reverse dropped at node 120 deg: the smoother bridges them (up
    to 14 on the default stage 1, rsp_inertia.estimation.balance.check_node_gaps)."""
    _drop_at_node(root, 5)


def _long_gap_at_a_node(root):
    """Forty rows dropped there: beyond what the smoother bridges."""
    _drop_at_node(root, 40)


def _pendulum_without_its_table(root):
    """A pendulum log, and no [pendulum] table in device.toml."""
    import shutil

    device = (root / "device.toml").read_text()
    (root / "device.toml").write_text(device[: device.index("[pendulum]")])
    shutil.copy(root / "stage1" / "braking.csv", root / "stage1" / "pendulum_k1.csv")


def _short_pendulum(root):
    """A pendulum log that never oscillates (stage 1's braking under its name)."""
    import shutil

    shutil.copy(root / "stage1" / "braking.csv", root / "stage1" / "pendulum_k1.csv")


def _clustered_nodes(root):
    """Stage 2's three nodes 0.2 deg apart: six axes, three of them nearly one."""
    device = (root / "device.toml").read_text()
    device = device.replace("nodes_deg = [60.0, 180.0, 300.0]", "nodes_deg = [60.0, 60.2, 60.4]")
    (root / "device.toml").write_text(device)


@pytest.mark.parametrize(
    "corrupt, refused",
    [
        (_cut_reverse, True),
        (_cut_braking, False),
        (_stub_braking, True),
        (_reversing_braking, True),
        (_gap_at_a_node, False),
        (_long_gap_at_a_node, True),
        (_pendulum_without_its_table, True),
        (_short_pendulum, True),
        (_clustered_nodes, True),
    ],
    ids=lambda value: value.__name__.strip("_") if callable(value) else None,
)
def test_check_is_ready_exactly_when_identify_accepts(ready, tmp_path, capsys, corrupt, refused):
    """check runs identify's own checks: it is ready when identify accepts the folder, and
    when identify refuses, check has a line ``error`` with identify's very message (or, for a
    braking that does not reach its last node, ``missing`` naming the same file)."""
    root = _copy(ready, tmp_path)
    corrupt(root)
    ready_status = main(["check", str(root)])
    lines = _lines(capsys)
    status, err = _identify(root, capsys)
    assert (status != 0) == refused, err
    assert (ready_status == 1) == refused, lines
    if not refused:
        assert (root / "result.json").is_file()
        return
    assert status == 2 and len(err.splitlines()) == 1, err
    message = err.removeprefix("rsp-inertia: error: ")
    named = message.split(":")[0].split(",")[0]
    assert f"error: {message}" in lines or any(
        line.startswith(f"missing: {named}: ") for line in lines
    ), (message, lines)


def test_a_bridged_gap_at_a_node_is_an_ok_line_with_its_added_std(ready, tmp_path, capsys):
    """Five rows dropped at a node's passage: check says the smoother bridges them, with the
    share of the balance's speed std they add and the most it would bridge there, as an
    ``ok`` line (identify accepts the folder)."""
    root = _copy(ready, tmp_path)
    _gap_at_a_node(root)
    assert main(["check", str(root)]) == 0
    lines = [line for line in _lines(capsys) if "bridged by the smoother" in line]
    assert len(lines) == 1, lines
    assert lines[0].startswith("ok: ") and "stage1/reverse.csv, line " in lines[0]
    assert "5 samples dropped within 5 deg of node 120 deg (stage 1)" in lines[0]
    share = float(lines[0].split("adding at most ")[1].split()[0])
    assert 0.0 < share <= 1.0


# (formula, home module, function, consumer modules) as tests/one_home.py takes them:
# identify's checks, which identify's path and check both call
SAME_CHECKS = [
    ("the logs as identify reads them", "estimation.reading", "read_run", ["checking"]),
    ("a run checked before the fit", "estimation.runs", "checked_run",
     ["estimation.runs", "checking"]),
    ("the range a run is balanced over", "estimation.balance", "balance_range",
     ["estimation.balance", "estimation.runs"]),
    ("a braking whose speed reverses", "plant.logs", "check_braking_monotone",
     ["estimation.runs", "checking"]),
    ("cond(V) refused", "estimation.identify", "checked_design",
     ["estimation.identify", "checking"]),
    ("pendulum logs need [pendulum]", "estimation.identify", "pendulum_settings",
     ["estimation.identify", "checking"]),
    ("a pendulum run reduced", "estimation.identify", "reduce_pendulum_run",
     ["estimation.identify", "checking"]),
    ("the tempco the logs are compensated with", "estimation.reading", "tempco_in_use",
     ["estimation.reading", "checking", "design.models"]),
]


def test_check_reads_the_runs_with_the_tempco_identify_uses(ready, capsys, monkeypatch):
    """calibration.toml's tempco where calibrate measured it (tempco_in_use), passed to the
    reader of every run, as identify reads them."""
    from rsp_inertia import checking

    seen = []
    read = checking.read_run

    def recording(exp, stage, direction, tempco=None):
        seen.append(tempco)
        return read(exp, stage, direction, tempco)

    monkeypatch.setattr(checking, "tempco_in_use", lambda exp, calibration: (-7e-4, 1e-5, []))
    monkeypatch.setattr(checking, "read_run", recording)
    main(["check", str(ready)])
    capsys.readouterr()
    assert seen and all(t == -7e-4 for t in seen)


@pytest.mark.parametrize("home, name, consumer", home_cases(SAME_CHECKS), ids=str)
def test_check_calls_identifys_own_checks(home, name, consumer):
    """Each of identify's refusals that its files show has one home, which identify's path
    and check both call (no copy of its own: tests/one_home.py)."""
    assert_calls_home(home, name, consumer)


def test_a_calibration_folder_needs_no_calibration_toml(tmp_path, capsys):
    """The demo's calibration folders before their runs: the empty fixture's with
    --calibration, the reference body's by its reference.toml. Their missing calibration.toml
    and unstated stds are no finding (calibrate measures what they would give); the body's
    folder keeps its suspicious line."""
    from rsp_inertia.scenarios import create_rig_experiment

    body, empty, reference = create_rig_experiment(tmp_path / "rig")
    for argv in (["check", str(empty), "--calibration"], ["check", str(reference)]):
        assert main(argv) == 1
        lines = _lines(capsys)
        assert not [line for line in lines if line.startswith(("suspicious: ", "error: "))]
        assert any(line.startswith("ok: ") and "a calibration folder" in line for line in lines)
        assert lines[-1].endswith(": not ready for calibrate (0 error(s), 12 missing, 0 suspicious)")
    assert main(["check", str(body)]) == 1
    lines = _lines(capsys)
    assert any(line.startswith("suspicious: ") and "calibration.toml: not found" in line
               for line in lines)
    assert lines[-1].endswith("not ready for identify (0 error(s), 12 missing, 2 suspicious)")
