"""The command line: simulate writes valid logs; bad input is one line on stderr, exit 2."""

from __future__ import annotations

import json
import math
import os
import re

import numpy as np
import pytest

import rsp_inertia
from rsp_inertia.cli import main
from rsp_inertia.plant.config import load_device
from rsp_inertia.plant.logs import read_log
from rsp_inertia.scenarios import create_default_experiment


@pytest.fixture
def experiment(tmp_path):
    return create_default_experiment(tmp_path / "exp")


def one_line_error(capsys, *needles):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    for needle in needles:
        assert needle in err, err
    return err


def test_simulate_braking_writes_valid_logs(experiment, capsys):
    assert main(["simulate", str(experiment), "--stage", "1"]) == 0
    device = load_device(experiment / "device.toml")
    log = read_log(experiment / "stage1" / "braking.csv", device.encoder, "braking")
    assert np.all(np.diff(log.phi) >= 0)  # the braking never turns back
    assert (log.phi[-1] - log.phi[0]) / (2 * math.pi) > 3
    assert "stage 1: braking" in capsys.readouterr().out


def test_ideal_reverse_and_pendulum_write_valid_logs(experiment):
    assert main(["simulate", str(experiment), "--stage", "2"]) == 0
    assert main(["simulate", str(experiment), "--stage", "2", "--part", "reverse", "--ideal"]) == 0
    assert main(["simulate", str(experiment), "--stage", "2", "--part", "pendulum"]) == 0
    device = load_device(experiment / "device.toml")
    reverse = read_log(experiment / "stage2" / "reverse.csv", device.encoder, "reverse")
    braking = read_log(experiment / "stage2" / "braking.csv", device.encoder, "braking")
    # The reverse starts where the braking stopped (same encoder zero, within a count).
    assert abs(reverse.phi[0] - braking.phi[-1]) <= device.encoder.quantum
    for k in (1, 2, 3):
        read_log(experiment / "stage2" / f"pendulum_k{k}.csv", device.encoder, "pendulum")


def test_same_inputs_give_the_same_files(experiment, tmp_path):
    other = create_default_experiment(tmp_path / "other")
    for root in (experiment, other):
        assert main(["simulate", str(root), "--stage", "1"]) == 0
    a = (experiment / "stage1" / "braking.csv").read_bytes()
    assert a == (other / "stage1" / "braking.csv").read_bytes()


def test_missing_folder(tmp_path, capsys):
    assert main(["simulate", str(tmp_path / "nowhere")]) == 2
    one_line_error(capsys, "nowhere")


def test_bad_device_key(experiment, capsys):
    path = experiment / "device.toml"
    path.write_text(path.read_text().replace("gear_ratio = 0.7639320225", "gear_ratio = -0.5"))
    assert main(["simulate", str(experiment)]) == 2
    one_line_error(capsys, "device.toml", "stage[1].gear_ratio")


@pytest.mark.parametrize(
    "file, table, lines, needles",
    [
        ("virtual.toml", "[rig]", "efficiency_driving = 1.5", ("rig.efficiency_driving", "<= 1")),
        ("virtual.toml", "[rig]", "efficiency_backdriven = 0.0", ("rig.efficiency_backdriven",)),
        (
            "virtual.toml",
            "[rig]",
            "encoder_error_amplitude = [2e-4, 5e-5]\nencoder_error_phase_deg = [30.0]",
            ("rig.encoder_error_phase_deg", "one entry per order"),
        ),
        (
            "device.toml",
            "[encoder]",
            "error_cos = [1e-4]\nerror_sin = [1e-4, 2e-5]",
            ("encoder.error_sin", "one entry per order"),
        ),
        ("device.toml", "[encoder]", "error_cos = [1e-4]", ("encoder.error_sin", "missing")),
    ],
)
def test_bad_drive_or_encoder_keys(experiment, capsys, file, table, lines, needles):
    # A drive's efficiency outside (0, 1] or a malformed encoder error series: one line,
    # exit status 2, nothing written.
    path = experiment / file
    text = path.read_text()
    header = re.search(rf"^{re.escape(table)}.*\n", text, flags=re.MULTILINE)
    if header is None:
        text += f"\n{table}\n{lines}\n"
    else:
        text = text[: header.end()] + f"{lines}\n" + text[header.end() :]
    path.write_text(text)
    before = sorted(p.name for p in experiment.rglob("*"))
    assert main(["simulate", str(experiment), "--stage", "1"]) == 2
    one_line_error(capsys, file, *needles)
    assert sorted(p.name for p in experiment.rglob("*")) == before


@pytest.mark.parametrize(
    "command",
    [
        ["program"],
        ["identify"],
        ["simulate"],
        ["simulate", "--part", "reverse", "--ideal"],
        ["calibrate", "--empty", "{exp}"],
    ],
    ids=["program", "identify", "simulate braking", "simulate reverse", "calibrate"],
)
def test_a_stage_without_its_protocol_is_refused_naming_it_and_plan(experiment, capsys, command):
    # Only plan (and the pilot and pendulum runs) go without the protocol; every command that
    # runs or reads it names the file, the stage's key and plan, and writes nothing.
    assert main(["simulate", str(experiment), "--stage", "1"]) == 0
    path = experiment / "device.toml"
    path.write_text(path.read_text().replace("braking_torque = 0.12 ", "# plan: braking_torque"))
    before = {p: p.read_bytes() for p in experiment.rglob("*") if p.is_file()}
    capsys.readouterr()
    name, *options = (part.format(exp=experiment) for part in command)
    assert main([name, str(experiment), *options]) == 2
    one_line_error(
        capsys, f"{path}: stage[2].braking_torque: missing", f"rsp-inertia plan {experiment}"
    )
    assert {p: p.read_bytes() for p in experiment.rglob("*") if p.is_file()} == before


def test_check_lists_a_stage_without_its_protocol_as_missing(experiment, capsys):
    # check is the list of what the folder lacks: before plan, the protocol is one of them.
    assert main(["simulate", str(experiment), "--stage", "1"]) == 0
    path = experiment / "device.toml"
    path.write_text(path.read_text().replace("braking_torque = 0.12 ", "# plan: braking_torque"))
    capsys.readouterr()
    assert main(["check", str(experiment)]) == 1
    out = capsys.readouterr().out
    assert f"missing: {path}: stage[2].braking_torque: missing" in out
    assert f"rsp-inertia plan {experiment}" in out
    assert out.rstrip().endswith("suspicious)") and "not ready for identify" in out


def test_no_such_stage(experiment, capsys):
    assert main(["simulate", str(experiment), "--stage", "3"]) == 2
    one_line_error(capsys, "device.toml", "stage 3")


def test_reverse_without_program(experiment, capsys):
    assert main(["simulate", str(experiment), "--stage", "1"]) == 0
    capsys.readouterr()
    assert main(["simulate", str(experiment), "--stage", "1", "--part", "reverse"]) == 2
    one_line_error(capsys, "program.csv")


def test_reverse_refuses_a_foreign_braking_log(experiment, capsys):
    assert main(["simulate", str(experiment), "--stage", "1"]) == 0
    path = experiment / "virtual.toml"
    path.write_text(path.read_text().replace("seed = 0", "seed = 5"))
    capsys.readouterr()
    assert main(["simulate", str(experiment), "--stage", "1", "--part", "reverse", "--ideal"]) == 2
    one_line_error(capsys, "braking.csv", "simulate it again")


def test_braking_that_never_stops(experiment, capsys):
    path = experiment / "device.toml"
    text = path.read_text().replace("braking_torque = 0.005 ", "braking_torque = 0.0   ")
    path.write_text(text.replace("coulomb = 1.0e-4", "coulomb = 0.0"))
    vpath = experiment / "virtual.toml"
    vtext = vpath.read_text()
    for key in ("coulomb = 1.0e-4", "viscous = 1.0e-4", "quadratic = 1.0e-3"):
        vtext = vtext.replace(key, key.split("=")[0] + "= 0.0")
    vpath.write_text(vtext)
    assert main(["simulate", str(experiment), "--stage", "1"]) == 2
    one_line_error(capsys, "stage 1", "does not stop")


def test_demo_keeps_an_edited_input(experiment):
    path = experiment / "device.toml"
    edited = path.read_text().replace('name = "virtual-paper"', 'name = "edited"')
    path.write_text(edited)
    create_default_experiment(experiment)
    assert path.read_text() == edited


def test_running_out_of_memory_is_one_line(experiment, capsys, monkeypatch):
    # Logs too long for the machine: whatever runs out of memory, the user gets one line that
    # names the command, the experiment and its logs' rows, and exit 2, never a traceback.
    assert main(["simulate", str(experiment), "--stage", "1", "--part", "braking"]) == 0
    device = load_device(experiment / "device.toml")
    rows = len(read_log(experiment / "stage1" / "braking.csv", device.encoder, "braking"))

    def exhausted(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(rsp_inertia, "identify", exhausted)
    capsys.readouterr()
    assert main(["identify", str(experiment)]) == 2
    one_line_error(capsys, "out of memory while running identify", str(experiment), f"{rows} rows")


def test_no_command_lists_the_commands(capsys):
    # `rsp-inertia` alone: what there is to run, not only "COMMAND is required".
    assert main([]) == 2
    err = capsys.readouterr().err
    for command in ("demo", "simulate", "plan", "program", "calibrate", "check", "identify",
                    "report", "design"):
        assert re.search(rf"^\s+{command}\s", err, re.MULTILINE), command


def test_help_states_the_exit_statuses(capsys):
    with pytest.raises(SystemExit) as done:
        main(["--help"])
    assert done.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "exit status: 0 done; 1 check" in out and "130 interrupted" in out


def test_ctrl_c_is_one_line_and_130(experiment, capsys, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(rsp_inertia, "identify", interrupted)
    assert main(["identify", str(experiment)]) == 130
    one_line_error(capsys, "interrupted: identify stopped")


def test_a_killed_writers_temporary_file_is_removed_by_the_next_write(tmp_path):
    # A writer killed between creating its temporary file and renaming it leaves the file;
    # the next write of the same target removes it, but never a live writer's.
    from rsp_inertia.infra.files import write_atomic

    target = tmp_path / "result.json"
    dead = 2**22 + 12345  # above Linux's default pid_max of 2**22: no such process
    stale = tmp_path / f".result.json.{dead}.0123456789ab.tmp"
    live = tmp_path / f".result.json.{os.getppid()}.0123456789ab.tmp"
    stale.write_text("half")
    live.write_text("being written")
    write_atomic(target, "{}\n")
    assert target.read_text() == "{}\n"
    assert not stale.exists() and live.exists()


def test_a_device_toml_with_a_byte_order_mark_reads(experiment):
    # Some Windows editors start a UTF-8 file with a byte-order mark; it was "Invalid
    # statement".
    path = experiment / "device.toml"
    plain = load_device(path)
    path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    assert load_device(path) == plain


def test_the_default_files_cite_the_docs_that_exist():
    # The generated device.toml files once cited "METHOD.md", a file the repository lacks.
    from pathlib import Path

    from rsp_inertia import plant

    for path in Path(plant.__file__).parent.joinpath("defaults").rglob("*.toml"):
        assert "METHOD.md" not in path.read_text(), path


def test_a_log_cut_while_writing_is_identified_without_its_last_row_and_says_so(
    experiment, capsys
):
    # The logger stopped mid-number: the row is left out, and identify and check say which
    # file (the result was used silently).
    assert main(["simulate", str(experiment)]) == 0
    assert main(["simulate", str(experiment), "--part", "reverse", "--ideal"]) == 0
    path = experiment / "stage1" / "reverse.csv"
    data = path.read_bytes()
    path.write_bytes(data + data.splitlines()[-1][:-3])  # a last line cut short, no line end
    capsys.readouterr()
    assert main(["check", str(experiment)]) == 0
    assert f"{path}: its last line has no line end" in capsys.readouterr().out
    assert main(["identify", str(experiment)]) == 0
    warnings = json.loads((experiment / "result.json").read_text())["warnings"]
    assert any(w.startswith(f"{path}: its last line has no line end") for w in warnings)


def test_a_torque_spike_in_a_log_is_refused_by_check_identify_and_program(experiment, capsys):
    # 1000 N m against a 0.5 N m motor: check said "ready", identify gave Jz 41% off, and a
    # 1e300 N m row made program ask for 1.3e297 N m; now each names the file and the line.
    # (Over a few rows: a single such row among neighbours that agree is a glitch, left out
    # with a warning, tests/test_cli_log_glitches.py.)
    assert main(["simulate", str(experiment), "--stage", "1"]) == 0
    path = experiment / "stage1" / "braking.csv"
    lines = path.read_text().splitlines(keepends=True)
    for k in range(100, 104):
        t, phi, _ = lines[k].split(",")
        lines[k] = f"{t},{phi},1000.0\n"
    path.write_text("".join(lines))
    capsys.readouterr()
    assert main(["check", str(experiment)]) == 1
    out = capsys.readouterr().out
    assert f"{path}, line 101: torque = 1000.0 N m is beyond what the drive can produce" in out
    for command in (["program", str(experiment), "--stage", "1"], ["identify", str(experiment)]):
        assert main(command) == 2
        one_line_error(capsys, f"{path}, line 101: torque = 1000.0 N m")


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
@pytest.mark.parametrize("command", ["identify", "program"])
def test_an_output_that_cannot_be_written_is_found_before_the_work(
    experiment, capsys, command
):
    assert main(["simulate", str(experiment), "--stage", "1"]) == 0
    folder = experiment if command == "identify" else experiment / "stage1"
    folder.chmod(0o555)
    try:
        capsys.readouterr()
        assert main([command, str(experiment)]) == 2
        one_line_error(capsys, "cannot be written", "nothing was computed")
    finally:
        folder.chmod(0o755)


def test_an_output_path_that_is_a_folder_is_found_before_the_work(
    experiment, capsys, monkeypatch
):
    # (A read-only folder is the usual case; as root, which writes anyway, a folder in the
    # output's place stands for it.) It was found only after the whole computation.
    from rsp_inertia import identifying

    assert main(["simulate", str(experiment), "--stage", "1"]) == 0
    (experiment / "result.json").mkdir()
    started = []
    monkeypatch.setattr(identifying, "identify_experiment", lambda *a, **k: started.append(1))
    capsys.readouterr()
    assert main(["identify", str(experiment)]) == 2
    one_line_error(capsys, "result.json: cannot be written: it is a folder")
    assert not started


def test_simulate_and_plan_find_an_unwritable_output_before_the_work(
    experiment, capsys, monkeypatch
):
    # A folder in an output's place stands for a read-only one (root writes anyway).
    from rsp_inertia import planning, simulating

    started = []
    monkeypatch.setattr(simulating, "simulate_braking", lambda *a, **k: started.append(1))
    monkeypatch.setattr(planning, "stage_models", lambda *a, **k: started.append(1))
    (experiment / "stage2").mkdir()
    (experiment / "stage2" / "braking.csv").mkdir()
    capsys.readouterr()
    assert main(["simulate", str(experiment)]) == 2
    one_line_error(capsys, "stage2/braking.csv: cannot be written: it is a folder")
    (experiment / "plan.png").mkdir()
    assert main(["plan", str(experiment)]) == 2
    one_line_error(capsys, "plan.png: cannot be written: it is a folder")
    assert not started
    assert not (experiment / "stage1").exists()  # nothing simulated, nothing written
