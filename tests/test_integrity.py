"""A result document's own hash (rsp_inertia.provenance.seal): a result.json or body.json
edited after it was written is told from one as written, and ``combine`` refuses it."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from rsp_inertia.cli import main
from rsp_inertia.provenance import (
    INTEGRITY_KEY,
    canonical_json,
    document_sha256,
    integrity_state,
    seal,
    sealed_json,
)
from tests.test_combine_cli import TURNED_X90, _mounting, one_line_error

DOCUMENT = {
    "tensor": {"Jx": 0.0250000792, "Jy": 0.1 + 0.2, "Jz": 1e-300, "Jxy": -0.0012},
    "warnings": ["no calibration.toml: device.toml's tares are taken as exact"],
    "com": None,
    "covariance": [[1.2345678901234567e-14, 0.0], [0.0, 3.0]],
    "note": "Ångström, µ",
    "n": 7,
}


def test_the_hash_is_the_sha256_of_the_sorted_compact_json_without_integrity():
    sealed = seal(DOCUMENT)
    assert list(sealed)[-1] == INTEGRITY_KEY
    # An independent writing of the recipe docs/files.md states.
    text = json.dumps(DOCUMENT, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    assert canonical_json(sealed) == text.encode()
    assert sealed[INTEGRITY_KEY]["sha256"] == hashlib.sha256(text.encode()).hexdigest()
    assert document_sha256(sealed) == document_sha256(DOCUMENT)


def test_a_sealed_file_read_back_is_as_written_whatever_its_layout():
    text = sealed_json(DOCUMENT)
    assert integrity_state(json.loads(text)) == "as written"
    # Re-indented, keys in another order: the same content.
    shuffled = dict(reversed(list(json.loads(text).items())))
    assert integrity_state(json.loads(json.dumps(shuffled))) == "as written"


@pytest.mark.parametrize(
    "edit",
    ["last digit of a float", "warning deleted", "key added", "key removed", "hash changed"],
)
def test_any_edit_is_found(edit):
    document = json.loads(sealed_json(DOCUMENT))
    if edit == "last digit of a float":
        document["tensor"]["Jx"] = np.nextafter(document["tensor"]["Jx"], 1.0)
    elif edit == "warning deleted":
        document["warnings"] = []
    elif edit == "key added":
        document["approved"] = True
    elif edit == "key removed":
        del document["com"]
    else:
        document[INTEGRITY_KEY]["sha256"] = "0" * 64
    assert integrity_state(json.loads(json.dumps(document))) == "edited"


def test_a_document_without_integrity_is_not_sealed():
    assert integrity_state(DOCUMENT) == "not sealed"
    assert integrity_state({**DOCUMENT, INTEGRITY_KEY: "x"}) == "edited"


def _sealed(root):
    """Seal a test mounting's hand-made result.json, as identify writes it."""
    path = root / "result.json"
    path.write_text(sealed_json(json.loads(path.read_text())))
    return root


def test_combine_refuses_an_edited_result_and_writes_nothing(tmp_path, capsys):
    first = _sealed(_mounting(tmp_path / "a", np.eye(3)))
    second = _sealed(_mounting(tmp_path / "b", TURNED_X90))
    out = tmp_path / "body"
    assert main(["combine", str(first), str(second), "--out", str(out)]) == 0
    body = json.loads((out / "body.json").read_text())
    assert integrity_state(body) == "as written"
    assert not any("records no integrity" in w for w in body["warnings"])
    (out / "body.json").unlink()

    path = second / "result.json"
    document = json.loads(path.read_text())
    document["tensor"]["Jx"] += 1e-7
    path.write_text(json.dumps(document, indent=2))
    capsys.readouterr()
    assert main(["combine", str(first), str(second), "--out", str(out)]) == 2
    one_line_error(capsys, f"{path}: edited after identify wrote it", "identify")
    assert not (out / "body.json").exists()


def test_combine_reads_a_result_without_integrity_with_a_note(tmp_path, capsys):
    first = _sealed(_mounting(tmp_path / "a", np.eye(3)))
    second = _mounting(tmp_path / "b", TURNED_X90)  # no integrity: an older rsp-inertia's
    out = tmp_path / "body"
    assert main(["combine", str(first), str(second), "--out", str(out)]) == 0
    warnings = json.loads((out / "body.json").read_text())["warnings"]
    noted = [w for w in warnings if "records no integrity" in w]
    assert len(noted) == 1 and str(second / "result.json") in noted[0]


def test_the_body_report_turns_red_on_an_edited_body_json(tmp_path):
    first = _sealed(_mounting(tmp_path / "a", np.eye(3)))
    second = _sealed(_mounting(tmp_path / "b", TURNED_X90))
    out = tmp_path / "body"
    assert main(["combine", str(first), str(second), "--out", str(out)]) == 0
    assert main(["report", str(out)]) == 0
    assert "body.json was edited" not in (out / "report.html").read_text()
    document = json.loads((out / "body.json").read_text())
    document["com"]["z"] += 1e-4
    (out / "body.json").write_text(json.dumps(document, indent=2))
    assert main(["report", str(out)]) == 0
    page = (out / "report.html").read_text()
    assert "<div class='verdict stale'>" in page and "body.json was edited after it" in page
    assert main(["report", str(out), "--strict"]) == 3
