"""``rsp-inertia report``: one self-contained HTML file from an identified experiment, that
leads with its verdict and checks its inputs against what identify read."""

from __future__ import annotations

import hashlib
import html
import json
import math
import re
import shutil

import pytest

from rsp_inertia.cli import main
from rsp_inertia.identifying import identify
from rsp_inertia.provenance import created_now, sealed_json
from rsp_inertia.report import VALUE
from rsp_inertia.scenarios import create_default_experiment
from tests.conftest import copy_experiment


@pytest.fixture(scope="module")
def identified(tmp_path_factory, default_logs):
    """The default experiment, ideal reverse, identified (no calibration: it warns)."""
    root = copy_experiment(default_logs, tmp_path_factory.mktemp("report") / "exp")
    identify(root)
    return root


@pytest.fixture
def rig(identified, tmp_path):
    """A copy of the identified folder as a real rig would hold it: no virtual.toml."""
    root = tmp_path / "rig"
    shutil.copytree(identified, root)
    (root / "virtual.toml").unlink()
    return root


def _verdict(page: str) -> str:
    match = re.search(r"<div class='verdict (\w+)'>(.*?)</div>", page, re.DOTALL)
    assert match, "no verdict box"
    return match.group(1), match.group(2)


def test_report_is_self_contained_and_says_what_went_in(tmp_path, capsys, identified):
    root = create_default_experiment(tmp_path / "exp")
    assert main(["report", str(root)]) == 2  # not identified yet: one line, nothing written
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "run rsp-inertia identify" in err
    assert not (root / "report.html").exists()

    root = identified
    assert main(["report", str(root)]) == 0
    page = (root / "report.html").read_text()
    result = json.loads((root / "result.json").read_text())
    for name, value in result["tensor"].items():
        assert f"<td>{name}</td><td>{value:{VALUE}}</td>" in page
    digest = hashlib.sha256((root / "device.toml").read_bytes()).hexdigest()
    assert f"<td>device.toml</td><td>{digest}</td><td>as read</td>" in page
    assert "stage1/braking.csv" in page and "virtual.toml" not in page
    assert "<td>numpy</td>" in page and "<td>casadi</td>" in page
    assert "data:image/png;base64," in page
    # Nothing is fetched: no external source or link.
    assert not re.search(r"(src|href)=['\"]?(https?:|//)", page)


def test_result_json_records_every_input_as_identify_read_it(identified):
    result = json.loads((identified / "result.json").read_text())
    provenance = result["provenance"]
    assert provenance["command"] == "identify"
    assert provenance["software"]["rsp-inertia"]
    inputs = provenance["inputs"]
    logs = sorted(p.relative_to(identified).as_posix() for p in identified.glob("stage*/*.csv")
                  if "program" not in p.name)
    assert sorted(inputs) == sorted(["device.toml", *logs])
    for name, digest in inputs.items():
        assert hashlib.sha256((identified / name).read_bytes()).hexdigest() == digest


def test_created_is_the_clock_unless_source_date_epoch_fixes_it(monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1795000000")
    assert created_now() == "2026-11-18T11:06:40Z"
    monkeypatch.delenv("SOURCE_DATE_EPOCH")
    import datetime

    now = datetime.datetime.now(datetime.UTC)
    made = datetime.datetime.strptime(created_now(), "%Y-%m-%dT%H:%M:%SZ").replace(
        tzinfo=datetime.UTC)
    assert abs((made - now).total_seconds()) < 5


def test_the_verdict_leads_with_the_warnings(rig):
    path = rig / "result.json"
    document = json.loads(path.read_text())
    warnings = ["no calibration.toml: device.toml's tares are taken as exact <check>",
                "the model test of stage 2 failed"]
    document["warnings"] = warnings
    # result.json is an output, not a recorded input; sealed again, as identify would have
    # written these warnings (an unsealed edit turns the verdict red: tests/test_integrity.py)
    path.write_text(sealed_json(document))
    assert main(["report", str(rig)]) == 0
    page = (rig / "report.html").read_text()
    level, box = _verdict(page)
    assert level == "warn"
    assert "2 warnings" in box
    for warning in warnings:
        assert html.escape(warning) in box
    # The box comes before any number.
    assert page.index("class='verdict") < page.index("Inertia tensor")


def test_a_changed_or_late_input_turns_the_verdict_red(rig, capsys):
    log = rig / "stage1" / "reverse.csv"
    log.write_text(log.read_text() + "\n")  # a changed byte is a changed file
    (rig / "calibration.toml").write_text("# written after identify\n")
    assert main(["report", str(rig)]) == 0
    page = (rig / "report.html").read_text()
    level, box = _verdict(page)
    assert level == "stale"
    assert "stage1/reverse.csv: changed since the result was made" in box
    assert "calibration.toml: not read when the result was made" in box
    assert "stage1/braking.csv" not in box
    assert "<td>stage1/reverse.csv</td>" in page and "<td>changed</td>" in page

    log.unlink()
    (rig / "calibration.toml").unlink()
    assert main(["report", str(rig)]) == 0
    assert "stage1/reverse.csv: removed" in _verdict((rig / "report.html").read_text())[1]


def test_a_result_without_provenance_cannot_be_trusted_to_match(rig):
    path = rig / "result.json"
    document = json.loads(path.read_text())
    del document["provenance"]
    path.write_text(json.dumps(document))
    assert main(["report", str(rig)]) == 0
    level, box = _verdict((rig / "report.html").read_text())
    assert level == "stale" and "records no provenance" in box


def test_a_clean_result_says_no_warnings(identified):
    assert json.loads((identified / "result.json").read_text())["warnings"] == []
    assert main(["report", str(identified)]) == 0
    level, box = _verdict((identified / "report.html").read_text())
    assert level == "ok" and "No warnings" in box


def test_the_report_states_intervals_principal_axes_and_a_budget_total(identified):
    assert main(["report", str(identified)]) == 0
    page = (identified / "report.html").read_text()
    result = json.loads((identified / "result.json").read_text())
    Jx, std = result["tensor"]["Jx"], result["tensor_std"]["Jx"]
    # the interval y +- U of the GUM statement, U = k std (k = 2 by default)
    U = result["expanded_uncertainty"]["tensor"]["Jx"]
    assert U == 2.0 * std
    assert f"[{Jx - U:{VALUE}}, {Jx + U:{VALUE}}]" in page
    assert "U = k u</b> with k = 2" in page and "95.45 %" in page
    for moment, m_std in zip(result["principal_moments"], result["principal_moments_std"]):
        assert f"<td>{moment:{VALUE}}</td><td>{m_std:.2g}</td>" in page
    # The budget's total row: the sources' variances add up to each entry's variance.
    budget = result["least_squares"]["std_budget"]
    totals = []
    for key, value in result["tensor_std"].items():
        total = math.sqrt(sum(part["tensor_std"][key] ** 2 for part in budget.values()))
        assert total == pytest.approx(value, rel=1e-6)
        totals.append(f"<td>{total:.2g}</td>")
    assert "<tr class='total'><td>total</td>" + "".join(totals) + "</tr>" in page
    # Each axis is named by its stage and node.
    for axis in result["axes"]:
        assert f"<th>stage {axis['stage']}, node {axis['phi_deg']:g} deg</th>" in page
    assert "<th>release angle, deg</th>" in page


def test_a_rig_folder_gets_the_figures_its_logs_allow(rig):
    assert not (rig / "virtual.toml").exists()
    for png in rig.glob("*.png"):
        png.unlink()
    assert main(["report", str(rig)]) == 0
    page = (rig / "report.html").read_text()
    names = re.findall(r"<img alt='([^']+)'", page)
    assert names == ["motion_stage1.png", "motion_stage2.png", "differences.png"]


def test_a_log_broken_since_identify_still_gets_a_report_that_says_so(rig):
    log = rig / "stage2" / "braking.csv"
    log.write_text(log.read_text().replace(",", ";", 40))
    assert main(["report", str(rig)]) == 0
    page = (rig / "report.html").read_text()
    level, box = _verdict(page)
    assert level == "stale" and "stage2/braking.csv: changed" in box
    assert "The logs cannot be read now: " in page and "stage2/braking.csv" in page


@pytest.mark.parametrize("text", ["{", "[1, 2]", '{"tensor": {}}'], ids=["json", "list", "keys"])
def test_a_result_json_not_identifys_is_one_line(rig, capsys, text):
    (rig / "result.json").write_text(text)
    capsys.readouterr()
    assert main(["report", str(rig)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "not a result.json written by identify" in err


@pytest.mark.parametrize("edit", ["Jx changed", "warnings deleted"])
def test_a_result_json_edited_after_it_was_written_turns_the_verdict_red(rig, edit):
    path = rig / "result.json"
    document = json.loads(path.read_text())
    if edit == "Jx changed":
        document["tensor"]["Jx"] *= 1.0 + 1e-6
    else:
        # A result with a warning, as identify writes it, then the warning deleted by hand.
        document["warnings"] = ["the model test of stage 2 failed"]
        document = json.loads(sealed_json(document))
        document["warnings"] = []
    path.write_text(json.dumps(document, indent=2))  # integrity kept, content changed
    assert main(["report", str(rig)]) == 0
    level, box = _verdict((rig / "report.html").read_text())
    assert level == "stale" and "edited after it was written" in box
    assert main(["report", str(rig), "--strict"]) == 3  # a script sees it too


def test_a_result_json_as_written_and_one_without_integrity(rig):
    assert main(["report", str(rig)]) == 0
    assert "edited" not in _verdict((rig / "report.html").read_text())[1]
    path = rig / "result.json"
    document = json.loads(path.read_text())
    del document["integrity"]  # as an older rsp-inertia wrote it
    path.write_text(json.dumps(document))
    assert main(["report", str(rig)]) == 0
    level, box = _verdict((rig / "report.html").read_text())
    assert "records no integrity" in box and "was edited after it was written<" not in box
    assert level == "ok"  # no warnings, as before: no integrity is not an edit


def test_the_report_says_how_the_torques_scale_was_taken(identified, tmp_path):
    """A warming motor modelled (device.toml [motor] winding_time_constant): its coefficient
    and each run's drift as result.json has them; a two-level braking's second torque in the
    protocol's table; nothing of it for the plain default experiment."""
    assert main(["report", str(identified)]) == 0
    assert "Torque scale through the passes" not in (identified / "report.html").read_text()
    root = tmp_path / "warming"
    shutil.copytree(identified, root)
    device = (root / "device.toml").read_text()
    device = re.sub(
        r"^\[motor\].*$", "\\g<0>\nwinding_time_constant = 60.0\ntemperature_lag = 5.0",
        device, count=1, flags=re.MULTILINE,
    )
    assert "winding_time_constant" in device
    (root / "device.toml").write_text(device)
    identify(root)
    assert main(["report", str(root)]) == 0
    page = html.unescape((root / "report.html").read_text())
    warming = json.loads((root / "result.json").read_text())["least_squares"]["warming"]
    assert warming["fitted"]
    assert (
        f"Warming motor modelled (winding 60 s, magnets 5 s behind): c = "
        f"{warming['coefficient']:.4g} +- {warming['std']:.2g} /(N^2 m^2)" in page
    )
    for drift in warming["drift"]:
        assert f"{drift['run']} {drift['value']:+.2g} +- {drift['std']:.1g}" in page
    # The protocol as device.toml states it (read when the report is made: here changed since
    # identify, which the verdict says).
    text = (root / "device.toml").read_text()
    (root / "device.toml").write_text(
        text.replace("braking_torque = ", "braking_switch_turns = 2.0\nbraking_torque_2 = 0.1\n"
                     "braking_torque = ", 1)
    )
    assert main(["report", str(root)]) == 0
    page = html.unescape((root / "report.html").read_text())
    assert ", then 0.1 after 2 turns</td>" in page
