"""The Python API (rsp_inertia.api, docs/api.md): the commands as functions with result objects.

Each result's ``str`` is compared with what ``rsp-inertia`` prints for the same experiment,
each InputError with the command line's stderr line, identify's ``to_json`` with
result.json. The experiments are the default one with short passes (the protocol ``plan``
chooses within 40 s: 4-9 s brakings) and an ideal reverse, so that identify takes seconds.
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import inspect
import json
import pkgutil
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import rsp_inertia
import rsp_inertia.results
from rsp_inertia.cli import main
from rsp_inertia.plant.config import load_device

SHORT_PROTOCOL = {
    "launch_speed = 12.0 ": "launch_speed = 10.3 ",
    "braking_torque = 0.005 ": "braking_torque = 0.0652",
    "launch_speed = 3.5 ": "launch_speed = 4.26",
    "braking_torque = 0.12 ": "braking_torque = 0.362",
}
"""The default device.toml's protocol -> a short one (stage 1: 4.5 s, stage 2: 9.3 s)."""

PLAN_TABLE = """
[plan]                             # rough guesses for plan
inertia = [0.02, 0.025, 0.03]      # kg m^2
friction = [1e-4, 1e-4, 1e-3]      # a1, a2, a3
com_offset = 0.0035                # m
torque_noise = 1e-4                # N m
"""

FIXTURE = """
[fixture]
mass = 0.8
inertia = [0.004, 0.0045, 0.006, 0.0002, -0.0001, 0.00015]
com = [0.001, 0.0005, 0.0]
"""
"""A mounting plate (virtual.toml): it gives the empty fixture enough inertia for 3 turns."""


def short_experiment(root: Path, logs: bool = True) -> Path:
    """The default experiment with short passes; with ``logs``, braking and ideal reverse."""
    root = rsp_inertia.create_experiment(root)
    text = (root / "device.toml").read_text()
    for old, new in SHORT_PROTOCOL.items():
        assert old in text
        text = text.replace(old, new)
    (root / "device.toml").write_text(text)
    if logs:
        rsp_inertia.simulate(root, part="braking")
        rsp_inertia.simulate(root, part="reverse", ideal=True)
    return root


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """(experiment folder, IdentifyResult, progress lines) of the API's identify."""
    root = short_experiment(tmp_path_factory.mktemp("api") / "exp")
    lines: list[str] = []
    result = rsp_inertia.identify(root, progress=lines.append)
    return root, result, lines


def cli(capsys, *argv) -> tuple[int, str, str]:
    """Run ``rsp-inertia *argv``; (exit status, stdout, stderr)."""
    capsys.readouterr()
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


WALL_TIME = re.compile(r"; \d+\.\d\d s -> ")
"""The wall time in program's line, which differs between two runs."""


# --- names and docstrings -------------------------------------------------------------------


def _sections(doc: str) -> dict[str, str]:
    """numpydoc sections of a docstring: title -> body."""
    doc = inspect.cleandoc(doc)
    parts = re.split(r"^(\w[\w ]*)\n-{3,}\n", doc, flags=re.MULTILINE)
    return dict(zip(parts[1::2], parts[2::2]))


def _documented_names(body: str) -> set[str]:
    """The names a Parameters/Attributes section documents (``a, b : type`` lines)."""
    names = set()
    for line in body.splitlines():
        match = re.match(r"^([A-Za-z_][\w, ]*?) :", line)
        if match:
            names |= {name.strip() for name in match.group(1).split(",")}
    return names


API_FUNCTIONS = [
    "calibrate", "check", "combine", "create_experiment", "demo", "export", "identify", "plan",
    "program", "simulate", "write_report",
]
API_CLASSES = [
    "CalibrateResult", "CheckResult", "CombineResult", "ExportResult", "IdentifyResult",
    "PlanResult",
    "ProgramResult", "SimulateResult",
]


def test_all_is_sorted_and_complete():
    assert rsp_inertia.__all__ == sorted(rsp_inertia.__all__)
    assert set(rsp_inertia.__all__) == {*API_FUNCTIONS, *API_CLASSES, "InputError", "__version__"}
    for name in rsp_inertia.__all__:
        assert getattr(rsp_inertia, name) is not None
        assert name in dir(rsp_inertia)
    with pytest.raises(AttributeError, match="no attribute 'identfy'"):
        rsp_inertia.identfy  # noqa: B018



def test_the_api_module_gives_the_same_objects():
    """The package's names are the API's (both lists are made from rsp_inertia.public); no
    module shadows a function (the demo's module is rig_demo, not demo)."""
    import rsp_inertia.api
    import rsp_inertia.rig_demo

    for name in rsp_inertia.api.__all__:
        assert getattr(rsp_inertia.api, name) is getattr(rsp_inertia, name)
    assert inspect.isfunction(rsp_inertia.demo)

@pytest.mark.parametrize("name", API_FUNCTIONS)
def test_functions_have_numpydoc_docstrings(name):
    function = getattr(rsp_inertia, name)
    sections = _sections(function.__doc__)
    assert {"Parameters", "Returns", "Examples"} <= set(sections), sections.keys()
    parameters = set(inspect.signature(function).parameters)
    assert _documented_names(sections["Parameters"]) == parameters


@pytest.mark.parametrize("name", API_CLASSES)
def test_result_classes_document_every_field(name):
    cls = getattr(rsp_inertia, name)
    sections = _sections(cls.__doc__)
    assert {"Attributes", "Examples"} <= set(sections), sections.keys()
    fields = {f.name for f in dataclasses.fields(cls)}
    assert _documented_names(sections["Attributes"]) >= fields
    assert dataclasses.fields(cls) and cls.__dataclass_params__.frozen
    for method in ("to_json", "figures"):
        if hasattr(cls, method):
            assert "Returns" in _sections(getattr(cls, method).__doc__)
    assert "to_json" in vars(cls) and cls.__str__ is not object.__str__


def test_input_error_is_the_librarys():
    from rsp_inertia.infra.errors import InputError

    assert rsp_inertia.InputError is InputError


def test_version_is_the_installed_one():
    assert isinstance(rsp_inertia.__version__, str)
    assert rsp_inertia.__version__ == importlib.metadata.version("rsp-inertia")


def test_import_loads_no_numerical_stack():
    """``import rsp_inertia`` and looking its functions up import none of the heavy packages;
    a result class loads numpy (rsp_inertia.results formats numbers with it), nothing else
    heavy."""
    code = (
        "import sys, rsp_inertia\n"
        "rsp_inertia.identify, rsp_inertia.combine, rsp_inertia.InputError\n"
        "rsp_inertia.__version__\n"
        "heavy = ('numpy', 'scipy', 'casadi', 'matplotlib', 'control')\n"
        "print(sorted({m.split('.')[0] for m in sys.modules} & set(heavy)))\n"
        "rsp_inertia.IdentifyResult, rsp_inertia.PlanResult, rsp_inertia.CombineResult\n"
        "print(sorted({m.split('.')[0] for m in sys.modules} & set(heavy)))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.split() == ["[]", "['numpy']"]


def _heavy_after(imports: str) -> list[str]:
    """The heavy packages loaded by ``imports`` in a fresh interpreter."""
    code = (
        f"import sys\nimport {imports}\n"
        "heavy = ('numpy', 'scipy', 'casadi', 'matplotlib', 'control')\n"
        "print(' '.join(sorted({m.split('.')[0] for m in sys.modules} & set(heavy))))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    return out.split()


RESULT_MODULES = [
    info.name
    for info in pkgutil.iter_modules(rsp_inertia.results.__path__, "rsp_inertia.results.")
]
"""Every module of rsp_inertia.results (one per command, and the shared one)."""


def test_each_command_loads_only_what_it_needs():
    """The results draw nothing themselves (their commands hand them their drawer): all of
    them together load numpy alone; combine
    loads neither CasADi nor matplotlib, check (identify's readers) no matplotlib."""
    assert _heavy_after("rsp_inertia.results") == []  # the names load on first use
    assert _heavy_after(", ".join(RESULT_MODULES)) == ["numpy"]
    assert _heavy_after("rsp_inertia.combining") == ["numpy", "scipy"]
    assert "matplotlib" not in _heavy_after("rsp_inertia.checking")
    assert "matplotlib" not in _heavy_after("rsp_inertia.simulating, rsp_inertia.programming")


# --- identify -------------------------------------------------------------------------------


def test_identify_prints_and_writes_what_the_command_line_does(identified, capsys):
    root, result, lines = identified
    written = (root / "result.json").read_text()
    assert result.to_json() == written
    assert lines and all("rows smoothed and balanced" in line for line in lines)
    status, out, _ = cli(capsys, "identify", root)
    assert status == 0
    assert out == "\n".join(lines + [str(result)]) + "\n"
    assert (root / "result.json").read_text() == written  # the same inputs, the same bytes
    assert str(result).endswith(f"\nresult -> {root / 'result.json'}")


def test_identify_result_fields(identified):
    root, result, _ = identified
    document = json.loads(result.to_json())
    names = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")
    np.testing.assert_array_equal(result.entries, [document["tensor"][n] for n in names])
    np.testing.assert_array_equal(result.entries_std, [document["tensor_std"][n] for n in names])
    assert result.tensor.shape == result.tensor_std.shape == (3, 3)
    np.testing.assert_array_equal(result.tensor, result.tensor.T)
    np.testing.assert_array_equal(np.diag(result.tensor), result.entries[:3])
    assert result.tensor[0, 1] == result.entries[3] and result.tensor[1, 2] == result.entries[4]
    assert result.tensor_std[0, 2] == result.entries_std[5]
    np.testing.assert_allclose(np.diag(result.entries_cov), result.entries_std**2)
    np.testing.assert_array_equal(result.covariance[:6, :6], result.entries_cov)
    assert result.covariance.shape == (8, 8)
    np.testing.assert_allclose(result.principal_moments, document["principal_moments"])
    np.testing.assert_allclose(result.principal_axes, document["principal_axes"])
    # The principal axes diagonalise the tensor.
    axes = result.principal_axes
    diagonal = axes @ result.tensor @ axes.T
    np.testing.assert_allclose(diagonal, np.diag(result.principal_moments), atol=1e-12)
    assert result.com.shape == result.com_std.shape == (2,)
    assert result.com[0] == document["com"]["x"] and result.com_std[1] == document["com_std"]["y"]
    assert [a.J for a in result.axes] == [a["J"] for a in document["axes"]]
    assert result.warnings == tuple(document["warnings"])
    assert result.condition_number == document["condition_number"]
    assert result.path == root / "result.json" and result.experiment == root
    assert result.truth is None
    # The true body of plant/defaults/virtual.toml, within 5 stds.
    truth = np.array([0.025, 0.028, 0.022, 0.0012, -0.0009, 0.0015])
    assert np.all(np.abs(result.entries - truth) < 5 * result.entries_std)
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.tensor = None


def test_identify_figures_where_their_inputs_are(identified, tmp_path):
    """A virtual experiment without programs (ideal reverse): the design, the motions and the
    error chart; without virtual.toml (a real rig's folder), only what needs no truth."""
    root, result, _ = identified
    paths = result.figures(tmp_path / "virtual")
    assert [p.name for p in paths] == [
        "design.png", "motion_stage1.png", "motion_stage2.png", "errors.png"
    ]
    assert all(p.stat().st_size > 10_000 for p in paths)
    rig = tmp_path / "rig"
    shutil.copytree(root, rig)
    (rig / "virtual.toml").unlink()
    rig_result = dataclasses.replace(result, experiment=rig)
    assert [p.name for p in rig_result.figures()] == [
        "design.png", "motion_stage1.png", "motion_stage2.png"
    ]
    assert (rig / "design.png").is_file()


# --- simulate, program, check ---------------------------------------------------------------


def test_simulate_and_program_print_what_the_command_line_does(tmp_path, capsys):
    root = short_experiment(tmp_path / "exp", logs=False)
    lines: list[str] = []
    passes = rsp_inertia.simulate(root, stage=1, progress=lines.append)
    assert len(passes) == 1 and passes[0].part == "braking" and passes[0].stage == 1
    assert str(passes) == "\n".join(lines)
    status, out, _ = cli(capsys, "simulate", root, "--stage", 1)
    assert status == 0 and out == str(passes) + "\n"
    document = json.loads(passes.to_json())
    assert document["passes"][0]["path"] == str(root / "stage1" / "braking.csv")
    assert document["passes"][0]["rows"] == passes[0].rows
    assert document["passes"][0]["duration"] == pytest.approx(passes[0].duration)

    lines.clear()
    programs = rsp_inertia.program(root, stage=1, progress=lines.append)
    assert [(run.stage, run.direction) for run in programs] == [(1, "forward")]
    assert str(programs) == "\n".join(lines)
    status, out, _ = cli(capsys, "program", root, "--stage", 1)
    assert status == 0
    assert WALL_TIME.sub("; - s -> ", out) == WALL_TIME.sub("; - s -> ", str(programs)) + "\n"
    document = json.loads(programs.to_json())["programs"][0]
    rows = len((root / "stage1" / "program.csv").read_text().splitlines()) - 1
    assert document["rows"] == rows == len(programs[0].details.program.t)
    assert document["path"] == str(root / "stage1" / "program.csv")
    assert 0 < document["peak_torque"] <= load_device(root / "device.toml").motor.torque_limit

    reverse = rsp_inertia.simulate(root, 1, "reverse", ideal=True)
    assert [p.part for p in reverse] == ["ideal reverse"]


def test_check_prints_what_the_command_line_does(tmp_path, capsys):
    root = rsp_inertia.create_experiment(tmp_path / "exp")
    result = rsp_inertia.check(root)
    assert not result.ready
    assert ("missing" in {level for level, _ in result.findings})
    status, out, _ = cli(capsys, "check", root)
    assert status == 1 and out == str(result) + "\n"
    document = json.loads(result.to_json())
    assert document["ready"] is False
    assert len(document["findings"]) == len(result.findings) == len(out.splitlines()) - 1


# --- plan and calibrate ---------------------------------------------------------------------


def test_plan_prints_and_writes_what_the_command_line_does(tmp_path, capsys):
    root = rsp_inertia.create_experiment(tmp_path / "exp")
    with open(root / "device.toml", "a") as f:
        f.write(PLAN_TABLE)
    before = (root / "device.toml").read_text()
    lines: list[str] = []
    result = rsp_inertia.plan(root, 40, rehearse=False, progress=lines.append)
    planned = (root / "device.toml").read_text()
    device = load_device(root / "device.toml")
    assert result.launch_speed == tuple(st.launch_speed for st in device.stages)
    assert result.braking_torque == tuple(st.braking_torque for st in device.stages)
    assert result.release_angle_deg == tuple(st.release_angle_deg for st in device.stages)
    assert result.previous == ((12.0, 0.005, None), (3.5, 0.12, None))
    assert not result.rehearsed and result.max_duration == 40.0 and result.duration <= 40.0
    assert result.predicted_std.shape == (6,) and list(result.axis_stage) == [1, 1, 1, 2, 2, 2]
    assert result.path == root / "device.toml" and result.figure == root / "plan.png"

    (root / "device.toml").write_text(before)  # the command line plans from the same inputs
    status, out, _ = cli(capsys, "plan", root, "--max-duration", 40, "--no-rehearsal")
    assert status == 0
    assert out == "\n".join(lines + [str(result)]) + "\n"
    assert (root / "device.toml").read_text() == planned

    document = json.loads(result.to_json())
    assert [s["launch_speed"] for s in document["stages"]] == list(result.launch_speed)
    assert document["stages"][0]["previous"]["launch_speed"] == 12.0
    assert document["predicted_std"] == list(result.predicted_std)
    figures = result.figures(tmp_path / "figures")
    assert figures == [tmp_path / "figures" / "plan.png"] and figures[0].stat().st_size > 10_000


def _fixture_folder(root: Path, body: bool) -> Path:
    """A short experiment on a rig with a mounting plate; without ``body``, the empty fixture
    (device.toml and virtual.toml without [body], a lighter stage-2 braking)."""
    root = short_experiment(root, logs=False)
    device = re.sub(r"tare_inertia_std = .*\n", "", (root / "device.toml").read_text())
    device = re.sub(r"\[pendulum\].*", "", device, flags=re.DOTALL)
    virtual = (root / "virtual.toml").read_text()
    if not body:
        device = re.sub(r"\[body\]\nmass = 2.0 .*\n", "", device)
        device = device.replace("launch_speed = 10.3 ", "launch_speed = 12.0 ")
        device = device.replace("braking_torque = 0.0652", "braking_torque = 0.005 ")
        device = device.replace("launch_speed = 4.26", "launch_speed = 3.5 ")
        device = device.replace("braking_torque = 0.362", "braking_torque = 0.03 ")
        virtual = re.sub(r"\[body\].*?\n\n", "", virtual, flags=re.DOTALL)
    (root / "device.toml").write_text(device)
    (root / "virtual.toml").write_text(virtual + FIXTURE)
    rsp_inertia.simulate(root, part="braking")
    rsp_inertia.simulate(root, part="reverse", ideal=True)
    return root


def test_calibrate_prints_and_writes_what_the_command_line_does(tmp_path, capsys):
    root = _fixture_folder(tmp_path / "exp", body=True)
    empty = _fixture_folder(tmp_path / "empty", body=False)
    lines: list[str] = []
    result = rsp_inertia.calibrate(root, empty, progress=lines.append)
    text = (root / "calibration.toml").read_text()
    document = tomllib.loads(text)
    # No reference: the drive taken as exact (both gains 1, std 0), no encoder terms.
    np.testing.assert_array_equal(result.drive_gains, [1.0, 1.0])
    np.testing.assert_array_equal(result.drive_gains_std, [0.0, 0.0])
    assert result.round_trip_efficiency == 1.0 and not result.reference
    assert result.encoder_error.size == result.encoder_error_std.size == 0
    assert result.empty_inertia.shape == result.empty_inertia_std.shape == (2, 5)
    np.testing.assert_array_equal(result.empty_inertia[1], document["stage"][1]["empty_inertia"])
    np.testing.assert_array_equal(result.fixture_gravity, document["fixture"]["gravity"])
    # The plate's m g x_c: 0.8 kg x 9.80665 m/s^2 x 1 mm.
    assert result.fixture_gravity[0] == pytest.approx(0.8 * 9.80665e-3, rel=1e-3)
    assert result.stiffness is None and result.path == root / "calibration.toml"
    # The day of the calibration in UTC: SOURCE_DATE_EPOCH (tests/conftest.py) is
    # 1795000000 s = 2026-11-18 11:06:40 UTC.
    assert document["calibration"]["date"] == "2026-11-18"
    json_document = json.loads(result.to_json())
    assert json_document.pop("warnings") == list(result.warnings)
    assert json_document == document

    (root / "calibration.toml").unlink()
    status, out, _ = cli(capsys, "calibrate", root, "--empty", empty)
    assert status == 0
    assert out == "\n".join(lines + [str(result)]) + "\n"
    assert (root / "calibration.toml").read_text() == text


# --- errors ---------------------------------------------------------------------------------


def _error_cases(root: Path, missing: Path):
    """(API call, command line) pairs that both refuse the input."""
    api = rsp_inertia
    return [
        (lambda: api.identify(missing), ["identify", missing]),
        (lambda: api.identify(root), ["identify", root]),
        (lambda: api.check(missing), ["check", missing]),
        (lambda: api.write_report(root), ["report", root]),
        (lambda: api.simulate(root, ideal=True), ["simulate", root, "--ideal"]),
        (
            lambda: api.simulate(root, direction="backward"),
            ["simulate", root, "--direction", "backward"],
        ),
        (
            lambda: api.simulate(root, 1, "reverse", ideal=True),
            ["simulate", root, "--stage", 1, "--part", "reverse", "--ideal"],
        ),
        (lambda: api.program(root, stage=3), ["program", root, "--stage", 3]),
        (lambda: api.program(root), ["program", root]),
        (lambda: api.plan(root), ["plan", root]),
        (lambda: api.plan(root, max_duration=0), ["plan", root, "--max-duration", 0]),
        (lambda: api.calibrate(root, missing), ["calibrate", root, "--empty", missing]),
    ]


def test_input_errors_carry_the_command_lines_message(tmp_path, capsys):
    root = rsp_inertia.create_experiment(tmp_path / "exp")
    for call, argv in _error_cases(root, tmp_path / "missing"):
        with pytest.raises(rsp_inertia.InputError) as raised:
            call()
        message = str(raised.value)
        status, out, err = cli(capsys, *argv)
        assert status == 2 and out == "", argv
        assert err == f"rsp-inertia: error: {message}\n", argv
        assert "\n" not in message


# --- demo -----------------------------------------------------------------------------------


@pytest.mark.slow
def test_demo_returns_the_calibrated_result_against_the_truth(tmp_path):
    """The whole demo (about 3 min): its result is the printed table against the truth."""
    lines: list[str] = []
    result = rsp_inertia.demo(tmp_path / "demo", progress=lines.append)
    assert result.truth is not None and result.truth.shape == (6,)
    table, written = str(result).split("\nresult -> ")
    assert "truth" in table.splitlines()[0]
    assert table in "\n".join(lines)
    # The identification's lines, then the second mounting's and the combination's.
    assert f"result -> {written}" in lines
    assert lines[-1] == f"body -> {tmp_path / 'demo' / 'body' / 'body.json'}"
    assert result.to_json() == (tmp_path / "demo" / "result.json").read_text()
    assert np.all(np.abs(result.entries - result.truth) < 5 * result.entries_std)
