"""The report as a test report (ISO/IEC 17025 section 7.8): its identification, record,
decision and signature block; the combined body's report (``report OUT`` on a combine
folder); the print: rendered in a real headless Chromium to PDF on A4 and Letter, its first
page holding the verdicts and the result, every page numbered, no heading left at a page's
foot."""

from __future__ import annotations

import hashlib
import html
import json
import re
import shutil

import numpy as np
import pytest

from rsp_inertia.cli import main
from rsp_inertia.identifying import identify
from rsp_inertia.pdf import BROWSERS
from rsp_inertia.provenance import sealed_json
from rsp_inertia.report_parts import VALUE, WARNINGS_SHOWN
from tests.conftest import copy_experiment
from tests.test_combine_cli import TURNED_X90, _mounting
from tests.test_docs import FILES, _section, _table_rows, _text

BROWSER = next((b for b in map(shutil.which, BROWSERS) if b), None)
needs_browser = pytest.mark.skipif(
    BROWSER is None,
    reason=f"no headless browser on the PATH ({', '.join(BROWSERS)}): apt-get install chromium",
)

PAPER_POINTS = {"a4": (595.3, 841.9), "letter": (612.0, 792.0)}
"""Each paper's width and height in PDF points (1/72 in)."""

RECORD = {
    "operator": "A. Keller", "part_id": "PN-4711", "serial": "SN-0042", "notes": None,
    "environment": {"temperature_C": 21.3, "pressure_hPa": 1012.0, "humidity_percent": None},
    "asset_id": "RIG-07",
    "calibration": {"date": "2026-10-01", "due": "2026-11-01", "interval_days": 31,
                    "overdue": True},
    "reference_certificate": {"id": "CERT-123", "issuer": "a national lab", "date": "2026-01-15"},
}
"""A record as the records engineer's result.json holds it (the shared schema)."""


@pytest.fixture(scope="module")
def identified(tmp_path_factory, default_logs):
    """The default experiment, ideal reverse, identified."""
    root = copy_experiment(default_logs, tmp_path_factory.mktemp("print") / "exp")
    identify(root)
    return root


@pytest.fixture
def signed(identified, tmp_path):
    """A copy whose result.json carries a record, a failed decision and eleven warnings (the
    issue's case: a long verdict must not push the result off the first page), beside the
    expanded uncertainty identify states."""
    root = tmp_path / "signed"
    shutil.copytree(identified, root)
    path = root / "result.json"
    result = json.loads(path.read_text())
    result["record"] = RECORD
    jx = result["tensor"]["Jx"]
    result["decision"] = {
        "rule": "guarded",
        "quantities": {"Jx": "pass", "Jy": "fail", "x": "indeterminate"},
        "limits": {"Jx": [jx * 0.99, jx * 1.01], "Jy": [0.0, 0.02], "x": [0.0, 0.003]},
        "part": "fail",
    }
    result["warnings"] = [f"warning number {i}: " + "a model test failed; " * 6
                          for i in range(1, 12)]
    # sealed again, as identify writes it (an unsealed edit turns the verdict red)
    path.write_text(sealed_json(result))
    return root


def _verdict(page: str) -> tuple[str, str]:
    match = re.search(r"<div class='verdict (\w+)'>(.*?)</div>", page, re.DOTALL)
    assert match, "no verdict box"
    return match.group(1), match.group(2)


def test_the_report_identifies_itself_as_a_test_report(identified):
    assert main(["report", str(identified)]) == 0
    page = (identified / "report.html").read_text()
    digest = hashlib.sha256((identified / "result.json").read_bytes()).hexdigest()
    number = f"RSP-{digest[:12]}"
    assert page.count(number) >= 2  # in the identification and every printed page's footer
    for label in ("report number", "date of issue", "item tested", "laboratory and rig",
                  "method", "date of the measurement"):
        assert f"<td class='k'>{label}</td>" in page
    assert "The results relate only to the item tested" in page
    assert "<h1>Test report: inertia tensor of" in page
    assert "counter(page)" in page and "counter(pages)" in page
    # No record.toml, no calibration: every field of the record says so, nothing is made up.
    assert page.count("not recorded") >= 11
    assert "Decision: none" in page and "No specification (EXP/spec.toml)" in page
    # The signature block: three roles, blank names, dates and signatures.
    block = page[page.index("<div class='signatures'>"):]
    for role in ("prepared by", "checked by", "approved by"):
        assert f"<tr><th>{role}</th><td></td><td></td><td></td></tr>" in block


def test_record_decision_and_expanded_uncertainty_are_shown(signed):
    assert main(["report", str(signed)]) == 0
    page = (signed / "report.html").read_text()
    result = json.loads((signed / "result.json").read_text())
    for text in ("A. Keller", "PN-4711", "SN-0042", "RIG-07", "2026-10-01",
                 "2026-11-01 (overdue)", "CERT-123", "21.3 \u00b0C", "1012 hPa"):
        assert html.escape(text) in page, text
    assert "<tr><th>prepared by</th><td>A. Keller</td>" in page
    # The part's verdict beside the software's: both before any number.
    decision = page.index("<h2>Part: FAIL</h2>")
    assert page.index("class='verdict") < decision < page.index("Inertia tensor")
    assert "<td>Jy</td><td></td><td></td><td>[0, 0.02]</td><td>FAIL</td>" in page
    assert "guarded acceptance" in page
    # U beside std: the entry's row gives U = 2 std and the interval y +- U, as the result
    # states them.
    jx, std = result["tensor"]["Jx"], result["tensor_std"]["Jx"]
    U = result["expanded_uncertainty"]["tensor"]["Jx"]
    assert U == 2 * std
    row = (f"<td>Jx</td><td>{jx:{VALUE}}</td><td>{std:.2g}</td><td>{U:.2g}</td>"
           f"<td>{std / jx:.1e}</td><td>[{jx - U:{VALUE}}, {jx + U:{VALUE}}]</td>")
    assert row in page
    assert "U (k = 2)" in page and "95.45 %" in page
    # Eleven warnings: the box lists the first ones, the section after the result all.
    level, box = _verdict(page)
    assert level == "warn" and "11 warnings" in box
    assert box.count("<li>") == WARNINGS_SHOWN + 1 and "8 more" in box
    listed = page[page.index("<h2>Warnings</h2>"):]
    assert all(f"warning number {i}:" in listed for i in range(1, 12))


@pytest.fixture
def combined(tmp_path):
    """A combine folder of two hand-made mountings (tests/test_combine_cli.py's body)."""
    first = _mounting(tmp_path / "a", np.eye(3))
    second = _mounting(tmp_path / "b", TURNED_X90)
    out = tmp_path / "body"
    assert main(["combine", str(first), str(second), "--out", str(out)]) == 0
    return out


def test_report_on_a_combine_folder_reports_the_body(combined, capsys):
    capsys.readouterr()
    assert main(["report", str(combined)]) == 0
    assert capsys.readouterr().out.strip() == f"report -> {combined / 'report.html'}"
    page = (combined / "report.html").read_text()
    body = json.loads((combined / "body.json").read_text())
    for key, value in body["tensor"].items():
        std = body["tensor_std"][key]
        assert f"<td>{key}</td><td>{value:{VALUE}}</td><td>{std:.2g}</td>" in page
    for axis in "xyz":  # z_c included
        value, std = body["com"][axis] * 1e3, body["com_std"][axis] * 1e3
        assert f"<td>{axis}_c</td><td>{value:.5f}</td><td>{std:.2g}</td>" in page
    consistency = body["consistency"]
    assert f"chi^2 = {consistency['chi2']:.4g} on {consistency['dof']} dof" in page
    # Each mounting: its rotation as its device.toml states it, its residuals.
    assert "<td>[1, 0, 0]; [0, 0, -1]; [0, 1, 0]</td>" in page
    for mounting in body["mountings"]:
        assert f"<td>{html.escape(mounting['name'])}</td>" in page
    # Provenance: each result.json combine read, with its sha256, as read.
    for name in ("../a/result.json", "../b/result.json"):
        digest = hashlib.sha256((combined / name).read_bytes()).hexdigest()
        assert body["provenance"]["inputs"][name] == digest
        assert f"<td>{name}</td><td>{digest}</td><td>as read</td>" in page
    digest = hashlib.sha256((combined / "body.json").read_bytes()).hexdigest()
    assert f"RSP-BODY-{digest[:12]}" in page
    # The hand-made results record no inputs: combine warned, the verdict says so.
    level, box = _verdict(page)
    assert level == "warn" and "records no inputs" in box
    assert "<div class='signatures'>" in page


def test_a_result_changed_since_combine_turns_the_body_verdict_red(combined):
    path = combined / ".." / "b" / "result.json"
    path.write_text(path.read_text() + " ")
    assert main(["report", str(combined)]) == 0
    level, box = _verdict((combined / "report.html").read_text())
    assert level == "stale" and "../b/result.json: changed since combine" in box

    body = json.loads((combined / "body.json").read_text())
    del body["provenance"]
    (combined / "body.json").write_text(json.dumps(body))
    assert main(["report", str(combined)]) == 0
    level, box = _verdict((combined / "report.html").read_text())
    assert level == "stale" and "records no provenance" in box


def test_a_combine_folder_without_body_json_is_one_line(tmp_path, capsys):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "body.json").write_text('{"tensor": {}}')
    assert main(["report", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "not a body.json written by combine" in err


def test_no_browser_is_one_line_and_nothing_written(identified, tmp_path, monkeypatch, capsys):
    root = tmp_path / "exp"
    shutil.copytree(identified, root)
    (root / "report.html").unlink(missing_ok=True)
    monkeypatch.setattr("rsp_inertia.pdf.shutil.which", lambda name: None)
    capsys.readouterr()
    assert main(["report", str(root), "--pdf"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "apt-get install chromium" in err
    assert not (root / "report.html").exists() and not (root / "report.pdf").exists()


def _headings(page: str) -> list[str]:
    return [html.unescape(re.sub(r"<[^>]+>", "", h))
            for h in re.findall(r"<h[23]>(.*?)</h[23]>", page)]


def _pages(path) -> list[str]:
    pypdf = pytest.importorskip("pypdf", reason="pypdf reads the printed PDF (test extra)")
    return [p.extract_text() for p in pypdf.PdfReader(path).pages], pypdf.PdfReader(path)


@needs_browser
@pytest.mark.parametrize("paper", ["a4", "letter"])
def test_the_print_keeps_verdicts_and_result_on_page_one(signed, paper, capsys):
    capsys.readouterr()
    assert main(["report", str(signed), "--pdf", "--paper", paper]) == 0
    assert capsys.readouterr().out.strip().endswith(f"pdf -> {signed / 'report.pdf'}")
    texts, reader = _pages(signed / "report.pdf")
    width, height = PAPER_POINTS[paper]
    box = reader.pages[0].mediabox
    assert float(box.width) == pytest.approx(width, abs=1) and float(box.height) == pytest.approx(
        height, abs=1)
    # 12 pages before issue 36 (a figure a page, headings orphaned); the figures now go two
    # to a row. Eleven warnings, a record and a decision included, it fits in 6.
    assert len(texts) <= 6, len(texts)
    for k, text in enumerate(texts, 1):
        assert f"page {k} of {len(texts)}" in text
    first = texts[0]
    result = json.loads((signed / "result.json").read_text())
    for needle in ("Verdict: read the warnings", "Part: FAIL", "Principal moments",
                   "Centre of mass", *(f"{v:{VALUE}}" for v in result["tensor"].values()),
                   f"{result['com']['x'] * 1e3:.5f}", f"{result['com']['y'] * 1e3:.5f}"):
        assert needle in first, needle
    # No heading is the last line of a page: each stays with what it heads.
    headings = set(_headings((signed / "report.html").read_text()))
    for k, text in enumerate(texts, 1):
        lines = [line.strip() for line in text.splitlines() if line.strip()]
        assert lines[-1] not in headings, (k, lines[-1])


@needs_browser
def test_the_body_report_prints_with_z_c_on_page_one(combined):
    assert main(["report", str(combined), "--pdf"]) == 0
    texts, _ = _pages(combined / "report.pdf")
    body = json.loads((combined / "body.json").read_text())
    assert "Verdict:" in texts[0] and "Decision: none" in texts[0]
    assert "z_c" in texts[0] and f"{body['com']['z'] * 1e3:.5f}" in texts[0]
    assert f"page {len(texts)} of {len(texts)}" in texts[-1]


def test_every_report_section_is_documented(signed, combined):
    # docs/files.md's report section names each heading of both reports (<...>: a part that
    # varies, such as the verdict's level).
    section = _section(_text(FILES), "report.html")
    documented = [re.sub(r"`", "", row[0]) for row in _table_rows(section)]
    patterns = [re.compile(re.sub(r"<[^>]*>", ".*", re.escape(d)) + "$") for d in documented]
    assert main(["report", str(signed)]) == 0
    assert main(["report", str(combined)]) == 0
    for page in ((signed / "report.html").read_text(), (combined / "report.html").read_text()):
        for heading in _headings(page):
            assert any(p.match(heading) for p in patterns), heading
