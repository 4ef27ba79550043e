"""A braking log that goes on after the stop, as a real drive's does: check, program and
identify cut it at its turning point and say so in the same one line, and work from it as
from the log that ended at the stop; an ambiguous end is refused in one line (exit 2)."""

from __future__ import annotations

import json

import numpy as np

from rsp_inertia.cli import main
from rsp_inertia.plant.config import load_device
from tests.conftest import copy_experiment


def _go_on(path, counts, q):
    """The log at ``path`` going on at 1 ms a row with readings ``counts`` off its last."""
    lines = path.read_text().splitlines()
    t, phi, torque = (float(x) for x in lines[-1].split(","))
    rows = [f"{t + k * 1e-3!r},{phi + int(c) * q!r},{torque!r}" for k, c in enumerate(counts, 1)]
    path.write_text("\n".join(lines + rows) + "\n")
    return len(lines)  # the file's line of its last row before


def test_a_held_tail_is_cut_and_said_in_one_line_by_every_command(default_logs, tmp_path, capsys):
    clean = copy_experiment(default_logs, tmp_path / "clean")
    held = copy_experiment(default_logs, tmp_path / "held")
    q = load_device(held / "device.toml").encoder.quantum
    path = held / "stage1" / "braking.csv"
    dither = np.random.default_rng(0).integers(-1, 2, 400)
    dither[:3] = [-1, -2, -2]  # settling back through the backlash, then dithering
    _go_on(path, dither - 1, q)
    capsys.readouterr()
    assert main(["check", str(held)]) == 0
    out = capsys.readouterr().out
    (note,) = [line for line in out.splitlines() if f"{path}, lines " in line]
    assert note.startswith("ok: ") and "turning point" in note and "left out" in note
    said = note.removeprefix("ok: ")
    assert main(["program", str(held), "--stage", "1"]) == 0
    assert f"warning: {said}" in capsys.readouterr().out.splitlines()
    assert main(["program", str(clean), "--stage", "1"]) == 0
    programs = [
        np.loadtxt(root / "stage1" / "program.csv", delimiter=",", skiprows=1)
        for root in (clean, held)
    ]
    # The same program but for the last few ms before the rest (the clean log's last stay
    # at its reading, which the cut leaves to the rest fit): lengths within a few rows, the
    # reference angle within a few counts.
    assert abs(len(programs[0]) - len(programs[1])) <= 5
    n = min(len(p) for p in programs)
    shift = len(programs[1]) - len(programs[0])
    a, b = programs[0][max(-shift, 0):][: n - 5], programs[1][max(shift, 0):][: n - 5]
    assert np.max(np.abs(a[:, 1] - b[:, 1])) < 20 * q
    for root in (clean, held):
        assert main(["identify", str(root)]) == 0
    err = capsys.readouterr().err  # the result on stdout, its warnings on stderr
    assert f"warning: {said}" in err.splitlines()
    results = [json.loads((root / "result.json").read_text()) for root in (clean, held)]
    entries = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")
    tensors = [np.array([r["tensor"][e] for e in entries]) for r in results]
    stds = np.array([results[0]["tensor_std"][e] for e in entries])
    assert np.all(np.abs(tensors[1] - tensors[0]) <= stds), (tensors, stds)


def test_an_ambiguous_end_is_refused_in_one_line(default_logs, tmp_path, capsys):
    root = copy_experiment(default_logs, tmp_path / "exp")
    path = root / "stage1" / "braking.csv"
    q = load_device(root / "device.toml").encoder.quantum
    last = _go_on(path, [0] * 300 + list(range(1, 60)), q)  # held, then it moves on
    capsys.readouterr()
    for command in (["program", str(root), "--stage", "1"], ["identify", str(root)]):
        assert main(command) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1, err
        assert f"{path}, lines " in err and "turning point is ambiguous" in err, err
        assert f"-{last + 300 + 32}: " in err, err  # the first row 32 counts on


def test_the_virtual_drive_holding_after_the_stop_simulates_its_reverse(tmp_path, capsys):
    """virtual.toml [logger] hold_after_stop: simulate's braking goes on after the stop, and
    its reverse is simulated from it (the braking on disk, cut by the reader at its turning
    point, is recognised as the simulator's own)."""
    from rsp_inertia.scenarios import create_default_experiment

    root = create_default_experiment(tmp_path / "held")
    with open(root / "virtual.toml", "a") as file:
        file.write("\n[logger]\nhold_after_stop = 0.2\n")
    assert main(["simulate", str(root), "--part", "braking", "--stage", "1"]) == 0
    assert main(["simulate", str(root), "--part", "reverse", "--stage", "1", "--ideal"]) == 0
    out = capsys.readouterr().out
    assert "stage 1: ideal reverse" in out, out
