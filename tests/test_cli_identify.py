"""``rsp-inertia identify`` on bad logs: exit status 2 and one line on stderr naming the file.

The logs are small synthetic passes (a uniform deceleration to rest and its exact mirror, read
by the default encoder), so that most checks fire before or soon after smoothing. A valid
pair of them passes every check of a stage (test_missing_reverse_log_of_a_later_stage).
"""

import math

import numpy as np
import pytest

from rsp_inertia.cli import main
from rsp_inertia.plant.config import load_device
from rsp_inertia.plant.logs import Log, write_log
from rsp_inertia.scenarios import create_default_experiment

RELEASE = math.radians(-30.0)
"""rad, where the synthetic braking starts (the default's release)."""

TORQUE = 0.005
"""N m, the synthetic braking torque (logged against the motion; the reverse drives)."""


@pytest.fixture
def experiment(tmp_path):
    """The default device.toml with empty stage folders."""
    root = create_default_experiment(tmp_path / "exp")
    for stage in (1, 2):
        (root / f"stage{stage}").mkdir()
    return root


def encoder(root):
    return load_device(root / "device.toml").encoder


def uniform_braking(root, turns: float, duration: float):
    """(braking, reverse) logs: uniform deceleration over ``turns`` to rest, and its mirror.

    Braking: phi(t) = phi_0 + W t - W t^2 / (2 T) with W T / 2 = turns * 2 pi; reverse:
    phi'(t') = phi(T - t') (docs/method.md §4). Both read as floor(phi / q) q.
    """
    enc = encoder(root)
    q, dt = enc.quantum, enc.dt
    n = round(duration / dt)
    t = np.arange(n) * dt
    top = 2 * turns * 2 * math.pi / duration

    def angle(time):
        return RELEASE + top * (time - time**2 / (2 * duration))

    braking = Log(t=t, phi=np.floor(angle(t) / q) * q, torque=np.full(n, -TORQUE))
    reverse = Log(t=t, phi=np.floor(angle(duration - t) / q) * q, torque=np.full(n, TORQUE))
    return braking, reverse


def write_stage(root, stage: int, braking: Log | None, reverse: Log | None):
    """Write the stage's logs; returns their paths."""
    b_path = root / f"stage{stage}" / "braking.csv"
    r_path = root / f"stage{stage}" / "reverse.csv"
    if braking is not None:
        write_log(b_path, braking)
    if reverse is not None:
        write_log(r_path, reverse)
    return b_path, r_path


def edit_line(path, line: int, column: int, text: str) -> None:
    """Replace one field of one line of a CSV (line 1 is the header)."""
    lines = path.read_text().split("\n")
    fields = lines[line - 1].split(",")
    fields[column] = text
    lines[line - 1] = ",".join(fields)
    path.write_text("\n".join(lines))


def identify_fails(root, capsys) -> str:
    """Run ``identify``; it must exit 2 with one line on stderr and write no result."""
    status = main(["identify", str(root)])
    err = capsys.readouterr().err.strip()
    assert status == 2, err
    assert len(err.splitlines()) == 1, err
    assert not (root / "result.json").exists()
    return err


def test_missing_reverse_log_of_a_later_stage(experiment, capsys):
    # Stage 1 is complete and valid (3 turns), so the run reaches stage 2.
    write_stage(experiment, 1, *uniform_braking(experiment, turns=3, duration=2.0))
    braking, _ = uniform_braking(experiment, turns=3, duration=2.0)
    _, r_path = write_stage(experiment, 2, braking, None)
    err = identify_fails(experiment, capsys)
    assert str(r_path) in err
    assert "no such file" in err


def no_overlap(root, capsys):
    """Stage 1's reverse stops half a turn back from the rest angle: no turn in common."""
    braking, reverse = uniform_braking(root, turns=3, duration=2.0)
    n = np.nonzero(reverse.phi >= reverse.phi[0] - math.pi)[0][-1] + 1
    short = Log(t=reverse.t[:n], phi=reverse.phi[:n], torque=reverse.torque[:n])
    paths = write_stage(root, 1, braking, short)
    return identify_fails(root, capsys), paths


def too_few_turns(root, capsys):
    """1.5 turns: the common range at useful speed (above 20 % of the top speed, 0.1 rad in
    from each end) is ~1.4 turns, so some node has no whole turn after its first passage."""
    paths = write_stage(root, 1, *uniform_braking(root, turns=1.5, duration=1.5))
    return identify_fails(root, capsys), paths




def test_logs_that_do_not_overlap(experiment, capsys):
    err, _ = no_overlap(experiment, capsys)
    assert "stage 1" in err
    assert "overlap" in err


def test_logs_that_do_not_overlap_name_the_reverse_that_stopped_early(experiment, capsys):
    """The braking covers its 3 turns; the reverse stopped half a turn after its start: the
    reverse is at fault, not the protocol (no hint at braking_torque)."""
    err, (b_path, r_path) = no_overlap(experiment, capsys)
    assert err.startswith(f"rsp-inertia: error: {r_path}: stage 1: covers 0.5")
    assert f"of the 3.00 the braking logged ({b_path}); the reverse run stopped early" in err
    assert "braking_torque" not in err


def test_too_few_turns_at_useful_speed(experiment, capsys):
    err, _ = too_few_turns(experiment, capsys)
    assert "stage 1" in err
    assert "turns at useful speed" in err


def test_too_few_turns_name_the_braking_and_the_protocol(experiment, capsys):
    """The reverse mirrors all of a braking that is too short: the braking is at fault, and
    the remedy is the protocol's."""
    err, (b_path, r_path) = too_few_turns(experiment, capsys)
    assert err.startswith(f"rsp-inertia: error: {b_path}: stage 1: the braking covers ")
    assert "lower braking_torque or higher launch_speed" in err
    assert str(r_path) not in err


def test_speed_reversing_inside_the_braking(experiment, capsys):
    braking, reverse = uniform_braking(experiment, turns=3, duration=2.0)
    q = encoder(experiment).quantum
    phi = braking.phi.copy()
    k = len(phi) - 5  # near rest, where the body moves under a count per sample
    phi[k] = phi[k - 1] - q  # one count back
    b_path, _ = write_stage(
        experiment, 1, Log(t=braking.t, phi=phi, torque=braking.torque), reverse
    )
    err = identify_fails(experiment, capsys)
    assert str(b_path) in err
    assert f"line {k + 2}" in err  # data row k is line k + 2 (the header is line 1)
    assert "reverses" in err


def test_reverse_log_on_another_encoder_grid(experiment, capsys):
    braking, reverse = uniform_braking(experiment, turns=3, duration=2.0)
    q = encoder(experiment).quantum
    coarse = 2 * math.pi / 4096  # a 12-bit encoder: 16 counts of the 16-bit one...
    phi = np.floor(reverse.phi / coarse) * coarse + 0.3 * q  # ...with a zero off the grid
    _, r_path = write_stage(
        experiment, 1, braking, Log(t=reverse.t, phi=phi, torque=reverse.torque)
    )
    err = identify_fails(experiment, capsys)
    assert str(r_path) in err
    assert "line 2" in err
    assert "grid" in err


def test_nan_in_the_torque(experiment, capsys):
    b_path, _ = write_stage(experiment, 1, *uniform_braking(experiment, turns=3, duration=2.0))
    edit_line(b_path, 100, 2, "nan")
    err = identify_fails(experiment, capsys)
    assert str(b_path) in err
    assert "line 100" in err
    assert "torque" in err


def test_time_going_backwards(experiment, capsys):
    _, r_path = write_stage(experiment, 1, *uniform_braking(experiment, turns=3, duration=2.0))
    edit_line(r_path, 50, 0, repr(47 * encoder(experiment).dt))  # line 50 holds t = 48 dt
    err = identify_fails(experiment, capsys)
    assert str(r_path) in err
    assert "line 50" in err
    assert "increasing" in err
