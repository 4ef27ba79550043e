"""Physically impossible rows in a log: every reader that knows the device refuses them with
the file and the line (check as an error, the other commands in one line, exit 2), and the
virtual device's genuine logs, as a drive's logger writes them, never come near the bounds
and have no glitch. (One such row among neighbours that agree is a glitch, left out with a
warning: tests/test_cli_log_glitches.py.)"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from benchmarks.experiments import vary
from rsp_inertia.cli import main
from rsp_inertia.plant.config import load_device
from rsp_inertia.plant.logs import read_device_log, read_log
from rsp_inertia.scenarios import create_default_experiment
from rsp_inertia.simulating import simulate
from rsp_inertia.virtual.config import LoggerSettings
from tests.conftest import copy_experiment
from tests.plant.test_log_formats import VARIANTS


def test_an_angle_jump_in_a_log_is_refused_by_check_identify_and_program(tmp_path, capsys):
    # A counter that skips by 3.1 rad from one row on, 1 ms after the row before: 3100 rad/s
    # on a device launched at 12 rad/s at most. Unchecked, it passes for half a turn of
    # braking work. (One row that jumps and comes back is a glitch, left out with a warning:
    # tests/test_cli_log_glitches.py.)
    root = create_default_experiment(tmp_path / "exp")
    assert main(["simulate", str(root), "--stage", "1"]) == 0
    device = load_device(root / "device.toml")
    path = root / "stage1" / "braking.csv"
    lines = path.read_text().splitlines(keepends=True)
    jump = round(3.1 / device.encoder.quantum) * device.encoder.quantum
    for k in range(100, len(lines)):
        t, phi, torque = lines[k].split(",")
        lines[k] = f"{t},{float(phi) + jump!r},{torque}"
    path.write_text("".join(lines))
    message = f"{path}, line 101: the angle jumps by 3.1"
    capsys.readouterr()
    assert main(["check", str(root)]) == 1
    out = capsys.readouterr().out
    assert any(line.startswith(f"error: {message}") for line in out.splitlines()), out
    for command in (["program", str(root), "--stage", "1"], ["identify", str(root)]):
        assert main(command) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and message in err, err
        assert "faster than any speed the device's runs can have" in err


SHORT_RUNS = {"stage1_launch_speed": 4.0, "stage1_braking_torque": 0.05, "coulomb": 0.05}
"""Stage 1 launched at a third of its speed and braked (and its pilot's coast stopped) harder than
the default's, so that its runs last a few seconds: the 10 kHz logs are read in seconds."""


def _logged(root: Path, rate: float, short: bool) -> Path:
    """The default experiment at ``rate`` as a drive's logger writes it (stamps jittered by
    the reader's limit, 2% of the rows dropped, counts of a 16-bit counter that wraps every
    turn) with every kind of log: braking, reverse (ideal), pilot and pendulum runs (0.5 s);
    ``short``: stage 1 only, its runs shortened (SHORT_RUNS)."""
    root = create_default_experiment(root)

    def device(d):
        stages = d.stages
        if short:
            one = replace(
                d.stages[0],
                launch_speed=SHORT_RUNS["stage1_launch_speed"],
                braking_torque=SHORT_RUNS["stage1_braking_torque"],
            )
            stages = (one, *d.stages[1:])
        return replace(
            d,
            stages=stages,
            encoder=replace(d.encoder, sample_rate=rate, counter_bits=16),
            pendulum=replace(d.pendulum, duration=0.5),
        )

    def virtual(v):
        logger = LoggerSettings(time_jitter=0.25, dropped_fraction=0.02, counts=True)
        friction = v.friction
        if short:
            friction = replace(friction, coulomb=SHORT_RUNS["coulomb"])
        return replace(v, logger=logger, friction=friction)

    vary(root, device=device, virtual=virtual)
    stage = 1 if short else None
    simulate(root, stage, "braking")
    simulate(root, stage, "reverse", ideal=True)
    simulate(root, stage, "pilot")
    simulate(root, stage, "pendulum")
    return root


@pytest.mark.parametrize(
    "rate, short",
    [
        (1000.0, True),
        (10000.0, True),  # about 12 s
        pytest.param(1000.0, False, marks=pytest.mark.slow),
        pytest.param(10000.0, False, marks=pytest.mark.slow),  # about 6 min
    ],
)
def test_genuine_logs_at_1_and_10_khz_stay_far_from_the_speed_bound(
    tmp_path, rate, short
):
    """Every log reads with the device's bounds, and would with a launch speed 5 x lower: the
    fastest step of a genuine log (a pilot's spin-up past the launch speed, jitter shortening
    a step, quantization) stays a fifth of the way to the bound."""
    root = _logged(tmp_path / "exp", rate, short)
    device = load_device(root / "device.toml")
    fastest = max(st.launch_speed for st in device.stages)
    paths = sorted(p for p in root.glob("stage*/*.csv") if not p.name.startswith("program"))
    kinds = {p.stem.split("_")[0] for p in paths}
    assert kinds == {"braking", "reverse", "pilot", "pendulum"}
    for path in paths:
        kind = path.stem.split("_")[0]
        assert path.read_text().startswith("t,counts,torque\n")
        log = read_device_log(path, device, kind)
        assert log.warnings == (), log.warnings  # no glitch (plant.log_glitches)
        assert np.diff(log.t).max() * rate > 1.5, path  # rows were dropped
        assert len(read_log(path, device.encoder, kind, launch_speed=fastest / 5)) == len(log)


# --- logs in the rig's logger's layout (device.toml [log]) --------------------------------

SEMICOLON_LAYOUT = VARIANTS["b semicolon, decimal comma, units row, named columns"]
"""A logger's European export: the [log] table of tests/plant/test_log_formats.py's variant b."""


def _with_layout(root: Path, layout: str) -> Path:
    (root / "device.toml").write_text((root / "device.toml").read_text() + layout)
    return root


def test_a_layout_is_simulated_checked_programmed_and_identified(tmp_path, capsys):
    """The virtual device's logger writes device.toml's layout; check reads it (the motor's
    temperature over each pass an ok line), program and the closed-loop reverse run on it."""
    root = _with_layout(create_default_experiment(tmp_path / "exp"), SEMICOLON_LAYOUT)
    assert main(["simulate", str(root), "--stage", "1"]) == 0
    text = (root / "stage1" / "braking.csv").read_text()
    assert text.startswith("Time [ms];Angle [deg];Torque [mN m];Motor temperature [C]\n")
    assert text.splitlines()[1] == "ms;deg;mN m;C"
    assert main(["program", str(root), "--stage", "1"]) == 0
    assert main(["simulate", str(root), "--stage", "1", "--part", "reverse"]) == 0
    capsys.readouterr()
    main(["check", str(root)])
    out = capsys.readouterr().out
    for name in ("braking", "reverse"):
        line = f"ok: {root / 'stage1' / name}.csv: motor temperature 25.0 to 25.0 C"
        assert line in out.splitlines(), out


LAYOUT_FAULTS = {
    # name: (added to device.toml, the message's words)
    "a column not found": (
        '[log]\ntorque_column = "Torque [N m]"\n',
        (
            "braking.csv, line 1: column 'Torque [N m]' not found; the header has 't', "
            "'phi', 'torque': set [log] torque_column"
        ),
    ),
    "the logs in another format": (
        '[log]\nformat = "parquet"\n',
        "braking.parquet: no such file, but braking.csv is there",
    ),
    "an unknown unit": ('[log]\nangle_unit = "grad"\n', "log.angle_unit: must be one of"),
}


@pytest.mark.parametrize("case", LAYOUT_FAULTS)
def test_a_layout_that_does_not_fit_the_logs_is_one_line_and_nothing_written(
    default_logs, tmp_path, capsys, case
):
    added, words = LAYOUT_FAULTS[case]
    root = _with_layout(copy_experiment(default_logs, tmp_path / "exp"), added)
    program = root / "stage1" / "program.csv"
    assert not program.exists()  # the ideal reverse needs none
    capsys.readouterr()
    for command in (["identify", str(root)], ["program", str(root), "--stage", "1"]):
        assert main(command) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and words in err, err
    assert not (root / "result.json").exists() and not program.exists()


def test_a_waveform_tdms_of_a_jittered_logger_is_refused_before_anything_is_written(
    tmp_path, capsys
):
    root = _with_layout(
        create_default_experiment(tmp_path / "exp"), '[log]\nformat = "tdms"\ntime_column = ""\n'
    )
    virtual = root / "virtual.toml"
    virtual.write_text(virtual.read_text() + "\n[logger]\ntime_jitter = 0.1\n")
    capsys.readouterr()
    assert main(["simulate", str(root), "--stage", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "waveform timing" in err, err
    assert not list(root.glob("stage1/*"))
