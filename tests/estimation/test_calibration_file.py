"""calibration.toml (rsp_inertia.estimation.calibration_file): what calibrate writes reads back
as the same calibrated terms, byte for byte the same text twice; a file of the older format is
read with its warning; bad files are one line naming the key."""

import dataclasses
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import rsp_inertia.plant
from rsp_inertia.estimation import reading
from rsp_inertia.estimation.calibration import (
    Calibration,
    calibrated_known_terms,
    device_known_terms,
)
from rsp_inertia.estimation.calibration_file import (
    calibration_file,
    read_calibration_file,
    write_calibration_file,
)
from rsp_inertia.estimation.known_terms import KnownTerms
from rsp_inertia.estimation.layout import theta_layout
from rsp_inertia.estimation.stiffness import StiffnessCalibration
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import load_device
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.results import CalibrateResult

DEVICE = load_device(Path(rsp_inertia.plant.__file__).parent / "defaults" / "device.toml")
"""The default gimbal: two stages of three nodes."""

DIGEST = "f44d56eec0c682627bf7ecdabaa9ccce054a7c75442d00fbed1858d24b00072b"


def known_terms(orders: int, reference: bool = True, seed: int = 1) -> KnownTerms:
    """Calibrated terms of DEVICE's two stages.

    Parameters
    ----------
    orders : int
        The encoder's orders.
    reference : bool
        Whether a reference fixed the gains (without one: gains 1, exact).
    seed : int
        Of the random covariance and encoder terms.

    Returns
    -------
    KnownTerms
        The terms, with a full covariance.
    """
    rng = np.random.default_rng(seed)
    size = theta_layout(len(DEVICE.stages), orders).size
    root = rng.normal(size=(size, size)) * 1e-4
    cov = root @ root.T
    gains = (0.947, 1.087) if reference else (1.0, 1.0)
    if not reference:
        cov[:2, :] = cov[:, :2] = 0.0
    return KnownTerms(
        gains=gains,
        inertia=np.array(
            [[0.0123, 1.5e-4, 1.2e-4, 2.3e-4, -1.5e-4], [0.2076, 6.9e-3, 5.5e-3, 1.6e-3, -1e-3]]
        ),
        gravity=np.array([7.85e-3, 3.92e-3]),
        cov=cov,
        calibrated=True,
        encoder=rng.normal(size=2 * orders) * 1e-5,
        zero=rng.normal() * 1e-3 if reference else 0.0,
    )


def calibration(
    orders: int = 3, reference: bool = True, pendulum: bool = True, chi2_dof: float = 0.93
) -> Calibration:
    """What calibrate finds for DEVICE, made up.

    Parameters
    ----------
    orders : int
        The encoder's orders.
    reference : bool
        Whether a reference experiment was used.
    pendulum : bool
        Whether it has the pendulum's stiffness.
    chi2_dof : float
        The fit's chi^2 per degree of freedom.

    Returns
    -------
    Calibration
        With two inputs' digests.
    """
    return Calibration(
        device_name=DEVICE.name,
        counts_per_rev=DEVICE.encoder.counts_per_rev,
        gear_ratios=tuple(stage.gear_ratio for stage in DEVICE.stages),
        nodes_deg=tuple(tuple(stage.nodes_deg) for stage in DEVICE.stages),
        known=known_terms(orders, reference),
        reference=reference,
        inputs={
            "bench-A/calibration/empty/device.toml": DIGEST,
            "bench-A/stage1/braking.csv": DIGEST,
        },
        chi2_dof=chi2_dof,
        stiffness=StiffnessCalibration(2.0099, 3.6e-4, [(1, 0.0, 2.0, 1e-3)] * 2, math.nan, [])
        if pendulum
        else None,
    )


def assert_same_terms(got: KnownTerms, expected: KnownTerms) -> None:
    assert got.gains == expected.gains
    for name in ("inertia", "gravity", "cov", "encoder"):
        np.testing.assert_array_equal(getattr(got, name), getattr(expected, name), err_msg=name)
    assert got.calibrated


# --- round trip -----------------------------------------------------------------------------


@pytest.mark.parametrize("orders", [3, 0], ids=["encoder terms", "no encoder terms"])
@pytest.mark.parametrize("pendulum", [True, False], ids=["pendulum", "no pendulum"])
@pytest.mark.parametrize("reference", [True, False], ids=["reference", "no reference"])
def test_what_calibrate_writes_reads_back_as_the_same_terms(tmp_path, orders, pendulum, reference):
    cal = calibration(orders, reference, pendulum)
    text = cal.to_toml()
    assert text == cal.to_toml()  # deterministic
    doc = tomllib.loads(text)
    file = read_calibration_file(doc)
    assert file == cal.to_file()  # what the reader gives back is what calibrate gives
    known, warnings = calibrated_known_terms(file, DEVICE, "calibration.toml")
    assert warnings == []
    assert_same_terms(known, cal.known)
    assert file.pendulum_stiffness() == ((2.0099, 3.6e-4) if pendulum else None)
    assert (doc["encoder"]["error_cos"] == []) == (orders == 0)
    # The file written is the text, byte for byte, and so is the file written from its reading.
    write_calibration_file(tmp_path / "a.toml", cal.to_file())
    write_calibration_file(tmp_path / "b.toml", read_calibration_file(tmp_path / "a.toml"))
    assert (tmp_path / "a.toml").read_text() == (tmp_path / "b.toml").read_text() == text


def test_the_file_is_commented_with_units_and_a_nan_chi2_is_nan():
    text = calibration(chi2_dof=math.nan).to_toml()
    assert text.startswith("# calibration.toml: the rig's calibration")
    assert "\nchi2_dof = nan\n" in text
    assert "\nstiffness = 2.0099  # N m/rad\n" in text
    assert "\ngravity = [0.00785, 0.00392]  # N m\n" in text
    assert "\nmatrix = [\n    [" in text  # one row per line
    assert math.isnan(read_calibration_file(tomllib.loads(text)).calibration.chi2_dof)


def test_calibrate_results_json_is_the_files_content(tmp_path):
    """The API's result and its JSON come from the file's reader: the same numbers as the
    parsed text, NaN as null."""
    cal = calibration(chi2_dof=math.nan)
    result = CalibrateResult(cal, tmp_path / "calibration.toml")
    doc = tomllib.loads(cal.to_toml())
    document = json.loads(result.to_json())
    assert document.pop("warnings") == []
    assert document.pop("calibration")["chi2_dof"] is None
    assert document == {name: value for name, value in doc.items() if name != "calibration"}
    np.testing.assert_array_equal(result.drive_gains, cal.known.gains)
    np.testing.assert_array_equal(result.encoder_error, cal.known.encoder)
    np.testing.assert_array_equal(result.empty_inertia, cal.known.inertia)
    assert result.stiffness == 2.0099 and math.isnan(result.chi2_dof)


# --- a file of the older format -------------------------------------------------------------

LEGACY_PARAMETERS = (
    ["h"] + [f"{h}[{s}]" for s in (1, 2) for h in ("M0", "Mc2", "Ms2", "Ms1", "Mc1")] + ["Gs", "Gc"]
)


def legacy_text(cov: np.ndarray) -> str:
    """calibration.toml as the rsp-inertia before the drive's gains wrote it."""
    rows = "".join(f"  [{', '.join(repr(float(v)) for v in row)}],\n" for row in cov)
    return f"""\
# Rig calibration written by rsp-inertia calibrate; identify applies it.
# theta = [h = 1/torque_gain, empty-system harmonics per stage, fixture gravity].

[calibration]
device = "{DEVICE.name}"
counts_per_rev = 65536
reference = true
torque_gain = 1.0029991073557472                # logged torque / applied torque
torque_gain_std = 4.526341237519046e-06
chi2_dof = 0.9342499103061012

[fixture]
gravity = [0.007847004762394968, 0.003924786501820339]     # [m g x_c, m g y_c] of the fixture, N m
gravity_std = [8.181446639309537e-07, 8.191477700593479e-07]

[[stage]]
gear_ratio = 0.7639320225
nodes_deg = [0.0, 120.0, 240.0]
empty_inertia = [0.012268385390285462, 0.00014587888125843656, 0.00011670446030081572, 0.00022908249254879862, -0.0001528723170767926]   # [M0, Mc2, Ms2, Ms1, Mc1], kg m^2
empty_inertia_std = [1.6509872446573582e-07, 3.749624018558635e-08, 4.5171161859195304e-08, 4.5124144476601194e-08, 4.363126284802187e-08]

[[stage]]
gear_ratio = 5.2360679775
nodes_deg = [60.0, 180.0, 300.0]
empty_inertia = [0.2076080750046895, 0.006853784702458743, 0.005484087599426667, 0.00157034958782479, -0.0010478740460890216]   # [M0, Mc2, Ms2, Ms1, Mc1], kg m^2
empty_inertia_std = [3.5429752813006842e-06, 7.819641898908147e-07, 9.235868931946984e-07, 4.936646309729208e-07, 5.074414012661146e-07]

[pendulum]                   # the torsion element, from the pendulum runs
stiffness = 2.0099386080645836      # N m/rad
stiffness_std = 0.0003631198571374831
nodes = 6

[covariance]
parameters = [{", ".join(f'"{name}"' for name in LEGACY_PARAMETERS)}]
matrix = [
{rows}]

[inputs]                     # sha256 of every file used
"bench-A/calibration/empty/device.toml" = "{DIGEST}"
"""


def test_a_file_of_the_older_format_is_read_with_a_lossless_drive_and_a_warning(tmp_path):
    rng = np.random.default_rng(3)
    root = rng.normal(size=(13, 13)) * 1e-5
    old = root @ root.T
    path = tmp_path / "calibration.toml"
    path.write_text(legacy_text(old))
    source = "EXP/calibration.toml"
    with open(path, "rb") as file:
        doc = tomllib.load(file)
    file = read_calibration_file(doc, source)
    known, warnings = calibrated_known_terms(file, DEVICE, source)
    assert warnings == [
        (
            f"{source}: written by an older rsp-inertia, without the drive's gains by direction "
            "of power flow and the encoder's error: the drive is taken as lossless (its "
            "torque_gain for both) and the encoder as exact, and their errors are not in the "
            "stds (calibrate again)"
        )
    ]
    h = 1.0 / 1.0029991073557472
    assert known.gains == (h, h) and known.encoder.size == 0 and known.calibrated
    assert known.inertia[1, 0] == 0.2076080750046895
    assert list(known.gravity) == [0.007847004762394968, 0.003924786501820339]
    # theta = [h, ...] -> [h_d, h_b, ...]: h's row and column for both gains, fully correlated.
    expected = np.empty((14, 14))
    expected[1:, 1:] = old
    expected[0, 1:] = expected[1:, 0] = old[0]
    expected[0, 0] = old[0, 0]
    # No encoder zero in such a file: 0, exact (its row and column zero, after Gs, Gc).
    expected = np.insert(np.insert(expected, 14, 0.0, axis=0), 14, 0.0, axis=1)
    np.testing.assert_array_equal(known.cov, expected)
    assert known.zero == 0.0 and known.names()[14] == "zero"
    assert known.names()[:3] == ["h_d", "h_b", "M0[1]"]
    assert file.pendulum_stiffness() == (2.0099386080645836, 0.0003631198571374831)
    assert file.legacy and read_calibration_file(path) == file


def test_an_older_file_is_checked_as_strictly():
    text = legacy_text(np.eye(13) * 1e-10)
    bad = text.replace("torque_gain = 1.0029991073557472", "torque_gain = -1.0")
    with pytest.raises(InputError) as error:
        read_calibration_file(tomllib.loads(bad), "EXP/calibration.toml")
    assert (
        str(error.value) == "EXP/calibration.toml: calibration.torque_gain: must be > 0, got -1.0"
    )
    bad = text.replace('"h", ', '"h_d", "h_b", ')
    with pytest.raises(InputError, match="covariance.parameters: must name the 13 parameters"):
        read_calibration_file(tomllib.loads(bad))


# --- bad files ------------------------------------------------------------------------------

SMALL = calibration(orders=1).to_toml()
"""A current file to break: two stages, one encoder order, a pendulum."""


def _first_row(text: str) -> str:
    start = text.index("matrix = [\n") + len("matrix = [\n")
    return text[start : text.index("\n", start) + 1]


def _last_row_dropped(text: str) -> str:
    end = text.index("]\n\n[inputs]")
    return text[: text.rindex("    [", 0, end)] + text[end:]


def _nan_first(text: str) -> str:
    row = _first_row(text)
    return text.replace(row, "    [nan" + row[row.index(",") :], 1)


def _inputs_a_number(text: str) -> str:
    return "inputs = 3\n" + text[: text.index("\n[inputs]\n")]


def _first_row_short(text: str) -> str:
    row = _first_row(text)
    return text.replace(row, row[: row.rindex(", ")] + "],\n", 1)


def _table_dropped(name: str):
    def edit(text: str) -> str:
        start = text.index(f"[{name}]\n")
        return text[:start] + text[text.index("\n\n", start) + 2 :]

    return edit


def _replaced(old: str, new: str):
    def edit(text: str) -> str:
        assert old in text, f"test setup: {old!r} not in the example"
        return text.replace(old, new, 1)

    return edit


BAD_FILES = [
    pytest.param(
        _replaced("gain_driving = 0.947", "gain_driving = -1.0"),
        "drive.gain_driving",
        "must be > 0, got -1.0",
        id="gain <= 0",
    ),
    pytest.param(
        _replaced("gain_backdriven_std = ", "gain_backdriven_std = -"),
        "drive.gain_backdriven_std",
        "must be >= 0",
        id="negative std",
    ),
    pytest.param(
        _nan_first,
        "covariance.matrix[1][1]",
        "must be finite, got nan",
        id="NaN in the matrix",
    ),
    pytest.param(
        _replaced("error_sin = [", "error_sin = [0.0, "),
        "encoder.error_sin",
        "must have one entry per order of encoder.error_cos (1), got 2",
        id="error_sin longer than error_cos",
    ),
    pytest.param(
        _replaced("error_cos_std = [", "error_cos_std = [0.0, "),
        "encoder.error_cos_std",
        "must have one entry per order of encoder.error_cos (1), got 2",
        id="a std per order",
    ),
    pytest.param(
        _last_row_dropped,
        "covariance.matrix",
        "must have one row per parameter (17), got 16",
        id="matrix one row short",
    ),
    pytest.param(
        _first_row_short,
        "covariance.matrix[2]",
        "must have 16 entries as row 1, got 17",
        id="matrix not rectangular",
    ),
    pytest.param(
        _replaced("zero_std = ", "# zero_std = "),
        "encoder.zero_std",
        "missing: encoder.zero is given",
        id="a zero without its std",
    ),
    pytest.param(
        _replaced('"Gs", "Gc"', '"Gc", "Gs"'),
        "covariance.parameters[13]",
        "must be 'Gs', got 'Gc'",
        id="parameters out of order",
    ),
    pytest.param(
        _replaced('"c1", "s1"', '"c1", "s1", "c2"'),
        "covariance.parameters",
        "must name the 17 parameters of 2 stage(s) and 1 encoder order(s), got 18",
        id="a parameter too many",
    ),
    pytest.param(
        _replaced("empty_inertia = [0.0123, ", "empty_inertia = ["),
        "stage[1].empty_inertia",
        "must have 5 entries [M0, Mc2, Ms2, Ms1, Mc1], got 4",
        id="four harmonics",
    ),
    pytest.param(
        _replaced("nodes = 2\n", "nodes = 2\nnode = 2\n"),
        "pendulum.node",
        "unknown key",
        id="unknown key",
    ),
    pytest.param(
        _replaced("[fixture]", "[fixtures]"), "fixtures", "unknown table", id="unknown table"
    ),
    pytest.param(
        _table_dropped("drive"),
        "drive",
        "missing required table [drive]",
        id="[encoder] without [drive]",
    ),
    pytest.param(
        _table_dropped("encoder"),
        "encoder",
        "missing required table [encoder]",
        id="[drive] without [encoder]",
    ),
    pytest.param(
        _replaced("reference = true\n", "reference = true\ntorque_gain = 1.0\n"),
        "calibration.torque_gain",
        "only in older files, without [drive]",
        id="torque_gain with [drive]",
    ),
    pytest.param(
        _replaced("chi2_dof = 0.93", "chi2_dof = inf"),
        "calibration.chi2_dof",
        "must be finite, got inf",
        id="infinite chi2",
    ),
    pytest.param(
        _replaced("reference = true", 'reference = "yes"'),
        "calibration.reference",
        "must be a boolean",
        id="wrong type",
    ),
    pytest.param(
        _replaced("nodes = 2", "nodes = 2.0"),
        "pendulum.nodes",
        "must be an integer, got 2.0",
        id="non-integer nodes",
    ),
    pytest.param(
        _replaced(f'device.toml" = "{DIGEST}"', 'device.toml" = "abc"'),
        'inputs."bench-A/calibration/empty/device.toml"',
        "must be a sha256 digest (64 hex digits), got 'abc'",
        id="not a digest",
    ),
    pytest.param(
        _inputs_a_number,
        "inputs",
        "must be a table, got 3",
        id="inputs not a table",
    ),
]


@pytest.mark.parametrize("edit, key, fault", BAD_FILES)
def test_bad_calibration_is_one_line_naming_file_and_key(tmp_path, edit, key, fault):
    path = tmp_path / "calibration.toml"
    path.write_text(edit(SMALL))
    with pytest.raises(InputError) as error:
        read_calibration_file(path)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: {key}: "), message
    assert fault in message, message


def test_inputs_may_be_left_out():
    doc = tomllib.loads(SMALL[: SMALL.index("\n[inputs]\n")])
    first, second = read_calibration_file(doc), read_calibration_file(doc)
    assert first.inputs == {} and first.inputs is not second.inputs


def test_bad_toml_and_a_missing_file_are_one_line(tmp_path):
    path = tmp_path / "calibration.toml"
    with pytest.raises(InputError, match="calibration.toml: file not found$"):
        read_calibration_file(path)
    path.write_text(SMALL.replace("[drive]", "[drive"))
    with pytest.raises(InputError, match="calibration.toml: invalid TOML"):
        read_calibration_file(path)


@pytest.mark.parametrize(
    "edit, fault",
    [
        (_replaced(f'device = "{DEVICE.name}"', 'device = "bench-B"'), "made for device 'bench-B'"),
        (_replaced("counts_per_rev = 65536", "counts_per_rev = 4096"), "encoder counts_per_rev"),
        (_replaced("gear_ratio = 5.2360679775", "gear_ratio = 5.3"), "stage[2]: made for another"),
        (_replaced("[60.0, 180.0, 300.0]", "[60.0, 180.0, 301.0]"), "stage[2]: made for another"),
    ],
)
def test_a_calibration_of_another_device_is_refused(edit, fault):
    with pytest.raises(InputError, match="^EXP/calibration.toml: ") as error:
        calibrated_known_terms(
            read_calibration_file(tomllib.loads(edit(SMALL))), DEVICE, "EXP/calibration.toml"
        )
    assert fault in str(error.value)


def test_writing_what_the_reader_refuses_raises_and_writes_nothing(tmp_path):
    path = tmp_path / "calibration.toml"
    bad = dataclasses.replace(calibration(), chi2_dof=-1.0)
    with pytest.raises(ValueError, match="calibration.chi2_dof: must be >= 0, got -1.0"):
        bad.to_toml()
    with pytest.raises(ValueError, match=f"^{path}: calibration.chi2_dof: must be >= 0"):
        write_calibration_file(path, calibration_file(bad))
    assert not path.exists()


# --- read once per command ------------------------------------------------------------------


def _calibrated_experiment(root: Path, text: str | None) -> Path:
    """DEVICE's experiment folder with ``text`` as its calibration.toml (None: none) and a
    pendulum log at one node (empty: the estimators are not run)."""
    (root / "stage1").mkdir(parents=True)
    (root / "device.toml").write_text(
        (Path(rsp_inertia.plant.__file__).parent / "defaults" / "device.toml").read_text()
    )
    (root / "stage1" / "pendulum_k1.csv").write_text("")
    if text is not None:
        (root / "calibration.toml").write_text(text)
    return root


def _count_parses(monkeypatch) -> list[str]:
    """Every parse of a calibration.toml's text from now on (tomllib.load and loads), listed."""
    parses: list[str] = []
    load, loads = tomllib.load, tomllib.loads

    def counted_load(file, **kwargs):
        doc = load(file, **kwargs)
        if Path(file.name).name == "calibration.toml":
            parses.append(file.name)
        return doc

    def counted_loads(text, **kwargs):
        if text.startswith("# calibration.toml"):
            parses.append("text")
        return loads(text, **kwargs)

    monkeypatch.setattr(tomllib, "load", counted_load)
    monkeypatch.setattr(tomllib, "loads", counted_loads)
    return parses


@dataclasses.dataclass(frozen=True)
class _Identified:
    """What a stand-in estimator returns: identify_experiment sets its coverage factor and
    the tempco the logs were compensated with (none here)."""

    coverage_factor: float = 2.0
    tempco: tuple | None = None


def test_identify_reads_the_calibration_once(tmp_path, monkeypatch):
    """identify_experiment parses and validates calibration.toml once; the known terms and
    the pendulum's stiffness it hands to the estimator come from that reading."""
    root = _calibrated_experiment(tmp_path, SMALL)
    exp = open_experiment(root)
    handed = {}

    def estimator(logs, known, *, pendulum_stiffness, warnings, conventions):
        handed.update(known=known, stiffness=pendulum_stiffness, warnings=warnings,
                      conventions=conventions)
        return _Identified()

    monkeypatch.setattr(reading, "identify_logs", estimator)
    parses = _count_parses(monkeypatch)
    assert reading.identify_experiment(exp, coverage_factor=3.0) == _Identified(3.0)
    assert parses == [str(root / "calibration.toml")]
    assert_same_terms(handed["known"], calibration(orders=1).known)
    assert handed["stiffness"] == (2.0099, 3.6e-4) and handed["warnings"] == []


def test_check_reads_the_calibration_once(tmp_path, monkeypatch):
    """What check reports of calibration.toml (its terms and warnings, its stiffness) comes
    from one reading (read_calibration, then known_terms and pendulum_stiffness of it)."""
    exp = open_experiment(_calibrated_experiment(tmp_path, SMALL))
    parses = _count_parses(monkeypatch)
    calibrated = reading.read_calibration(exp)
    known, warnings = reading.known_terms(exp, calibrated)
    assert calibrated.pendulum_stiffness() == (2.0099, 3.6e-4) and warnings == []
    assert_same_terms(known, calibration(orders=1).known)
    assert len(parses) == 1


def test_without_a_calibration_the_device_states_the_terms(tmp_path):
    exp = open_experiment(_calibrated_experiment(tmp_path, None))
    assert reading.read_calibration(exp) is None
    known, warnings = reading.known_terms(exp, None)
    expected, expected_warnings = device_known_terms(DEVICE, str(exp.calibration_path))
    assert warnings == expected_warnings
    for name in ("gains", "inertia", "gravity", "cov", "encoder", "calibrated"):
        np.testing.assert_array_equal(getattr(known, name), getattr(expected, name))


def test_an_experiments_calibration_that_is_not_toml_is_one_line(tmp_path):
    exp = open_experiment(_calibrated_experiment(tmp_path, SMALL.replace("[drive]", "[drive")))
    with pytest.raises(InputError) as error:
        reading.read_calibration(exp)
    assert str(error.value).startswith(f"{exp.calibration_path}: cannot read as TOML: ")
    assert "\n" not in str(error.value)


# --- the tempco the calibration runs measured ([motor]) --------------------------------------


def test_a_measured_tempco_reads_back_and_a_kept_one_is_not_written(tmp_path):
    from rsp_inertia.estimation.tempco import TempcoFit

    cal = calibration()
    size = len(cal.known.names())
    cov = tuple(1e-12 * (k + 1) for k in range(size))
    measured = TempcoFit(stated=-0.0011, stated_std=1e-4, estimate=-0.00082, std=1.9e-5,
                         covariance=cov, reference_temperature=25.0)
    cal = dataclasses.replace(cal, tempco_fit=measured)
    text = cal.to_toml()
    file = read_calibration_file(tomllib.loads(text))
    assert file == cal.to_file()
    assert (file.motor.torque_constant_tempco, file.motor.torque_constant_tempco_std) == (
        -0.00082, 1.9e-5)
    assert file.motor.covariance == cov and file.motor.reference_temperature == 25.0
    # One of its keys per parameter of [covariance], else one line naming the key.
    path = tmp_path / "calibration.toml"
    path.write_text(text.replace("covariance = [1e-12, ", "covariance = ["))
    with pytest.raises(InputError) as error:
        read_calibration_file(path)
    assert str(error.value).startswith(f"{path}: motor.covariance: must have one entry per")
    # Runs that did not measure it (posterior variance half the prior's): no [motor].
    kept = dataclasses.replace(measured, std=1e-4 / math.sqrt(2))
    assert not kept.informed
    assert dataclasses.replace(cal, tempco_fit=kept).to_file().motor is None
