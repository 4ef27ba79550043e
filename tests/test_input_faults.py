"""Smaller faults of issue 36, each with its test: unwritable folders for ``design`` and
``demo``, the API's arguments of the wrong type, ``combine`` given one folder, read-only result
arrays, and ``check`` agreeing with ``identify`` on a program at another sample rate."""

from __future__ import annotations

import dataclasses
import os
import re

import numpy as np
import pytest

import rsp_inertia
from rsp_inertia.cli import main
from tests.conftest import copy_experiment
from tests.test_combine_cli import TURNED_X90, _mounting, one_line_error

ROOT = os.geteuid() == 0
"""Root writes into read-only folders: a file in the folder's place stands for one."""


# --- design and demo on a folder they cannot write ------------------------------------------


@pytest.fixture
def no_work(monkeypatch):
    """Records whether design's search or the demo's first step started."""
    from rsp_inertia import axis_designs, rig_demo

    started = []
    monkeypatch.setattr(axis_designs, "best_cone_opening", lambda: started.append("design"))
    monkeypatch.setattr(rig_demo, "create_rig_experiment", lambda p: started.append("demo"))
    return started


@pytest.mark.parametrize("command", ["design", "demo"])
def test_a_file_in_the_folders_place_is_one_line_before_any_work(
    tmp_path, capsys, no_work, command
):
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    argv = {
        "design": ["design", "--plot", str(blocker / "design.png")],
        "demo": ["demo", str(blocker / "exp")],
    }[command]
    capsys.readouterr()
    assert main(argv) == 2
    one_line_error(capsys, str(blocker), "nothing was computed")
    assert no_work == []


def test_a_demo_subfolder_that_is_a_file_is_one_line(tmp_path, capsys, no_work):
    root = tmp_path / "exp"
    (root / "calibration").mkdir(parents=True)
    (root / "calibration" / "empty").write_text("")
    assert main(["demo", str(root)]) == 2
    one_line_error(capsys, str(root / "calibration" / "empty"), "is a file, not a folder")
    assert no_work == []


@pytest.mark.skipif(ROOT, reason="root writes into read-only folders")
@pytest.mark.parametrize("command", ["design", "demo"])
def test_a_read_only_folder_is_one_line_before_any_work(tmp_path, capsys, no_work, command):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        argv = {"design": ["design", "--plot", str(folder / "d.png")],
                "demo": ["demo", str(folder)]}[command]
        capsys.readouterr()
        assert main(argv) == 2
        one_line_error(capsys, "cannot be written", "nothing was computed")
    finally:
        folder.chmod(0o755)
    assert no_work == []


# --- the API's arguments of the wrong type -------------------------------------------------

WRONG = {
    "identify(None)": (lambda e: rsp_inertia.identify(None), "identify: path: "),
    "identify(3)": (lambda e: rsp_inertia.identify(3), "identify: path: "),
    "program(stage='1')": (lambda e: rsp_inertia.program(e, stage="1"), "program: stage: "),
    "program(stage=1.5)": (lambda e: rsp_inertia.program(e, stage=1.5), "program: stage: "),
    "program(stage=True)": (lambda e: rsp_inertia.program(e, stage=True), "program: stage: "),
    "simulate(stage='2')": (lambda e: rsp_inertia.simulate(e, stage="2"), "simulate: stage: "),
    "simulate(ideal='no')": (lambda e: rsp_inertia.simulate(e, ideal="no"),
                             "simulate: ideal: "),
    "calibrate(empty=None)": (lambda e: rsp_inertia.calibrate(e, None), "calibrate: empty: "),
    "calibrate(reference=3)": (lambda e: rsp_inertia.calibrate(e, e, 3),
                               "calibrate: reference: "),
    "plan(max_duration='100')": (lambda e: rsp_inertia.plan(e, "100"),
                                 "plan: max_duration: "),
    "plan(rehearse=None)": (lambda e: rsp_inertia.plan(e, rehearse=None), "plan: rehearse: "),
    "check(None)": (lambda e: rsp_inertia.check(None), "check: path: "),
    "check(calibration='yes')": (lambda e: rsp_inertia.check(e, calibration="yes"),
                                 "check: calibration: "),
    "write_report(None)": (lambda e: rsp_inertia.write_report(None), "write_report: path: "),
    "create_experiment(None)": (lambda e: rsp_inertia.create_experiment(None),
                                "create_experiment: path: "),
    "combine([None])": (lambda e: rsp_inertia.combine([None], e), "combine: paths[0]: "),
    "combine(out=None)": (lambda e: rsp_inertia.combine([e], None), "combine: out: "),
    "combine(3)": (lambda e: rsp_inertia.combine(3, e), "combine: paths: "),
    "demo(None)": (lambda e: rsp_inertia.demo(None), "demo: path: "),
    "export(None)": (lambda e: rsp_inertia.export(None, e / "x"), "export: source: "),
    "export(mass='2')": (lambda e: rsp_inertia.export(e, e / "x", mass="2"), "export: mass: "),
    "export(frame=1)": (lambda e: rsp_inertia.export(e, e / "x", frame=1), "export: frame: "),
}


@pytest.mark.parametrize("call", list(WRONG))
def test_a_wrong_type_is_an_input_error_of_one_line(tmp_path, call):
    run, start = WRONG[call]
    exp = rsp_inertia.create_experiment(tmp_path / "exp")
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    with pytest.raises(rsp_inertia.InputError) as raised:
        run(exp)
    message = str(raised.value)
    assert message.startswith(start) and "\n" not in message, message
    assert re.search(r"must be .*, got ", message)
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before


def test_combine_takes_one_folder_as_a_list_of_one(tmp_path):
    first = _mounting(tmp_path / "a", np.eye(3))
    second = _mounting(tmp_path / "b", TURNED_X90)
    messages = []
    for paths in (str(first), first, [str(first)]):
        with pytest.raises(rsp_inertia.InputError) as raised:
            rsp_inertia.combine(paths, tmp_path / "body")
        messages.append(str(raised.value))
    # one mounting cannot give z_c: the same refusal, not a folder per character
    assert messages[0] == messages[1] == messages[2] and "cannot give z_c" in messages[0]
    body = rsp_inertia.combine((first, second), tmp_path / "body")
    assert body.combination.names == (str(first), str(second))


# --- result arrays are read-only ------------------------------------------------------------


def _arrays(obj, path="result", seen=None):
    """(path, array) of every NumPy array a result holds or gives: fields and properties,
    through the records, lists, tuples and dicts inside it."""
    seen = set() if seen is None else seen
    if id(obj) in seen:
        return
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        yield path, obj
    elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        names = [f.name for f in dataclasses.fields(obj)]
        names += [n for n in dir(type(obj)) if isinstance(getattr(type(obj), n), property)]
        for name in names:
            yield from _arrays(getattr(obj, name), f"{path}.{name}", seen)
    elif isinstance(obj, (list, tuple)):
        for i, item in enumerate(obj):
            yield from _arrays(item, f"{path}[{i}]", seen)
    elif isinstance(obj, dict):
        for key, item in obj.items():
            yield from _arrays(item, f"{path}[{key!r}]", seen)


def _writable(result) -> list[str]:
    found = list(_arrays(result))
    assert found, "no array found"
    return [path for path, array in found if array.flags.writeable]


def test_an_identify_result_and_its_record_are_read_only(default_logs, tmp_path):
    root = copy_experiment(default_logs, tmp_path / "exp")
    result = rsp_inertia.identify(root)
    assert _writable(result) == []
    with pytest.raises(ValueError, match="read-only"):
        result.identification.entries[0] = 0.0
    with pytest.raises(ValueError, match="read-only"):
        result.entries[0] = 0.0


def test_combine_export_and_design_results_are_read_only(tmp_path):
    first = _mounting(tmp_path / "a", np.eye(3))
    second = _mounting(tmp_path / "b", TURNED_X90)
    body = rsp_inertia.combine([first, second], tmp_path / "body")
    exported = rsp_inertia.export(tmp_path / "body", tmp_path / "body.json", mass_std=0.001)
    design = rsp_inertia.api.axis_designs([first, second], tmp_path / "design.png")
    for result in (body, exported, design):
        assert _writable(result) == [], type(result).__name__


# --- check and identify agree on a program made at another sample rate ----------------------


def test_check_is_ready_where_identify_runs_after_the_sample_rate_changed(
    default_logs, tmp_path, capsys
):
    """A program.csv made at 1000 Hz, then device.toml's sample_rate corrected to 1001:
    identify never reads program.csv and runs; check said "not ready" (an error for the
    program). With its reverse log there it is suspicious; without, still an error (the
    drive could not run it)."""
    root = copy_experiment(default_logs, tmp_path / "exp")
    header = "t,phi_ref,omega_ref,torque_ff,k_phi,k_omega"
    rows = [f"{k / 1000.0!r},{0.01 * k!r},10.0,0.005,80.0,2.5" for k in range(200)]
    for stage in (1, 2):
        (root / f"stage{stage}" / "program.csv").write_text("\n".join([header, *rows]) + "\n")
    device = root / "device.toml"
    text, found = re.subn(r"sample_rate = 1000\.0", "sample_rate = 1001.0", device.read_text())
    assert found == 1
    device.write_text(text)
    capsys.readouterr()
    assert main(["check", str(root)]) == 0
    out = capsys.readouterr().out
    flagged = [line for line in out.splitlines() if "program.csv, line 3: time step" in line]
    assert len(flagged) == 2 and all(line.startswith("suspicious: ") for line in flagged)
    assert "identify does not read the program" in flagged[0]
    assert main(["identify", str(root)]) == 0
    (root / "stage1" / "reverse.csv").unlink()
    capsys.readouterr()
    assert main(["check", str(root)]) == 1
    assert any(line.startswith("error: ") and "stage1/program.csv, line 3" in line
               for line in capsys.readouterr().out.splitlines())
