"""``rsp-inertia check``: an experiment folder's findings, one line each, and its verdict."""

from __future__ import annotations

import os

import pytest

from rsp_inertia.cli import main
from rsp_inertia.pipeline import create_default_experiment, simulate


@pytest.fixture(scope="module")
def ready(tmp_path_factory):
    """The default experiment with its braking and (ideal) reverse logs."""
    root = create_default_experiment(tmp_path_factory.mktemp("check") / "exp")
    simulate(root, part="braking")
    simulate(root, part="reverse", ideal=True)
    return root


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
    from rsp_inertia.pipeline import program

    root = create_default_experiment(tmp_path / "exp")
    vary(root, lambda d: with_encoder_bits(d, 12))
    simulate(root, part="braking")
    program(root)
    main(["check", str(root)])
    flagged = [line for line in _lines(capsys) if "regulator's bandwidth" in line]
    assert len(flagged) == 1 and flagged[0].startswith("suspicious: ")
    assert "stage2/program.csv" in flagged[0] and "below the braking's speed harmonics" in flagged[0]
