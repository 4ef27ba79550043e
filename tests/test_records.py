"""The lab's records and decisions (issue 36, items 3, 4 and 8): record.toml, device.toml's
asset id and calibration interval and calibration.toml's date in result.json's ``record``; a
calibration used after its due date warns and turns the report amber; spec.toml's limits
decided by the simple or the guarded rule (ILAC-G8) in result.json's ``decision`` and beside
the report's verdict; ``--strict`` exits 3 on a result that is not clean, whose warnings go to
stderr and the result to stdout.

The experiments are the session's default logs (tests/conftest.py), identified in about 2 s;
every limit of a spec is placed from the identified value and its U, so that each verdict is
known by construction.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import tomlkit

import rsp_inertia
from rsp_inertia.cli import STRICT, main
from rsp_inertia.estimation import reading
from rsp_inertia.estimation.calibration import Calibration
from rsp_inertia.estimation.calibration_file import read_calibration_file
from rsp_inertia.estimation.coverage import expanded_uncertainty
from rsp_inertia.estimation.decision import (
    FAIL,
    INDETERMINATE,
    PASS,
    decide_quantity,
    expanded_for_decision,
    part_verdict,
)
from rsp_inertia.estimation.known_terms import KnownTerms
from rsp_inertia.estimation.records import calibration_due, reference_certificate
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import file_sha256
from rsp_inertia.infra.toml_schema import REQUIRED, accepted_keys, is_table, layout
from rsp_inertia.plant.config import Certificate, load_device
from rsp_inertia.plant.geometry import ENTRY_KEYS
from rsp_inertia.plant.record_config import RecordFile, Rule, SpecFile, load_record, load_spec
from rsp_inertia.provenance import sealed_json
from rsp_inertia.report_parts import decision_box
from tests.conftest import copy_experiment
from tests.test_combine_cli import TURNED_X90, _mounting
from tests.test_docs import FILES, _documented, _examples, _section, _text

MADE = "2026-11-18"
"""The day every result of the tests is made: SOURCE_DATE_EPOCH = 1795000000 s
(tests/conftest.py) is 2026-11-18 11:06:40 UTC."""

RECORD = """\
[record]
operator = "A. Smith"
part_id = "DWG-1234 rev. B"
serial = "SN 0815"
notes = "cover removed"

[environment]
temperature_C = 21.4
pressure_hPa = 1013.2
humidity_percent = 45.0
"""


def cli(capsys, *argv) -> tuple[int, str, str]:
    """Run ``rsp-inertia *argv``: (exit status, stdout, stderr)."""
    capsys.readouterr()
    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def _exact_calibration(root: Path, date: str | None) -> None:
    """A calibration.toml of ``root``'s own device that holds its tares exactly (what the
    virtual rig has), made on ``date``: identify applies it without changing the result."""
    device = load_device(root / "device.toml")
    calibration = Calibration(
        device_name=device.name,
        counts_per_rev=device.encoder.counts_per_rev,
        gear_ratios=tuple(stage.gear_ratio for stage in device.stages),
        nodes_deg=tuple(tuple(stage.nodes_deg) for stage in device.stages),
        known=KnownTerms.from_tares([stage.tare_inertia for stage in device.stages]),
        reference=False,
        date=date,
    )
    (root / "calibration.toml").write_text(calibration.to_toml())


def _device_keys(root: Path, lines: str) -> None:
    """``lines`` added to device.toml's [device] table."""
    path = root / "device.toml"
    text = path.read_text()
    assert text.startswith("# ") and "\n[device]\n" in text
    path.write_text(text.replace("\n[device]\n", f"\n[device]\n{lines}", 1))


def _result(root: Path) -> dict:
    return json.loads((root / "result.json").read_text())


@pytest.fixture(scope="module")
def plain(tmp_path_factory, default_logs) -> tuple[Path, dict]:
    """The default experiment identified as it is (no record, no spec, no calibration: no
    warnings), and its result.json."""
    root = copy_experiment(default_logs, tmp_path_factory.mktemp("records") / "plain")
    assert main(["identify", str(root)]) == 0
    return root, _result(root)


# --- record.toml ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "needles"),
    [
        ('[record]\noperater = "A"\n', ("record.operater", "unknown key")),
        ("[record]\noperator = 5\n", ("record.operator", "must be a string")),
        ('[environmnet]\ntemperature_C = 20.0\n', ("environmnet", "unknown table")),
        ("[environment]\ntemperature_C = 293.15\n", ("environment.temperature_C", "<= 60")),
        ("[environment]\npressure_hPa = 101.3\n", ("environment.pressure_hPa", ">= 500")),
        ("[environment]\nhumidity_percent = 120\n", ("environment.humidity_percent", "<= 100")),
        ('[environment]\nhumidity_percent = "45 %"\n', ("humidity_percent", "must be a number")),
        ("[record\n", ("invalid TOML",)),
    ],
    ids=["unknown key", "type", "unknown table", "kelvin", "kPa", "humidity", "text", "toml"],
)
def test_a_bad_record_is_one_line_before_the_work_and_nothing_is_written(
    default_logs, tmp_path, capsys, monkeypatch, text, needles
):
    root = copy_experiment(default_logs, tmp_path / "exp")
    (root / "record.toml").write_text(text)

    def no_work(*args, **kwargs):
        raise AssertionError("identify computed before refusing record.toml")

    monkeypatch.setattr(reading, "identify_logs", no_work)
    status, out, err = cli(capsys, "identify", root)
    assert status == 2 and out == ""
    assert len(err.strip().splitlines()) == 1
    assert err.startswith(f"rsp-inertia: error: {root / 'record.toml'}: ")
    for needle in needles:
        assert needle in err, err
    assert not (root / "result.json").exists()


def test_the_record_goes_into_result_json_and_an_overdue_calibration_warns(
    default_logs, plain, tmp_path, capsys
):
    root = copy_experiment(default_logs, tmp_path / "exp")
    (root / "record.toml").write_text(RECORD)
    _device_keys(root, 'asset_id = "RIG-0042"\ncalibration_interval_days = 180\n')
    # 2026-05-20 + 180 days = 2026-11-16, two days before the result is made.
    _exact_calibration(root, "2026-05-20")
    status, out, err = cli(capsys, "identify", root)
    assert status == 0  # without --strict a warning does not change the exit status
    result = _result(root)
    record = result["record"]
    assert record == {
        "operator": "A. Smith",
        "part_id": "DWG-1234 rev. B",
        "serial": "SN 0815",
        "notes": "cover removed",
        "environment": {"temperature_C": 21.4, "pressure_hPa": 1013.2, "humidity_percent": 45.0},
        "asset_id": "RIG-0042",
        "calibration": {
            "date": "2026-05-20", "due": "2026-11-16", "interval_days": 180, "overdue": True
        },
        "reference_certificate": None,
    }
    assert result["provenance"]["created"].startswith(MADE)
    (warning,) = result["warnings"]
    assert "2026-11-16" in warning and "overdue" in warning and "calibration.toml" in warning
    # The warning on stderr, the result table on stdout.
    assert err.splitlines() == [f"warning: {warning}"]
    assert "warning" not in out and out.rstrip().endswith(f"result -> {root / 'result.json'}")
    # The exact calibration holds the virtual rig's own tares: the numbers are the plain ones.
    for key in ENTRY_KEYS:
        assert result["tensor"][key] == pytest.approx(plain[1]["tensor"][key], rel=1e-9)
    assert cli(capsys, "identify", root, "--strict")[0] == STRICT
    # The API gives the same record.
    assert rsp_inertia.identify(root).record.to_dict() == record

    # The report: amber, naming the overdue calibration; --strict exits 3.
    status, out, _ = cli(capsys, "report", root, "--strict")
    assert status == STRICT and out.strip() == f"report -> {root / 'report.html'}"
    level, box = _verdict((root / "report.html").read_text())
    assert level == "warn"
    assert "The calibration was overdue" in box and "2026-11-16" in box

    # The same result with its warning deleted by hand is red: edited after it was written
    # (the verdict the report leads with, without drawing it again); sealed again, as a
    # script could, it is still amber: the record says the calibration was overdue.
    result["warnings"] = []
    (root / "result.json").write_text(json.dumps(result))
    assert rsp_inertia.api.report_verdict(root) == ("stale", None)
    (root / "result.json").write_text(sealed_json(result))
    assert rsp_inertia.api.report_verdict(root) == ("warn", None)


def test_a_calibration_within_its_interval_does_not_warn(default_logs, tmp_path, capsys):
    root = copy_experiment(default_logs, tmp_path / "exp")
    _device_keys(root, "calibration_interval_days = 180\n")
    _exact_calibration(root, "2026-05-22")  # due 2026-11-18, the day the result is made
    status, _, err = cli(capsys, "identify", root, "--strict")
    assert status == 0 and err == ""
    record = _result(root)["record"]
    assert record["calibration"] == {
        "date": "2026-05-22", "due": MADE, "interval_days": 180, "overdue": False
    }
    assert record["operator"] is None and record["asset_id"] is None
    assert record["environment"] == dict.fromkeys(
        ("temperature_C", "pressure_hPa", "humidity_percent")
    )


def test_due_dates_count_calendar_days():
    # 2024 is a leap year: 2024-02-01 + 30 days is 2024-03-02.
    due = calibration_due("2024-02-01", 30, "2024-03-02T23:59:59Z")
    assert (due.due, due.overdue) == ("2024-03-02", False)
    assert calibration_due("2024-02-01", 30, "2024-03-03").overdue
    assert calibration_due("2024-02-01", 29, "2024-03-02").overdue
    # Without a date or an interval there is no due date, and nothing is overdue.
    assert calibration_due(None, 30, "2099-01-01").to_dict() == {
        "date": None, "due": None, "interval_days": 30, "overdue": False
    }
    assert not calibration_due("2000-01-01", None, "2099-01-01").overdue


def test_the_reference_certificate_is_read_where_calibration_toml_has_one():
    certificate = Certificate(id="PTB-2026-0815", issuer="PTB", date="2026-03-01")
    assert reference_certificate(SimpleNamespace(certificate=certificate)) == {
        "id": "PTB-2026-0815", "issuer": "PTB", "date": "2026-03-01"
    }
    # Its issuer and date may be left out of reference.toml.
    assert reference_certificate(SimpleNamespace(certificate=Certificate(id="X"))) == {
        "id": "X", "issuer": None, "date": None
    }
    assert reference_certificate(SimpleNamespace(certificate=None)) is None  # no [certificate]
    assert reference_certificate(None) is None


@pytest.mark.parametrize(
    ("lines", "needles"),
    [
        ("asset_id = 42\n", ("device.asset_id", "must be a string")),
        ("calibration_interval_days = 0\n", ("device.calibration_interval_days", "> 0")),
        ("calibration_interval_days = 30.5\n", ("calibration_interval_days", "integer")),
    ],
    ids=["asset id", "interval 0", "interval not integer"],
)
def test_bad_device_record_keys_are_one_line(default_logs, tmp_path, lines, needles):
    root = copy_experiment(default_logs, tmp_path / "exp")
    _device_keys(root, lines)
    with pytest.raises(InputError) as error:
        load_device(root / "device.toml")
    message = str(error.value)
    assert "\n" not in message and message.startswith(str(root / "device.toml"))
    for needle in needles:
        assert needle in message


def test_calibration_toml_holds_the_calibration_date(tmp_path):
    root = rsp_inertia.create_experiment(tmp_path / "exp")
    _exact_calibration(root, "2026-02-28")
    path = root / "calibration.toml"
    assert read_calibration_file(path).calibration.date == "2026-02-28"
    text = path.read_text()
    for bad in ("2026-02-30", "2026-2-28", "28.02.2026"):
        path.write_text(text.replace('date = "2026-02-28"', f'date = "{bad}"'))
        with pytest.raises(InputError, match=r"calibration\.date: must be a date YYYY-MM-DD"):
            read_calibration_file(path)
    # A file of an older rsp-inertia has no date: no due date.
    path.write_text(text.replace('date = "2026-02-28"\n', ""))
    assert read_calibration_file(path).calibration.date is None


# --- spec.toml ------------------------------------------------------------------------------


LIMITS = (1.0, 2.0)
U = 0.1


@pytest.mark.parametrize(
    ("value", "simple", "guarded"),
    [
        (1.5, PASS, PASS),  # inside by 5 U
        (1.95, PASS, INDETERMINATE),  # inside by U / 2: value + U is beyond the limit
        (2.05, FAIL, INDETERMINATE),  # outside by U / 2: value - U is inside
        (2.0, PASS, INDETERMINATE),  # on the limit
        (2.15, FAIL, FAIL),  # outside by 1.5 U
        (0.95, FAIL, INDETERMINATE),
        (0.85, FAIL, FAIL),
        (1.1, PASS, PASS),  # value - U on the limit: still inside
    ],
)
def test_each_rule_decides_a_value_placed_against_its_limits(value, simple, guarded):
    assert decide_quantity(value, U, LIMITS, Rule.SIMPLE) == simple
    assert decide_quantity(value, U, LIMITS, Rule.GUARDED) == guarded


def test_the_part_fails_if_any_fails_else_is_indeterminate_if_any_is():
    assert part_verdict([PASS, PASS]) == PASS
    assert part_verdict([PASS, INDETERMINATE]) == INDETERMINATE
    assert part_verdict([INDETERMINATE, FAIL, PASS]) == FAIL


def test_the_decision_takes_the_expanded_uncertainty_the_result_states():
    """U is the result's own GUM statement: k std of the entries and the centre of mass, the
    principal moments' from their Monte Carlo intervals (estimation.coverage); a diagonal
    covariance of well separated moments keeps the truth plain (their U 2 std within the
    Monte Carlo's tolerance)."""
    entries = np.array([0.025, 0.028, 0.022, 0.0, 0.0, 0.0])
    std = np.array([1e-6, 2e-6, 3e-6, 1e-7, 1e-7, 1e-7])
    com, com_std = np.array([0.003, -0.002]), np.array([1e-6, 2e-6])
    found = SimpleNamespace(entries=entries, entries_cov=np.diag(std**2), com=com)
    found.expanded_uncertainty = expanded_uncertainty(
        entries, found.entries_cov, 3.0, com_std=com_std
    )
    values = expanded_for_decision(found)
    assert values["tensor.Jy"] == (0.028, pytest.approx(6e-6))
    assert values["com.y"] == (-0.002, pytest.approx(6e-6))
    # A diagonal tensor: the principal moments are the diagonal, ascending, with its stds.
    assert values["principal.moments[1]"] == (pytest.approx(0.022), pytest.approx(9e-6, rel=0.05))
    assert values["principal.moments[3]"] == (pytest.approx(0.028), pytest.approx(6e-6, rel=0.05))


def _values(result: dict) -> dict[str, tuple[float, float]]:
    """Each quantity of result.json with the U its GUM statement gives (result.json
    ``expanded_uncertainty``): the entries', the centre of mass's and the principal
    moments'."""
    stated = result["expanded_uncertainty"]
    out = {f"tensor.{k}": (result["tensor"][k], stated["tensor"][k]) for k in ENTRY_KEYS}
    out |= {f"com.{k}": (result["com"][k], stated["com"][k]) for k in "xy"}
    for i, (m, U) in enumerate(zip(result["principal_moments"], stated["principal_moments"]), 1):
        out[f"principal.moments[{i}]"] = (m, U)
    return out


def _spec(rule: str, limits: dict[str, tuple[float, float]]) -> str:
    """spec.toml's text for ``limits`` by dotted key."""
    tables: dict[str, list[str]] = {}
    moments = []
    for name, (low, high) in limits.items():
        if name.startswith("principal."):
            moments.append(f"[{low!r}, {high!r}]")
            continue
        table, key = name.split(".")
        tables.setdefault(table, []).append(f"{key} = [{low!r}, {high!r}]")
    text = f'[decision]\nrule = "{rule}"\n'
    for table, lines in tables.items():
        text += f"[{table}]\n" + "\n".join(lines) + "\n"
    if moments:
        text += f"[principal]\nmoments = [{', '.join(moments)}]\n"
    return text


def _placed(values: dict[str, tuple[float, float]]) -> dict[str, tuple[tuple, str, str]]:
    """Limits placed against each value by a multiple of its U: quantity -> (limits, simple
    verdict, guarded verdict), true by construction."""
    placed = {}
    for name, offset in [
        ("tensor.Jx", None),  # inside by 3 U each side
        ("tensor.Jy", 0.5),  # the high limit U / 2 above the value
        ("tensor.Jz", -0.5),  # the low limit U / 2 above the value: outside by U / 2
        ("tensor.Jxy", -2.0),  # the low limit 2 U above the value
        ("com.x", None),
        ("principal.moments[1]", None),
        ("principal.moments[2]", 0.5),
        ("principal.moments[3]", None),
    ]:
        value, u = values[name]
        assert u > 0, name
        if offset is None:
            placed[name] = ((value - 3 * u, value + 3 * u), PASS, PASS)
        elif offset > 0:
            placed[name] = ((value - 3 * u, value + offset * u), PASS, INDETERMINATE)
        elif offset > -1:
            placed[name] = ((value - offset * u, value + 3 * u), FAIL, INDETERMINATE)
        else:
            placed[name] = ((value - offset * u, value + 3 * u), FAIL, FAIL)
    return placed


@pytest.mark.parametrize("rule", ["simple", "guarded"])
def test_the_decision_against_limits_placed_by_construction(
    default_logs, plain, tmp_path, capsys, rule
):
    values = _values(plain[1])
    placed = _placed(values)
    root = copy_experiment(default_logs, tmp_path / "exp")
    (root / "spec.toml").write_text(_spec(rule, {n: p[0] for n, p in placed.items()}))
    status, out, err = cli(capsys, "identify", root, "--strict")
    result = _result(root)
    decision = result["decision"]
    verdict = 1 if rule == "simple" else 2
    assert decision["rule"] == rule
    assert decision["quantities"] == {name: p[verdict] for name, p in placed.items()}
    assert decision["part"] == FAIL  # tensor.Jxy is 2 U outside under either rule
    assert status == STRICT and err == ""  # no warning: the part's verdict alone
    assert f"part against spec.toml ({rule} rule): fail" in out
    for name, (limits, *_) in placed.items():
        assert decision["limits"][name] == pytest.approx(list(limits), rel=1e-12)
        value, u = values[name]
        # U = 2 std of result.json's own stds (principal moments: their linearised std).
        assert decision["values"][name]["value"] == pytest.approx(value, rel=1e-12)
        assert decision["values"][name]["U"] == pytest.approx(u, rel=1e-9)
    if rule == "simple":
        assert "not controlled" in decision["statement"]
    # The same numbers as without a spec: the decision changes nothing else.
    for key in ENTRY_KEYS:
        assert result["tensor"][key] == plain[1]["tensor"][key]


def test_a_part_within_its_limits_passes_and_an_indeterminate_one_is_not_strict_clean(
    default_logs, plain, tmp_path, capsys
):
    values = _values(plain[1])
    root = copy_experiment(default_logs, tmp_path / "exp")
    jx, u = values["tensor.Jx"]
    inside = {"tensor.Jx": (jx - 3 * u, jx + 3 * u)}
    (root / "spec.toml").write_text(_spec("guarded", inside))
    status, out, err = cli(capsys, "identify", root, "--strict")
    assert (status, err) == (0, "") and _result(root)["decision"]["part"] == PASS
    assert "part against spec.toml (guarded rule): pass" in out
    status, out, _ = cli(capsys, "report", root, "--strict")
    assert status == 0
    page = (root / "report.html").read_text()
    assert _verdict(page)[0] == "ok"
    level, box = _part(page)
    assert level == "ok" and "<h2>Part: PASS</h2>" in box
    assert "<td>tensor.Jx</td>" in box and "guard band" in box
    assert page.index("class='verdict ok'") < page.index("class='part verdict") < page.index(
        "Inertia tensor"
    )

    # U / 2 from the limit: the guarded rule cannot decide, and --strict does not pass it.
    (root / "spec.toml").write_text(_spec("guarded", {"tensor.Jx": (jx - 3 * u, jx + u / 2)}))
    status, out, err = cli(capsys, "identify", root, "--strict")
    assert status == STRICT and err == ""
    assert _result(root)["decision"]["part"] == INDETERMINATE
    assert rsp_inertia.api.report_verdict(root) == ("ok", INDETERMINATE)
    assert _part(decision_box(_result(root)["decision"]))[0] == "warn"  # amber
    # The simple rule passes it: the value is inside.
    (root / "spec.toml").write_text(_spec("simple", {"tensor.Jx": (jx - 3 * u, jx + u / 2)}))
    assert cli(capsys, "identify", root, "--strict")[0] == 0


@pytest.mark.parametrize(
    ("text", "needles"),
    [
        ('[decision]\nrule = "simple"\n[tensor]\nJx = [2.0, 1.0]\n', ("tensor.Jx", "low <= high")),
        ('[decision]\nrule = "lenient"\n[tensor]\nJx = [1.0, 2.0]\n', ("decision.rule", "one of")),
        ("[tensor]\nJx = [1.0, 2.0]\n", ("decision", "missing required table")),
        ('[decision]\nrule = "simple"\n[tensor]\nJx = [1.0]\n', ("tensor.Jx", "2 entries")),
        ('[decision]\nrule = "simple"\n[tensor]\nJq = [1.0, 2.0]\n', ("tensor.Jq", "unknown key")),
        ('[decision]\nrule = "simple"\n', ("no limits",)),
        (
            '[decision]\nrule = "simple"\n[principal]\nmoments = [[0.0, 1.0], [0.0, 1.0]]\n',
            ("principal.moments", "3 limits"),
        ),
        (
            '[decision]\nrule = "simple"\n[principal]\nmoments = [[0.0, 1.0, 2.0]] \n',
            ("principal.moments", "3 limits"),
        ),
        (
            '[decision]\nrule = "guarded"\n[com]\nz = [-0.01, 0.01]\n',
            ("com.z", "one mounting does not measure z_c"),
        ),
    ],
    ids=["reversed", "rule", "no rule", "one number", "unknown", "no limits", "two moments",
         "three numbers", "z_c"],
)
def test_a_bad_spec_is_one_line_before_the_work_and_nothing_is_written(
    default_logs, tmp_path, capsys, monkeypatch, text, needles
):
    root = copy_experiment(default_logs, tmp_path / "exp")
    (root / "spec.toml").write_text(text)

    def no_work(*args, **kwargs):
        raise AssertionError("identify computed before refusing spec.toml")

    monkeypatch.setattr(reading, "identify_logs", no_work)
    status, out, err = cli(capsys, "identify", root)
    assert status == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert err.startswith(f"rsp-inertia: error: {root / 'spec.toml'}: ")
    for needle in needles:
        assert needle in err, err
    assert not (root / "result.json").exists()


def test_a_com_limit_needs_the_bodys_mass(default_logs, tmp_path, capsys):
    root = copy_experiment(default_logs, tmp_path / "exp")
    text = (root / "device.toml").read_text()
    text, found = re.subn(r"\[body\]\nmass = 2\.0 .*\n", "", text)
    assert found == 1
    (root / "device.toml").write_text(text)
    (root / "spec.toml").write_text('[decision]\nrule = "simple"\n[com]\nx = [-0.01, 0.01]\n')
    status, _, err = cli(capsys, "identify", root)
    assert status == 2 and "com.x" in err and "[body] mass" in err


def test_check_reads_the_record_and_the_spec_as_identify_does(default_logs, tmp_path, capsys):
    root = copy_experiment(default_logs, tmp_path / "exp")
    (root / "record.toml").write_text(RECORD)
    (root / "spec.toml").write_text('[decision]\nrule = "simple"\n[com]\nx = [-0.01, 0.01]\n')
    _device_keys(root, "calibration_interval_days = 180\n")
    _exact_calibration(root, "2026-05-20")  # due 2026-11-16: overdue on the tests' day
    status, out, _ = cli(capsys, "check", root)
    assert status == 0
    lines = out.splitlines()
    assert f"ok: {root / 'record.toml'}: the record (part DWG-1234 rev. B)" in lines
    assert f"ok: {root / 'spec.toml'}: 1 limit(s), simple rule" in lines
    (overdue,) = [line for line in lines if "overdue" in line]
    assert overdue.startswith("suspicious: ") and "2026-11-16" in overdue
    (root / "spec.toml").write_text('[decision]\nrule = "simple"\n[com]\nz = [-0.01, 0.01]\n')
    status, out, _ = cli(capsys, "check", root)
    assert status == 1
    assert f"error: {root / 'spec.toml'}: com.z: one mounting does not measure z_c" in out


# --- --strict and the output streams ----------------------------------------------------------


def test_a_clean_identify_and_report_exit_0_under_strict(plain, capsys):
    root, result = plain
    assert result["warnings"] == [] and result["decision"] is None
    status, out, err = cli(capsys, "identify", root, "--strict")
    assert (status, err) == (0, "")
    assert out.rstrip().endswith(f"result -> {root / 'result.json'}")
    assert cli(capsys, "report", root, "--strict")[0] == 0
    page = (root / "report.html").read_text()
    assert "Decision: none" in page and "No specification (EXP/spec.toml)" in page


def test_report_strict_exits_3_on_a_red_or_amber_verdict(plain, tmp_path, capsys):
    root = copy_experiment(plain[0], tmp_path / "exp")
    document = _result(root)
    document["warnings"] = ["the model test of stage 2 failed"]
    (root / "result.json").write_text(sealed_json(document))  # as identify would write it
    assert cli(capsys, "report", root)[0] == 0  # without --strict: done
    assert cli(capsys, "report", root, "--strict")[0] == STRICT
    assert _verdict((root / "report.html").read_text())[0] == "warn"
    document["warnings"] = []
    (root / "result.json").write_text(sealed_json(document))
    log = root / "stage1" / "reverse.csv"
    log.write_text(log.read_text() + "\n")  # changed since identify: red
    assert cli(capsys, "report", root, "--strict")[0] == STRICT
    assert _verdict((root / "report.html").read_text())[0] == "stale"


def test_combine_prints_its_result_on_stdout_and_its_warnings_on_stderr(tmp_path, capsys):
    first = _mounting(tmp_path / "a", np.eye(3))
    second = _mounting(tmp_path / "b", TURNED_X90)
    out = tmp_path / "body"
    # Hand-made result.json files record no inputs: combine warns.
    status, printed, err = cli(capsys, "combine", first, second, "--out", out, "--strict")
    assert status == STRICT and (out / "body.json").is_file()
    warnings = json.loads((out / "body.json").read_text())["warnings"]
    assert warnings and err.splitlines() == [f"warning: {w}" for w in warnings]
    assert "warning" not in printed and printed.rstrip().endswith(f"body -> {out / 'body.json'}")
    assert cli(capsys, "combine", first, second, "--out", out)[0] == 0
    # With their inputs recorded (device.toml, the only input such a folder has), the exact
    # mountings agree: nothing to warn about.
    for root in (first, second):
        document = json.loads((root / "result.json").read_text())
        document["provenance"] = {"inputs": {"device.toml": file_sha256(root / "device.toml")}}
        (root / "result.json").write_text(sealed_json(document))  # as identify writes it
    status, _, err = cli(capsys, "combine", first, second, "--out", out, "--strict")
    assert (status, err) == (0, "")


def test_calibrate_prints_its_warnings_on_stderr_and_strict_exits_3(tmp_path, capsys, monkeypatch):
    """The command line's handling of a calibration's warnings (the calibration itself:
    tests/test_api.py); a stand-in for the library's result keeps it short."""
    class Found:
        warnings = ("the reference is light",)

        def __str__(self) -> str:
            return "drive: ...\ncalibration -> EXP/calibration.toml"

    monkeypatch.setattr(rsp_inertia, "calibrate", lambda *args: Found())
    status, out, err = cli(capsys, "calibrate", tmp_path, "--empty", tmp_path, "--strict")
    assert status == STRICT
    assert out == "drive: ...\ncalibration -> EXP/calibration.toml\n"
    assert err == "warning: the reference is light\n"
    assert cli(capsys, "calibrate", tmp_path, "--empty", tmp_path)[0] == 0
    Found.warnings = ()
    assert cli(capsys, "calibrate", tmp_path, "--empty", tmp_path, "--strict")[0] == 0


def test_exit_statuses_name_strict():
    from rsp_inertia.cli import EXIT_STATUSES

    assert "3 --strict" in EXIT_STATUSES
    section = _section(_text(FILES.parent / "commands.md"), "Exit statuses")
    assert re.search(r"^\| 3 \| `--strict`", section, re.MULTILINE)


# --- the report's boxes ---------------------------------------------------------------------


def _verdict(page: str) -> tuple[str, str]:
    """The software's verdict box: (level, its content)."""
    match = re.search(r"<div class='verdict (\w+)'>(.*?)</div>", page, re.DOTALL)
    assert match, "no verdict box"
    return match.group(1), match.group(2)


def _part(page: str) -> tuple[str, str]:
    """The part's verdict box: (level, its content)."""
    match = re.search(r"<div class='part verdict (\w+)'>(.*?)</div>", page, re.DOTALL)
    assert match, "no part verdict box"
    return match.group(1), match.group(2)


# --- docs/files.md --------------------------------------------------------------------------


FILE_CLASSES = {"record.toml": (RecordFile, load_record), "spec.toml": (SpecFile, load_spec)}


def _fields(cls: type) -> dict:
    """Dotted key -> the field that declares it."""
    out = {}
    for name, entry in layout(cls).items():
        assert is_table(entry.kind), name
        out |= {f"{name}.{key}": member for key, member in layout(entry.kind).items()}
    assert set(out) == {f"{t}.{k}" for t, keys in accepted_keys(cls).items() if t for k in keys}
    return out


@pytest.mark.parametrize("file", list(FILE_CLASSES))
def test_record_and_spec_keys_are_documented_with_their_units_and_defaults(file):
    cls, _ = FILE_CLASSES[file]
    fields = _fields(cls)
    documented = _documented(file)
    assert set(documented) == set(fields)
    for dotted, row in documented.items():
        member = fields[dotted]
        unit = member.meta["unit"]
        assert not unit or row[2] == unit or row[2].startswith(unit + ","), (dotted, row[2])
        assert (row[1] == "required") == (member.default is REQUIRED), dotted
        if row[1] != "required":
            assert row[1] == "not set" and member.default is None, dotted


@pytest.mark.parametrize("file", list(FILE_CLASSES))
def test_record_and_spec_examples_load_as_written(file, tmp_path):
    """The docs' example has every table, and loads to what it says."""
    cls, load = FILE_CLASSES[file]
    (example,) = _examples(file)
    assert set(example) == set(accepted_keys(cls)) - {""}
    path = tmp_path / file
    path.write_text(tomlkit.dumps(example))
    loaded = load(path)
    for table, keys in example.items():
        for key, value in keys.items():
            assert _plain(getattr(getattr(loaded, table), key)) == value, f"{table}.{key}"


def _plain(value):
    """A loaded value as tomllib gives it: tuples as lists, a rule as its text."""
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value.value if isinstance(value, Rule) else value
