"""``rsp-inertia report``: EXP/report.html, one self-contained file for a test report.

Built from what identify wrote (result.json) and what the experiment holds: the tensor and
the axial moments with their stds, the uncertainty budget, the warnings, the calibration
applied, the protocol of every stage (device.toml), the sha256 of every input file, the
package versions, and the figures found in the folder (PNG, inlined as base64: the file
needs no network and no other file).
"""

from __future__ import annotations

import base64
import hashlib
import html
import json
import platform
from importlib import metadata
from pathlib import Path

from rsp_inertia.plant.errors import InputError
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.logs import write_atomic

__all__ = ["FIGURES", "PACKAGES", "REPORT_FILE", "write_report"]

REPORT_FILE = "report.html"
"""Written into the experiment folder."""

FIGURES = ("errors.png", "design.png", "plan.png", "encoder_error.png")
"""Figures inlined when present, then every motion_stageN.png and tracking_stageN.png."""

PACKAGES = ("rsp-inertia", "numpy", "scipy", "casadi", "control", "matplotlib")
"""Whose installed versions the report records."""

INPUT_PATTERNS = ("device.toml", "calibration.toml", "reference.toml", "stage*/*.csv")
"""The input files whose hashes the report records (result.json is the output it shows)."""


def _table(head: list[str], rows: list[list[str]]) -> str:
    cells = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows
    )
    return f"<table><tr>{cells}</tr>{body}</table>"


def _version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "not installed"


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def write_report(root: str | Path) -> Path:
    """Write EXP/report.html (atomically) and return its path.

    Raises
    ------
    InputError
        No result.json (run identify first), or one that is not identify's.
    """
    exp = open_experiment(root)
    path = exp.result_path
    if not path.is_file():
        raise InputError(f"{path}: not found: run rsp-inertia identify {exp.root} first")
    try:
        result = json.loads(path.read_text())
        tensor, tensor_std, axes = result["tensor"], result["tensor_std"], result["axes"]
    except (json.JSONDecodeError, KeyError, TypeError) as error:
        raise InputError(f"{path}: not a result.json written by identify ({error!r})") from None
    device = exp.device
    parts = [
        f"<h1>rsp-inertia report: {html.escape(device.name)}</h1>",
        f"<p>Experiment folder <code>{html.escape(str(exp.root))}</code>.</p>",
        "<h2>Inertia tensor (least squares)</h2>",
        _table(
            ["entry", "kg m^2", "std"],
            [[k, f"{v:.8g}", f"{tensor_std[k]:.2g}"] for k, v in tensor.items()],
        ),
    ]
    if result.get("com") is not None:
        com, std = result["com"], result.get("com_std") or {}
        parts.append(
            "<p>Centre of mass: "
            + ", ".join(f"{n} = {com[n] * 1e3:.4f} &plusmn; {std.get(n, float('nan')) * 1e3:.1g} mm"
                        for n in ("x", "y"))
            + "</p>"
        )
    parts += [
        f"<p>cond(V) = {result.get('condition_number', float('nan')):.4g}</p>",
        "<h2>Axial moments</h2>",
        _table(
            ["stage", "node deg", "J kg m^2", "std", "node formula", "std"],
            [[a["stage"], f"{a['phi_deg']:g}", f"{a['J']:.8g}", f"{a['J_std']:.2g}",
              f"{a['J_node']:.8g}", f"{a['J_node_std']:.2g}"] for a in axes],
        ),
    ]
    budget = (result.get("least_squares") or {}).get("std_budget") or {}
    if budget:
        parts += [
            "<h2>Uncertainty budget (std of each axis by source, kg m^2)</h2>",
            _table(
                ["source"] + [f"axis {k + 1}" for k in range(len(axes))],
                [[source, *(f"{v:.2g}" for v in part["axes_J_std"])]
                 for source, part in budget.items()],
            ),
        ]
    warnings = result.get("warnings") or []
    parts.append("<h2>Warnings</h2>")
    parts.append(
        "<ul>" + "".join(f"<li>{html.escape(w)}</li>" for w in warnings) + "</ul>"
        if warnings else "<p>None.</p>"
    )
    parts.append("<h2>Calibration</h2>")
    calibration = result.get("calibration")
    parts.append(
        f"<pre>{html.escape(json.dumps(calibration, indent=2))}</pre>" if calibration
        else "<p>None applied: device.toml's tares and a torque gain of 1.</p>"
    )
    parts += [
        "<h2>Protocol</h2>",
        _table(
            ["stage", "gear ratio", "nodes deg", "launch speed rad/s", "braking torque N m",
             "directions"],
            [[k, f"{st.gear_ratio:.10g}", ", ".join(f"{n:g}" for n in st.nodes_deg),
              f"{st.launch_speed:g}", f"{st.braking_torque:g}", ", ".join(st.directions)]
             for k, st in enumerate(device.stages, 1)],
        ),
    ]
    inputs = sorted({p for pattern in INPUT_PATTERNS for p in exp.root.glob(pattern)})
    parts += [
        "<h2>Input files</h2>",
        _table(["file", "sha256"],
               [[str(p.relative_to(exp.root)), _sha256(p)] for p in inputs]),
        "<h2>Software</h2>",
        _table(["package", "version"],
               [["python", platform.python_version()]]
               + [[name, _version(name)] for name in PACKAGES]),
    ]
    figures = [exp.root / name for name in FIGURES]
    figures += sorted(exp.root.glob("motion_stage*.png")) + sorted(exp.root.glob("tracking_stage*.png"))
    figures = [f for f in figures if f.is_file()]
    if figures:
        parts.append("<h2>Figures</h2>")
        for figure in figures:
            data = base64.b64encode(figure.read_bytes()).decode("ascii")
            parts.append(
                f"<figure><img alt='{html.escape(figure.name)}' "
                f"src='data:image/png;base64,{data}'><figcaption>{html.escape(figure.name)}"
                "</figcaption></figure>"
            )
    style = (
        "body{font-family:sans-serif;max-width:60em;margin:auto}"
        "table{border-collapse:collapse}td,th{border:1px solid #999;padding:2px 6px}"
        "img{max-width:100%}"
    )
    page = (
        "<!DOCTYPE html><html><head><meta charset='utf-8'>"
        f"<title>rsp-inertia report: {html.escape(device.name)}</title>"
        f"<style>{style}</style></head><body>\n" + "\n".join(parts) + "\n</body></html>\n"
    )
    out = exp.root / REPORT_FILE
    write_atomic(out, page)
    return out
