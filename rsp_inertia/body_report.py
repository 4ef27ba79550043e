"""``rsp-inertia report OUT`` on a combine folder: OUT/report.html, the combined body's test
report.

Built from what combine wrote (OUT/body.json) and the mountings' result.json files it names
(body.json's ``provenance``, relative to OUT). It leads with a verdict: whether each
mounting's result.json is still the one combine read (its sha256), whether the mountings agree
within their noise (combine's chi^2 test), and combine's warnings; beside it the decision
(none: a specification judges a mounting's result, not the combined body, yet). Then the
tensor about the body frame's origin in body axes and the whole centre of mass (z_c
included), each with its std and 95% interval; the principal moments and axes; the mountings
(rotation and origin as their device.toml states them, residuals in stds); the record of each
mounting's measurement; the provenance and the software; the signature block. Shared parts:
rsp_inertia.report_parts.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import check_writable, file_sha256, write_atomic
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.experiment import BODY_FILE, REPORT_FILE, open_experiment
from rsp_inertia.provenance import created_now, integrity_state, package_versions
from rsp_inertia.report_parts import (
    STATEMENT,
    VALUE,
    decision_box,
    identification,
    interval,
    page,
    record_section,
    report_number,
    signature_block,
    table,
    warning_items,
    warnings_section,
)

__all__ = ["is_body_folder", "write_body_report"]

NO_DECISION = (
    "No specification for the combined body: a specification (EXP/spec.toml) judges one "
    "experiment's result. The verdict beside this box is about the measurement, not the part."
)
"""The decision box of a body.json without ``decision``."""

ENTRY_KEYS = ("Jx", "Jy", "Jz", "Jxy", "Jyz", "Jxz")
"""The tensor's entries as body.json names them."""


def is_body_folder(root: str | Path) -> bool:
    """Whether ``root`` is a combine folder: it holds body.json and no device.toml."""
    root = Path(root)
    return (root / BODY_FILE).is_file() and not (root / "device.toml").is_file()


def _read_body(path: Path) -> dict:
    try:
        body = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise InputError(f"{path}: not a body.json written by combine ({error})") from None
    missing = [key for key in ("tensor", "tensor_std", "com", "com_std", "mountings")
               if not isinstance(body, dict) or key not in body]
    if missing:
        raise InputError(f"{path}: not a body.json written by combine (no {missing[0]!r})")
    return body


def _inputs(root: Path, body: dict) -> list[dict]:
    """Each mounting's result.json as body.json's provenance names it: its name, path, the
    sha256 recorded, its state now ("as read", "changed", "removed") and its document (None
    when it cannot be read)."""
    found = []
    for name, digest in ((body.get("provenance") or {}).get("inputs") or {}).items():
        path = root / name
        state, document = "removed", None
        if path.is_file():
            state = "as read" if file_sha256(path) == digest else "changed"
            try:
                document = json.loads(path.read_text(encoding="utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError):
                document = None
        found.append({"name": name, "path": path, "sha256": digest, "state": state,
                      "document": document})
    return found


def _verdict(root: Path, body: dict, inputs: list[dict]) -> str:
    """The box the report leads with: are the mountings' results those combine read, do the
    mountings agree, and combine's warnings."""
    level, items = body_verdict(body, inputs)
    title = {"ok": "Verdict: no warnings", "warn": "Verdict: read the warnings",
             "stale": "Verdict: do not use as it stands"}[level]
    return f"<div class='verdict {level}'><h2>{title}</h2>" + "".join(items) + "</div>"


def body_verdict(body: dict, inputs: list[dict]) -> tuple[str, list[str]]:
    """The combined body's verdict: 'ok', 'warn' or 'stale' (as
    rsp_inertia.report.verdict_level's), and the HTML paragraphs that say why.

    Parameters
    ----------
    body : dict
        body.json as read.
    inputs : list of dict
        The mountings' result.json files as the folder holds them now (their ``state``).

    Returns
    -------
    (str, list of str)
        The level and the paragraphs.
    """
    items, level = [], "ok"
    if integrity_state(body) == "edited":
        level = "stale"
        items.append(
            "<p><b>body.json was edited after it was written</b> (its integrity sha256 is not "
            "its content's): a number or a warning below may not be combine's. Run combine "
            "again.</p>")
    if "provenance" not in body:
        level = "stale"
        items.append(
            "<p><b>body.json records no provenance</b> (made by an older rsp-inertia): which "
            "results it combines, and whether they are unchanged, cannot be checked. Run "
            "combine again.</p>")
    changed = [i for i in inputs if i["state"] != "as read"]
    if changed:
        level = "stale"
        items.append(
            "<p><b>A mounting's result changed since combine read it</b>: the body below is "
            "made from the results as they were. Run combine again.</p><ul>"
            + "".join(f"<li>{html.escape(i['name'])}: {i['state']} since combine</li>"
                      for i in changed) + "</ul>")
    consistency = body.get("consistency") or {}
    warnings = body.get("warnings") or []
    if warnings:
        level = "stale" if level == "stale" else "warn"
        items.append(
            f"<p><b>{len(warnings)} warning{'s' if len(warnings) > 1 else ''}</b>: read them "
            "before using the numbers.</p>" + warning_items(warnings))
    else:
        items.append("<p><b>No warnings</b>: combine found nothing questionable.</p>")
    if consistency:
        items.append(
            f"<p>The mountings' consistency: chi^2 = {consistency['chi2']:.4g} on "
            f"{consistency['dof']} degrees of freedom, p = {consistency['p']:.2g} (they "
            "disagree below p = 0.01).</p>")
    return level, items


def body_report_verdict(root: str | Path) -> str:
    """The combined body's verdict a report of combine folder ``root`` leads with, without
    writing it: 'ok', 'warn' or 'stale' (:func:`body_verdict`).

    Parameters
    ----------
    root : str or pathlib.Path
        The combine folder, with its body.json.

    Returns
    -------
    str
        'ok', 'warn' or 'stale'.
    """
    root = Path(root)
    body = _read_body(root / BODY_FILE)
    return body_verdict(body, _inputs(root, body))[0]


def _result_sections(body: dict) -> list[str]:
    tensor, std = body["tensor"], body["tensor_std"]
    com, com_std = body["com"], body["com_std"]
    parts = [
        "<h2>Inertia tensor in body axes, kg m^2</h2>",
        ("<p>About the body frame's origin, in the body's own axes (each mounting's "
         "device.toml [mounting] states how they sat on the rig). Products are the tensor's "
         "entries (Jxy = -integral of x y dm). std: the standard uncertainty; 95% interval: "
         "+- 1.96 std.</p>" + table(
             ["entry", "kg m^2", "std", "relative std", "95% interval"],
             [[k, f"{tensor[k]:{VALUE}}", f"{std[k]:.2g}",
               f"{std[k] / abs(tensor[k]):.1e}" if tensor[k] else "-",
               interval(tensor[k], std[k])] for k in ENTRY_KEYS if k in tensor])),
        "<h2>Centre of mass in body axes, mm</h2>",
        ("<p>z_c included: the mountings turn the body, so the coordinate that one mounting "
         "keeps along the shaft another measures.</p>" + table(
             ["", "mm", "std", "95% interval"],
             [[f"{n}_c", f"{com[n] * 1e3:.5f}", f"{com_std[n] * 1e3:.2g}",
               interval(com[n] * 1e3, com_std[n] * 1e3, ".5f")] for n in ("x", "y", "z")
              if n in com])),
    ]
    moments = body.get("principal_moments")
    if moments:
        moments_std = body.get("principal_moments_std") or [float("nan")] * 3
        tilt = body.get("principal_axes_tilt_std_deg") or [None] * 3
        parts += ["<h2>Principal moments and axes (body axes)</h2>", table(
            ["", "kg m^2", "std", "95% interval", "axis (x, y, z)", "axis tilt std, deg"],
            [[f"I{i + 1}", f"{m:{VALUE}}", f"{s:.2g}", interval(m, s),
              "(" + ", ".join(f"{c:+.6f}" for c in a) + ")",
              "not defined (equal moments)" if t is None else f"{t:.2g}"]
             for i, (m, s, a, t) in enumerate(
                 zip(moments, moments_std, body["principal_axes"], tilt))])]
    return parts


def _devices(root: Path, body: dict, inputs: list[dict]) -> list[Device | None]:
    """Each mounting's device.toml as it is now (None: it cannot be read), found beside the
    result.json that body.json's provenance names (else under the mounting's name)."""
    devices = []
    for k, mounting in enumerate(body["mountings"]):
        folder = inputs[k]["path"].parent if k < len(inputs) else root / mounting["name"]
        try:
            devices.append(open_experiment(folder, protocol=False).device)
        except InputError:
            devices.append(None)
    return devices


def _mounting_rows(body: dict, devices: list[Device | None]) -> list[list[str]]:
    """Per mounting: its folder, the rotation and origin its device.toml states now (or that
    it cannot be read)."""
    rows = []
    for mounting, device in zip(body["mountings"], devices):
        if device is None:
            rows.append([mounting["name"], "device.toml not found", ""])
            continue
        placed = device.mounting
        rotation = ("identity (no [mounting])" if placed is None else
                    "; ".join("[" + ", ".join(f"{c:.6g}" for c in row) + "]"
                              for row in placed.rotation))
        origin = ("0.000, 0.000, 0.000" if placed is None else
                  ", ".join(f"{c * 1e3:.3f}" for c in placed.origin))
        rows.append([mounting["name"], rotation, origin])
    return rows


def _mountings_section(body: dict, devices: list[Device | None]) -> list[str]:
    keys = list(body["mountings"][0]["residuals"] if body["mountings"] else {})
    residuals = [[m["name"], *("-" if m["residuals"].get(k) is None
                               else f"{m['residuals'][k]:+.2f}" for k in keys)]
                 for m in body["mountings"]]
    consistency = body.get("consistency") or {}
    return [
        "<h2>Mountings</h2>",
        ("<p>How the body sat on the rig (rotation: body axes to rig axes, rows; origin: the "
         "body frame's origin in rig axes, mm), as each mounting's device.toml states it "
         "now.</p>" + table(["mounting", "rotation", "origin, mm"],
                            _mounting_rows(body, devices))),
        "<h3>Consistency: each measured quantity's residual, in stds</h3>",
        ("<p>What each mounting measured minus what the combined body predicts for it, over "
         "the std of that difference ('-': not tested, the other mountings do not measure "
         "it)." + (f" chi^2 = {consistency['chi2']:.4g} on {consistency['dof']} dof, "
                   f"p = {consistency['p']:.2g}." if consistency else "") + "</p>"
         + table(["mounting", *keys], residuals)),
    ]


def _provenance_sections(body: dict, inputs: list[dict]) -> list[str]:
    provenance = body.get("provenance") or {}
    software = provenance.get("software") or {}
    rows = [[i["name"], i["sha256"], i["state"]] for i in inputs]
    return [
        "<h2>Results combined (sha256 when combine read them)</h2>",
        (table(["result.json", "sha256", "now"], rows, kind="long hashes") if rows
         else "<p>Not recorded.</p>"),
        "<h2>Software</h2>",
        table(["package", "made the body", "installed now"],
              [[name, software.get(name, "not recorded"), version]
               for name, version in package_versions().items()]),
    ]


def write_body_report(root: str | Path) -> Path:
    """Write OUT/report.html (atomically) for the body that ``rsp-inertia combine`` wrote to
    OUT/body.json, and return its path.

    Parameters
    ----------
    root : str or pathlib.Path
        The combine folder, with body.json.

    Returns
    -------
    pathlib.Path
        The report.html written.

    Raises
    ------
    InputError
        No body.json, or one that combine did not write.
    """
    root = Path(root)
    path = root / BODY_FILE
    if not path.is_file():
        raise InputError(f"{path}: not found: run rsp-inertia combine EXP ... --out {root}")
    body = _read_body(path)
    out = root / REPORT_FILE
    check_writable(out)
    inputs = _inputs(root, body)
    written = created_now()
    number = report_number("RSP-BODY", path.read_bytes())
    documents = [i["document"] if isinstance(i["document"], dict) else {} for i in inputs]
    mountings = [m["name"] for m in body["mountings"]]
    labels = mountings if len(mountings) == len(inputs) else [i["name"] for i in inputs]
    records = {label: d.get("record") for label, d in zip(labels, documents)}
    first = next((r for r in records.values() if r), {})
    devices = _devices(root, body, inputs)
    rigs = sorted({d.name for d in devices if d is not None})
    rig = ", ".join(rigs) or "device.toml not found"
    if first.get("asset_id"):
        rig += f" (asset {first['asset_id']})"
    provenance = body.get("provenance") or {}
    version = (provenance.get("software") or {}).get("rsp-inertia", "an unrecorded version")
    measured = sorted({str((d.get("provenance") or {}).get("created", "")) for d in documents}
                      - {""})
    item = ", ".join(f"{label} {first[key]}" for label, key in
                     (("part", "part_id"), ("serial", "serial")) if first.get(key))
    names = ", ".join(m["name"] for m in body["mountings"])
    parts = [
        (f"<h1>Test report: inertia tensor and centre of mass of the body, from "
        f"{len(body['mountings'])} mountings</h1>"),
        identification([
            ("report number", number),
            ("date of issue", written),
            ("item tested", item or "the body of the mountings (part and serial not recorded)"),
            ("laboratory and rig", rig),
            ("method", (f"mountings combined by generalised least squares, rsp-inertia "
                       f"{version} combine (docs/method.md section 5, Combining mountings)")),
            ("date of the measurement", "not recorded; identify ran " + (
                ", ".join(measured) if measured else "at unrecorded times")),
            ("combine folder", str(root)),
            ("mountings", names),
        ]),
        ("<div class='boxes'>" + _verdict(root, body, inputs)
         + decision_box(body.get("decision"), NO_DECISION) + "</div>"),
        *_result_sections(body),
        f"<p class='statement'>{html.escape(STATEMENT)}</p>",
        *warnings_section(body.get("warnings") or []),
        *_mountings_section(body, devices),
        *(record_section(records) if records else []),
        *_provenance_sections(body, inputs),
        signature_block(first.get("operator")),
    ]
    write_atomic(out, page(f"Test report {number}: body from {names} ({written[:10]})",
                           number, parts))
    return out
