"""What both reports share (``rsp-inertia report`` on an experiment folder, EXP/report.html,
and on a combine folder, OUT/report.html): the page and its print layout, the test report's
identification (ISO/IEC 17025 section 7.8: a title, the report's unique number, the lab and
rig, the method, the dates, the item, the statement that the results relate only to it), the
record of the measurement, the decision against a specification, the signature block.

The report's number is taken from the result it shows (the sha256 of result.json or
body.json as read): the same result gives the same number, another result another. Every
page of the print carries it with "page x of y" (CSS ``@page`` margin boxes, which Chromium
and WeasyPrint both print). The layout fits A4 and Letter (the narrower width and the lower
height of the two); headings stay with what follows them, tables and figures are not split
where they fit on one page.
"""

from __future__ import annotations

import hashlib
import html
import math
from collections.abc import Iterable

__all__ = [
    "STATEMENT",
    "VALUE",
    "Z95",
    "decision_box",
    "identification",
    "interval",
    "page",
    "record_section",
    "report_number",
    "signature_block",
    "table",
    "warning_items",
    "warnings_section",
]

VALUE = "#.8g"
"""How an estimate is printed: eight significant digits, trailing zeros kept (0.028000000,
not 0.028, whose precision reads as two digits)."""

Z95 = 1.959963984540054
"""The 95% interval of a Gaussian estimate is +- Z95 std."""

STATEMENT = (
    "The results relate only to the item tested, as mounted and measured in the runs named "
    "here. This report shall not be reproduced except in full."
)
"""The statement ISO/IEC 17025 section 7.8.2.1 asks of a test report."""

NOT_RECORDED = "not recorded"
"""What the report says of a record field that result.json does not hold."""

STYLE = (
    "body{font-family:sans-serif;max-width:62em;margin:auto;padding:0 1em;color:#222}"
    "table{border-collapse:collapse;margin:0.4em 0 1em}"
    "td,th{border:1px solid #999;padding:2px 6px;text-align:right}"
    "td:first-child,th:first-child{text-align:left}"
    "tr.total td{font-weight:bold;border-top:2px solid #444}"
    "table.id td{text-align:left;border-color:#ccc}table.id td.k{color:#555;white-space:nowrap}"
    "table.hashes td{font-family:monospace;font-size:0.85em}"
    ".boxes{display:flex;gap:0.8em;align-items:stretch;margin:0.8em 0}"
    ".boxes>div{flex:1 1 0}"
    ".verdict{border:3px solid;border-radius:6px;padding:0.3em 1em}"
    ".verdict h2{margin-top:0.3em}"
    ".ok{border-color:#2a7a2a;background:#eef8ee}"
    ".warn{border-color:#b07000;background:#fff6e0}"
    ".stale{border-color:#b00020;background:#fdecee}"
    ".none{border-color:#888;background:#f4f4f4}"
    ".meta{color:#555}.statement{font-style:italic}"
    "img{max-width:100%}figure{margin:1em 0}"
    "table.sign{width:100%;margin-top:0.6em}table.sign td{text-align:left;height:2.6em;"
    "vertical-align:bottom;width:25%}table.sign th{text-align:left}"
    "@media print{"
    "body{max-width:none;margin:0;padding:0;font-size:9pt}"
    "h1{font-size:15pt;margin:0 0 0.3em}h2{font-size:11pt;margin:0.7em 0 0.25em}"
    "h3{font-size:9.5pt;margin:0.5em 0 0.2em}p{margin:0.3em 0}"
    "table{margin:0.2em 0 0.6em}td,th{padding:1px 4px}"
    "h1,h2,h3{break-after:avoid;page-break-after:avoid}"
    ".keep,table,figure,.verdict,.signatures{break-inside:avoid;page-break-inside:avoid}"
    "table.long{break-inside:auto;page-break-inside:auto}tr{break-inside:avoid}"
    ".figures figure{display:inline-block;width:49%;margin:0 0 0.5em;vertical-align:top}"
    ".figures img{max-height:80mm;width:auto;max-width:100%}"
    "figcaption{font-size:8pt}"
    "}"
)
"""The page's CSS: the screen, then the print (both A4 and Letter: no fixed paper size;
``report --pdf`` sets the paper). :func:`page` adds the ``@page`` rule with the footer."""

PAGE_RULE = (
    "@page{{margin:14mm 12mm 16mm 12mm;"
    "@bottom-left{{content:'{number}';font:8pt sans-serif;color:#555}}"
    "@bottom-right{{content:'page ' counter(page) ' of ' counter(pages);font:8pt sans-serif;"
    "color:#555}}}}"
)
"""Every printed page's margins and footer: the report's number, and page x of y."""


def table(
    head: list[str],
    rows: list[list[str]],
    total: list[str] | None = None,
    kind: str = "",
) -> str:
    """An HTML table: a header row, the rows, an optional bold total row (every cell
    escaped).

    Parameters
    ----------
    head : list of str
        The header cells.
    rows : list of list of str
        The rows' cells.
    total : list of str, optional
        A last row in bold (a budget's total).
    kind : str, optional
        The table's CSS classes (``long``: it may break across printed pages; ``hashes``:
        monospaced cells).

    Returns
    -------
    str
        The table's HTML.
    """
    cells = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows
    )
    if total is not None:
        body += "<tr class='total'>" + "".join(
            f"<td>{html.escape(str(c))}</td>" for c in total
        ) + "</tr>"
    css = f" class='{kind}'" if kind else ""
    return f"<table{css}><tr>{cells}</tr>{body}</table>"


def interval(value: float, std: float | None, digits: str = VALUE) -> str:
    """The 95% interval ``[value - Z95 std, value + Z95 std]`` as text.

    Parameters
    ----------
    value : float
        The estimate.
    std : float or None
        Its standard uncertainty (None or not finite: "not defined").
    digits : str, optional
        The format of both ends (default :data:`VALUE`).

    Returns
    -------
    str
        ``[low, high]``.
    """
    if std is None or not math.isfinite(std):
        return "not defined"
    return f"[{value - Z95 * std:{digits}}, {value + Z95 * std:{digits}}]"


def report_number(prefix: str, document: bytes) -> str:
    """The report's unique number: ``prefix`` and the first 12 hex digits of the sha256 of the
    result file as read (the same result, the same number).

    Parameters
    ----------
    prefix : str
        ``RSP`` for an experiment's result, ``RSP-BODY`` for a combined body.
    document : bytes
        result.json's or body.json's bytes.

    Returns
    -------
    str
        ``PREFIX-xxxxxxxxxxxx``.
    """
    return f"{prefix}-{hashlib.sha256(document).hexdigest()[:12]}"


def _text(value: object) -> str:
    """A record field as text; None or absent is :data:`NOT_RECORDED`."""
    return NOT_RECORDED if value is None or value == "" else str(value)


def identification(rows: Iterable[tuple[str, str]]) -> str:
    """The report's identification: label/value pairs in a two-pair-wide table (values
    escaped here)."""
    rows = list(rows)
    cells = []
    for i in range(0, len(rows), 2):
        pair = rows[i : i + 2]
        cells.append("<tr>" + "".join(
            f"<td class='k'>{html.escape(k)}</td><td>{html.escape(v)}</td>" for k, v in pair
        ) + ("<td></td><td></td>" if len(pair) == 1 else "") + "</tr>")
    return "<table class='id'>" + "".join(cells) + "</table>"


WARNINGS_SHOWN = 3
"""The verdict box lists at most this many warnings; the rest follow the result, in the
section "Warnings" (so that the first printed page keeps the result with the verdict)."""


def warning_items(warnings: list[str]) -> str:
    """The verdict box's list: the first :data:`WARNINGS_SHOWN` warnings, and how many more
    the section "Warnings" lists."""
    shown = "".join(f"<li>{html.escape(w)}</li>" for w in warnings[:WARNINGS_SHOWN])
    more = len(warnings) - WARNINGS_SHOWN
    if more > 0:
        shown += (f"<li><b>{more} more</b>: under Warnings, below the result (all "
                  f"{len(warnings)} there).</li>")
    return f"<ul>{shown}</ul>"


def warnings_section(warnings: list[str]) -> list[str]:
    """Every warning, when the verdict box could not list them all (else nothing)."""
    if len(warnings) <= WARNINGS_SHOWN:
        return []
    return ["<h2>Warnings</h2>",
            "<ol>" + "".join(f"<li>{html.escape(w)}</li>" for w in warnings) + "</ol>"]


def record_rows(record: dict | None) -> list[tuple[str, str]]:
    """The record's fields as (label, text) rows; every field :data:`NOT_RECORDED` without
    ``record`` (result.json written before records existed, or without EXP/record.toml)."""
    record = record or {}
    environment = record.get("environment") or {}
    calibration = record.get("calibration") or {}
    certificate = record.get("reference_certificate")
    due = _text(calibration.get("due"))
    if calibration.get("overdue"):
        due += " (overdue)"

    def unit(value: object, suffix: str) -> str:
        return NOT_RECORDED if value is None else f"{value:g} {suffix}"

    return [
        ("operator", _text(record.get("operator"))),
        ("part number", _text(record.get("part_id"))),
        ("serial number", _text(record.get("serial"))),
        ("rig's asset id", _text(record.get("asset_id"))),
        ("calibration date", _text(calibration.get("date"))),
        ("calibration due", due),
        ("reference certificate", NOT_RECORDED if not certificate else ", ".join(
            _text(certificate.get(k)) for k in ("id", "issuer", "date"))),
        ("temperature", unit(environment.get("temperature_C"), "\u00b0C")),
        ("pressure", unit(environment.get("pressure_hPa"), "hPa")),
        ("relative humidity", unit(environment.get("humidity_percent"), "%")),
        ("notes", _text(record.get("notes"))),
    ]


def record_section(records: dict[str, dict | None]) -> list[str]:
    """The record of the measurement: per result (one for an experiment, one per mounting for
    a combined body) its record fields, or "not recorded".

    Parameters
    ----------
    records : dict of str to dict or None
        Result's name -> its ``record`` (result.json, docs/files.md), None where it has none.

    Returns
    -------
    list of str
        The section's HTML parts.
    """
    names = list(records)
    note = ("" if any(records.values()) else
            "<p>result.json holds no record (no EXP/record.toml when identify ran): the fields "
            "below are to be filled in by hand.</p>")
    if len(names) == 1:
        return ["<h2>Record of the measurement</h2>",
                note + identification(record_rows(records[names[0]]))]
    rows = [[label, *(dict(record_rows(records[n]))[label] for n in names)]
            for label, _ in record_rows(None)]
    return ["<h2>Record of the measurements</h2>", note + table(["field", *names], rows)]


DECISION_TEXT = {"pass": "PASS", "fail": "FAIL", "indeterminate": "INDETERMINATE"}
"""How a decision is printed."""

DECISION_CLASS = {"pass": "ok", "fail": "stale", "indeterminate": "warn"}
"""A decision's box colour: green, red, amber."""


def decision_box(decision: dict | None, absent: str = "") -> str:
    """The part's verdict against its specification (result.json ``decision``), to stand
    beside the software's verdict: each limited quantity's value, U, limits and verdict, and
    the decision rule in words; a grey box saying there is none when ``decision`` is None or
    absent.

    Parameters
    ----------
    decision : dict or None
        ``{"rule", "quantities": {name: "pass" | "fail" | "indeterminate"},
        "limits": {name: [low, high]}, "part"}``, and optionally ``"values"`` {name:
        {"value", "U"}} and ``"statement"`` (the rule in words).
    absent : str, optional
        What the grey box says without a decision (default: no EXP/spec.toml).

    Returns
    -------
    str
        The box's HTML.
    """
    if not decision:
        absent = absent or ("No specification (EXP/spec.toml): the part is not judged. The "
                            "verdict beside this box is about the measurement, not the part.")
        return f"<div class='verdict none'><h2>Decision: none</h2><p>{absent}</p></div>"
    part = str(decision.get("part", "indeterminate"))
    rule = str(decision.get("rule", "not stated"))
    limits = decision.get("limits") or {}
    values = decision.get("values") or {}
    rows = []
    for name, verdict in (decision.get("quantities") or {}).items():
        low_high = limits.get(name)
        span = (f"[{low_high[0]:.12g}, {low_high[1]:.12g}]" if isinstance(low_high, list | tuple)
                and len(low_high) == 2 else "")
        value = values.get(name) or {}
        rows.append([
            name,
            f"{value['value']:.12g}" if "value" in value else "",
            f"{value['U']:.2g}" if "U" in value else "",
            span,
            DECISION_TEXT.get(verdict, str(verdict)),
        ])
    rule_text = decision.get("statement") or {
        "simple": "simple acceptance (the estimate within the limits)",
        "guarded": "guarded acceptance (ILAC-G8: the limits narrowed by the expanded "
                   "uncertainty U to pass, widened by U to fail)",
    }.get(rule, rule)
    return (
        f"<div class='part verdict {DECISION_CLASS.get(part, 'warn')}'>"
        f"<h2>Part: {html.escape(DECISION_TEXT.get(part, part))}</h2>"
        f"<p>Against EXP/spec.toml ({html.escape(rule)} rule): {html.escape(rule_text)}.</p>"
        + table(["quantity (SI units)", "value", "U", "limits", "decision"], rows) + "</div>"
    )


def signature_block(prepared_by: str | None) -> str:
    """Prepared by / checked by / approved by: name, date and signature lines, blank to be
    signed on paper; ``prepared by``'s name filled from the record's operator when known."""
    rows = "".join(
        f"<tr><th>{role}</th><td>{html.escape(name)}</td><td></td><td></td></tr>"
        for role, name in (("prepared by", prepared_by or ""), ("checked by", ""),
                           ("approved by", ""))
    )
    return (
        "<div class='signatures'><h2>Signatures</h2><table class='sign'>"
        "<tr><th></th><th>name</th><th>date</th><th>signature</th></tr>"
        f"{rows}</table></div>"
    )


def _paragraph(part: str) -> bool:
    """Whether ``part`` is one paragraph alone (no table or figure after it)."""
    return part.startswith("<p") and part.endswith("</p>") and part.count("<p") == 1


def _kept(parts: list[str]) -> list[str]:
    """The parts with each heading (h2, h3) wrapped together with the parts after it up to the
    first that is not a paragraph (a table, a figure), so that a printed page never ends on
    a heading or on the sentence that introduces a table."""
    kept, pending = [], []
    for part in parts:
        # A heading, and a paragraph under one, wait for what follows them.
        if part.startswith(("<h2", "<h3")) or (pending and _paragraph(part)):
            pending.append(part)
            continue
        kept.append("<div class='keep'>" + "".join(pending) + part + "</div>" if pending
                    else part)
        pending = []
    return kept + pending


def page(title: str, number: str, parts: list[str]) -> str:
    """The whole HTML document.

    Parameters
    ----------
    title : str
        The document's title (the browser's tab, the PDF's metadata).
    number : str
        The report number, printed in every page's footer with "page x of y".
    parts : list of str
        The body's HTML parts, in order; each heading (h2, h3) is kept with the part after it.

    Returns
    -------
    str
        The page, with its style and print layout.
    """
    footer = "".join(c for c in number if c.isalnum() or c in " -_.:")
    return (
        "<!DOCTYPE html><html><head><meta charset='utf-8'>"
        f"<title>{html.escape(title)}</title>"
        f"<style>{STYLE}{PAGE_RULE.format(number='Report ' + footer)}</style></head><body>\n"
        + "\n".join(_kept(parts)) + "\n</body></html>\n"
    )
