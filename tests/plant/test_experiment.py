"""The experiment folder: where each direction's files live, and the virtual device writing
both directions of a stage through ``rsp_inertia.simulating.simulate``."""

import math
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from rsp_inertia import scenarios, simulating
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant import experiment
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.logs import read_log
from rsp_inertia.virtual.config import experiment_virtual


def short_experiment(root: Path, directions: str) -> Path:
    """The default experiment with short braking passes (~2 turns, a few seconds each) and
    stage 1 run in ``directions`` (a TOML array)."""
    scenarios.create_default_experiment(root)
    path = root / "device.toml"
    text = path.read_text()
    text = re.sub(r"launch_speed = [0-9.]+", "launch_speed = 5.0", text)
    text = text.replace(
        "braking_torque = 0.005       # N m",
        f"braking_torque = 0.05\ndirections = {directions}",
    )
    text = text.replace("braking_torque = 0.12 ", "braking_torque = 0.5 ")
    path.write_text(text)
    return root


def test_backward_files_sit_beside_the_forward_ones(tmp_path):
    exp = open_experiment(scenarios.create_default_experiment(tmp_path))
    stage1 = tmp_path / "stage1"
    assert exp.braking_path(1) == exp.braking_path(1, Direction.FORWARD) == stage1 / "braking.csv"
    assert exp.program_path(1, Direction.FORWARD) == stage1 / "program.csv"
    assert exp.reverse_path(1) == stage1 / "reverse.csv"
    assert exp.braking_path(2, Direction.BACKWARD) == tmp_path / "stage2" / "braking_backward.csv"
    assert exp.program_path(1, Direction.BACKWARD) == stage1 / "program_backward.csv"
    assert exp.reverse_path(1, Direction.BACKWARD) == stage1 / "reverse_backward.csv"
    with pytest.raises(InputError, match="no stage 3"):
        exp.reverse_path(3, Direction.BACKWARD)


def test_the_experiments_files_are_named_in_one_place(tmp_path):
    """Each file of the folder has its name in plant.experiment, and its path on Experiment."""
    exp = open_experiment(scenarios.create_default_experiment(tmp_path))
    assert exp.device_path == tmp_path / experiment.DEVICE_FILE == tmp_path / "device.toml"
    assert exp.virtual_path == tmp_path / experiment.VIRTUAL_FILE == tmp_path / "virtual.toml"
    paths = {
        "calibration.toml": exp.calibration_path,
        "reference.toml": exp.reference_path,
        "result.json": exp.result_path,
        "report.html": exp.report_path,
        "plan.png": exp.plan_figure_path,
    }
    assert paths == {name: tmp_path / name for name in paths}
    assert (experiment.CALIBRATION_FILE, experiment.REFERENCE_FILE, experiment.RESULT_FILE) == (
        "calibration.toml",
        "reference.toml",
        "result.json",
    )
    assert exp.identify_inputs() == [exp.device_path]  # the logs, once simulated, follow
    (tmp_path / experiment.CALIBRATION_FILE).write_text("")
    assert exp.identify_inputs() == [exp.device_path, exp.calibration_path]


def test_simulate_writes_every_direction_of_each_stage(tmp_path):
    root = short_experiment(tmp_path, '["forward", "backward"]')
    summaries = simulating.simulate(root, part="braking")
    exp = open_experiment(root)
    assert [(s.stage, s.direction) for s in summaries] == [
        (1, "forward"),
        (1, "backward"),
        (2, "forward"),
    ]
    assert str(summaries[1]).startswith("stage 1: braking backward: ")
    assert str(summaries[0]).startswith("stage 1: braking: ")
    backward = read_log(
        exp.braking_path(1, Direction.BACKWARD), exp.device.encoder, "braking", Direction.BACKWARD
    )
    assert backward.phi[-1] < backward.phi[0]
    # Turns past the last node, along the motion: the release sits 30 deg before node 0 in
    # either direction; the last node met is 240 deg further forward, 270 deg further back.
    for summary, log, last in (
        (summaries[0], read_log(exp.braking_path(1), exp.device.encoder, "braking"), 270.0),
        (summaries[1], backward, 270.0),
    ):
        span = abs(log.phi[-1] - log.phi[0]) / (2 * math.pi)
        assert summary.turns == pytest.approx(span)
        # The log starts at the encoder's reading of the release, within a count (1.5e-5
        # turns) of the true angle the node passages are counted from.
        assert summary.turns_past_last_node == pytest.approx(span - last / 360.0, abs=1e-4)

    reverses = simulating.simulate(root, stage=1, part="reverse", ideal=True, direction="backward")
    assert [(s.stage, s.part, s.direction) for s in reverses] == [(1, "ideal reverse", "backward")]
    reverse = read_log(
        exp.reverse_path(1, Direction.BACKWARD), exp.device.encoder, "reverse", Direction.BACKWARD
    )
    assert reverse.phi[-1] > reverse.phi[0]
    assert not exp.reverse_path(1).exists()


def test_simulate_refuses_a_direction_no_stage_runs(tmp_path):
    root = short_experiment(tmp_path, '["forward"]')
    with pytest.raises(InputError, match=r"stage\[2\]\.directions: does not include 'backward'"):
        simulating.simulate(root, stage=2, direction="backward")
    with pytest.raises(InputError, match="no stage's directions include 'backward'"):
        simulating.simulate(root, direction="backward")
    with pytest.raises(InputError, match="--direction: must be one of forward, backward"):
        simulating.simulate(root, direction="up")


def test_the_reverse_needs_the_backward_braking_of_the_same_settings(tmp_path):
    root = short_experiment(tmp_path, '["backward"]')
    with pytest.raises(InputError, match="braking_backward.csv: not found"):
        simulating.simulate(root, stage=1, part="reverse", ideal=True)
    simulating.simulate(root, stage=1, part="braking")
    exp = open_experiment(root)
    assert exp.braking_path(1, Direction.BACKWARD).is_file() and not exp.braking_path(1).exists()
    path = root / "virtual.toml"
    path.write_text(path.read_text().replace("seed = 0", "seed = 1"))
    with pytest.raises(InputError, match="not the virtual device's braking pass"):
        simulating.simulate(root, stage=1, part="reverse", ideal=True)


def test_load_virtual_checks_the_rigs_tare_against_the_stages(tmp_path):
    root = scenarios.create_default_experiment(tmp_path)
    path = root / "virtual.toml"
    path.write_text(path.read_text() + "\n[rig]\ntare_inertia = [0.004]\n")
    with pytest.raises(InputError) as error:
        experiment_virtual(open_experiment(root))
    message = str(error.value)
    assert "\n" not in message and message.startswith(f"{path}: rig.tare_inertia: ")


def test_simulate_without_virtual_toml_says_where_to_get_one(tmp_path):
    """The message names the file and the way to one; following it, simulate runs on the
    device.toml already there (the one-line command the message gives, run as given)."""
    root = short_experiment(tmp_path / "bench", '["forward"]')
    device = (root / "device.toml").read_text()
    (root / "virtual.toml").unlink()
    with pytest.raises(InputError) as error:
        simulating.simulate(root, stage=1)
    message = str(error.value)
    assert "\n" not in message and message.startswith(f"{root / 'virtual.toml'}: not found: ")
    assert "docs/files.md" in message
    command = re.search(r'python -c "[^"]+"', message).group(0)
    subprocess.run([sys.executable, *shlex.split(command)[1:]], check=True)
    assert (root / "device.toml").read_text() == device
    (summary,) = simulating.simulate(root, stage=1)
    assert summary.rows > 0
