"""``rsp-inertia report``: EXP/report.html, one self-contained file for a test report.

Built from what identify wrote (result.json) and what the experiment holds. It leads with a
verdict: whether the inputs are still those identify read (result.json's provenance, checked
against the folder), and identify's warnings. Then the tensor, its principal moments and
axes and the centre of mass, each with its std and 95% interval; the axial moments; the
uncertainty budget by source, per stage and node, with its total; the calibration applied;
the protocol of every stage and the runs as logged (release angle, launch speed, turns);
the figures the logs allow (drawn from them) and those found in the folder; the input files'
sha256; the software that made the result. Figures are inlined as base64 PNG: the file needs
no network and no other file. The report never reads virtual.toml (the simulator's truth).
"""

from __future__ import annotations

import base64
import html
import json
import math
from pathlib import Path

from rsp_inertia.estimation.runs import runs
from rsp_inertia.estimation.smoothing import smooth_log
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import check_writable, write_atomic
from rsp_inertia.plant.experiment import (
    ENCODER_FIGURE,
    PLAN_FIGURE,
    REPORT_FILE,
    Experiment,
    open_experiment,
)
from rsp_inertia.plant.geometry import HARMONIC_NAMES
from rsp_inertia.plant.logs import read_device_log
from rsp_inertia.plots import (
    AXIS_DESIGN_FIGURE,
    ERRORS_FIGURE,
    difference_figure,
    experiment_figures,
    figure_png,
)
from rsp_inertia.provenance import (
    created_now,
    input_changes,
    input_status,
    integrity_state,
    package_versions,
)

__all__ = ["FIGURES", "REPORT_FILE", "VALUE", "Z95", "write_report"]

FIGURES = (PLAN_FIGURE, AXIS_DESIGN_FIGURE, ENCODER_FIGURE, ERRORS_FIGURE)
"""Figures of other commands inlined when present (plan, design or demo, calibrate, demo);
the motion and tracking figures are drawn from the logs (rsp_inertia.plots.experiment_figures)."""

VALUE = "#.8g"
"""How an estimate is printed: eight significant digits, trailing zeros kept (0.028000000,
not 0.028, whose precision reads as two digits)."""

Z95 = 1.959963984540054
"""The 95% interval of a Gaussian estimate is +- Z95 std."""

STYLE = (
    "body{font-family:sans-serif;max-width:62em;margin:auto;padding:0 1em;color:#222}"
    "table{border-collapse:collapse;margin:0.4em 0 1em}"
    "td,th{border:1px solid #999;padding:2px 6px;text-align:right}"
    "td:first-child,th:first-child{text-align:left}"
    "tr.total td{font-weight:bold;border-top:2px solid #444}"
    ".verdict{border:3px solid;border-radius:6px;padding:0.3em 1em;margin:1em 0}"
    ".verdict h2{margin-top:0.3em}"
    ".ok{border-color:#2a7a2a;background:#eef8ee}"
    ".warn{border-color:#b07000;background:#fff6e0}"
    ".stale{border-color:#b00020;background:#fdecee}"
    ".meta{color:#555}"
    "img{max-width:100%}figure{margin:1em 0}"
)


def _table(head: list[str], rows: list[list[str]], total: list[str] | None = None) -> str:
    cells = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows
    )
    if total is not None:
        body += "<tr class='total'>" + "".join(
            f"<td>{html.escape(str(c))}</td>" for c in total
        ) + "</tr>"
    return f"<table><tr>{cells}</tr>{body}</table>"


def _interval(value: float, std: float, digits: str = VALUE) -> str:
    """The 95% interval ``[value - Z95 std, value + Z95 std]``."""
    if std is None or not math.isfinite(std):
        return "not defined"
    return f"[{value - Z95 * std:{digits}}, {value + Z95 * std:{digits}}]"


def _read_result(exp: Experiment) -> dict:
    path = exp.result_path
    if not path.is_file():
        raise InputError(f"{path}: not found: run rsp-inertia identify {exp.root} first")
    try:
        result = json.loads(path.read_text())
    except json.JSONDecodeError as error:
        raise InputError(f"{path}: not a result.json written by identify ({error})") from None
    missing = [key for key in ("tensor", "tensor_std", "axes")
               if not isinstance(result, dict) or key not in result]
    if missing:
        raise InputError(f"{path}: not a result.json written by identify (no {missing[0]!r})")
    return result


def _verdict(exp: Experiment, result: dict, status: dict[str, str] | None) -> str:
    """The box the report leads with: are the inputs those identify read (``status``:
    rsp_inertia.provenance.input_status, None when result.json records none), is result.json
    as identify wrote it (rsp_inertia.provenance.integrity_state), and its warnings."""
    warnings = result.get("warnings") or []
    items, level = [], "ok"
    integrity = integrity_state(result)
    if integrity == "edited":
        level = "stale"
        items.append(
            "<p><b>result.json was edited after it was written</b> (its integrity sha256 is "
            "not its content's): a number or a warning below may not be identify's. Run "
            f"<code>rsp-inertia identify {html.escape(str(exp.root))}</code> again.</p>"
        )
    elif integrity == "not sealed":
        items.append(
            "<p>result.json records no integrity (an older rsp-inertia wrote it): whether it "
            "was edited after it was written cannot be checked.</p>"
        )
    if status is not None:
        changes = input_changes(status)
        if changes:
            level = "stale"
            items.append(
                "<p><b>The inputs changed since identify made this result</b>: the numbers "
                "below describe the files as they were, not as they are. Run "
                f"<code>rsp-inertia identify {html.escape(str(exp.root))}</code> again.</p>"
            )
            items.append("<ul>" + "".join(f"<li>{html.escape(c)}</li>" for c in changes)
                         + "</ul>")
    else:
        level = "stale"
        items.append(
            "<p><b>result.json records no provenance</b> (made by an older rsp-inertia): "
            "whether the folder still holds the inputs it was made from cannot be checked. "
            "Run identify again.</p>"
        )
    if warnings:
        level = "stale" if level == "stale" else "warn"
        items.append(
            f"<p><b>{len(warnings)} warning{'s' if len(warnings) > 1 else ''}</b>: each says "
            "what may move the result beyond its stds; read them before using the numbers.</p>"
        )
        items.append("<ul>" + "".join(f"<li>{html.escape(w)}</li>" for w in warnings) + "</ul>")
    else:
        items.append("<p><b>No warnings</b>: identify found nothing questionable.</p>")
    title = {"ok": "Verdict: no warnings", "warn": "Verdict: read the warnings",
             "stale": "Verdict: do not use as it stands"}[level]
    return f"<div class='verdict {level}'><h2>{title}</h2>" + "".join(items) + "</div>"


def _tensor_sections(result: dict) -> list[str]:
    tensor, std = result["tensor"], result["tensor_std"]
    parts = [
        "<h2>Inertia tensor (least squares), kg m^2</h2>",
        ("<p>In the rig's axes: z along the shaft, x and y as at phi = 0. Products are the "
         "tensor's entries (Jxy = -integral of x y dm).</p>"),
        _table(
            ["entry", "kg m^2", "std", "relative std", "95% interval"],
            [[k, f"{v:{VALUE}}", f"{std[k]:.2g}",
              f"{std[k] / abs(v):.1e}" if v else "-", _interval(v, std[k])]
             for k, v in tensor.items()],
        ),
    ]
    moments = result.get("principal_moments")
    if moments:
        moments_std = result.get("principal_moments_std") or [float("nan")] * 3
        tilt = result.get("principal_axes_tilt_std_deg") or [None] * 3
        axes = result["principal_axes"]
        parts += [
            "<h2>Principal moments and axes</h2>",
            _table(
                ["", "kg m^2", "std", "95% interval", "axis (x, y, z)", "axis tilt std, deg"],
                [[f"I{i + 1}", f"{m:{VALUE}}", f"{s:.2g}", _interval(m, s),
                  "(" + ", ".join(f"{c:+.6f}" for c in a) + ")",
                  "not defined (equal moments)" if t is None else f"{t:.2g}"]
                 for i, (m, s, a, t) in enumerate(zip(moments, moments_std, axes, tilt))],
            ),
        ]
    com = result.get("com")
    if com is not None:
        com_std = result.get("com_std") or {}
        parts += [
            "<h2>Centre of mass, mm</h2>",
            ("<p>z_c, along the shaft, does not change the potential energy on this gimbal: "
             "one mounting does not measure it.</p>"),
            _table(
                ["", "mm", "std", "95% interval"],
                [[n, f"{com[n] * 1e3:.5f}", f"{com_std.get(n, float('nan')) * 1e3:.2g}",
                  _interval(com[n] * 1e3, com_std.get(n, float("nan")) * 1e3, ".5f")]
                 for n in ("x", "y")],
            ),
        ]
    else:
        parts.append("<p>Centre of mass: not identified (device.toml gives no [body] mass).</p>")
    axes = result["axes"]
    parts += [
        f"<p>cond(V) of the node axes = {result.get('condition_number', float('nan')):.4g}</p>",
        "<h2>Axial moments</h2>",
        _table(
            ["stage", "node, deg", "J, kg m^2", "std", "node formula", "std"],
            [[a["stage"], f"{a['phi_deg']:g}", f"{a['J']:{VALUE}}", f"{a['J_std']:.2g}",
              f"{a['J_node']:{VALUE}}", f"{a['J_node_std']:.2g}"] for a in axes],
        ),
    ]
    return parts


def _budget_section(result: dict) -> list[str]:
    """The std budget by source: of the tensor's entries and of each axial moment, with a
    total row (the sources' variances add up, docs/method.md)."""
    budget = (result.get("least_squares") or {}).get("std_budget") or {}
    if not budget:
        return []
    keys = list(result["tensor"])
    axes = result["axes"]
    entry_total = [math.sqrt(sum(part["tensor_std"][k] ** 2 for part in budget.values()))
                   for k in keys]
    axis_total = [math.sqrt(sum(part["axes_J_std"][i] ** 2 for part in budget.values()))
                  for i in range(len(axes))]
    return [
        "<h2>Uncertainty budget: std by source, kg m^2</h2>",
        "<h3>Tensor entries</h3>",
        _table(
            ["source", *keys],
            [[source, *(f"{part['tensor_std'][k]:.2g}" for k in keys)]
             for source, part in budget.items()],
            ["total", *(f"{v:.2g}" for v in entry_total)],
        ),
        "<h3>Axial moments</h3>",
        _table(
            ["source", *(f"stage {a['stage']}, node {a['phi_deg']:g} deg" for a in axes)],
            [[source, *(f"{v:.2g}" for v in part["axes_J_std"])]
             for source, part in budget.items()],
            ["total", *(f"{v:.2g}" for v in axis_total)],
        ),
    ]


def _labels(key: str, count: int) -> list[str]:
    """Names of the numbers of calibration ``key`` (docs/files.md, result.json calibration)."""
    if key == "drive_gains":
        return ["h_d (motor drives the body)", "h_b (body drives the motor)"]
    if key == "fixture_gravity":
        return ["m g x_c of the fixture, N m", "m g y_c of the fixture, N m"]
    if key == "encoder_error":
        return [f"{'cs'[i % 2]}_{i // 2 + 1} of the encoder error, rad" for i in range(count)]
    if key == "encoder_zero":
        return ["encoder zero offset, rad"]
    if count == 1:
        return [key.replace("_", " ")]
    return [f"{key}[{i}]" for i in range(count)]


def _sentence(text: str) -> str:
    """``text`` with its first letter capitalised."""
    return text[:1].upper() + text[1:]


def _calibration_section(result: dict) -> list[str]:
    calibration = result.get("calibration")
    if not calibration:
        return ["<h2>Calibration</h2>",
                ("<p>None applied: device.toml's tares, a torque gain of 1, a lossless drive "
                 "and the stated encoder error, taken as exact; the rig's conventions (the "
                 "gear's sense, phi's handedness, the encoder's zero) were not verified: "
                 "calibrate with a reference mounted turned verifies them.</p>")]
    refined = calibration.get("refined") or {}
    rows = []
    for key, value in calibration.items():
        if key.endswith("_std") or key in ("refined", "conventions"):
            continue
        std = calibration.get(f"{key}_std")
        after, after_std = refined.get(key), refined.get(f"{key}_std")
        if key == "empty_inertia":  # per stage, the harmonics of M_empty(phi)
            for k, (harmonics, stds) in enumerate(zip(value, std or [[None] * 5] * len(value))):
                rows += [[f"stage {k + 1} empty system {name}, kg m^2", f"{v:{VALUE}}",
                          "-" if s is None else f"{s:.2g}", "", ""]
                         for name, v, s in zip(HARMONIC_NAMES, harmonics, stds)]
            continue
        values = value if isinstance(value, list) else [value]
        stds = std if isinstance(std, list) else [std] * len(values)
        afters = after if isinstance(after, list) else [after] * len(values)
        after_stds = after_std if isinstance(after_std, list) else [after_std] * len(values)
        names = _labels(key, len(values))
        for name, v, s, a, a_s in zip(names, values, stds, afters, after_stds):
            rows.append([name, f"{v:{VALUE}}", "-" if s is None else f"{s:.2g}",
                         "" if a is None else f"{a:{VALUE}}", "" if a_s is None else f"{a_s:.2g}"])
    return [
        "<h2>Calibration</h2>",
        ("<p>What identify took as known, with its std (calibration.toml, or device.toml's "
         "stated stds); where the body's own runs refine a term, its value after them.</p>"),
        _table(["quantity", "calibration", "std", "after the runs", "std"], rows),
        *([f"<p>{html.escape(_sentence(calibration['conventions']))}.</p>"]
          if calibration.get("conventions") else []),
    ]


def _run_rows(exp: Experiment) -> list[list[str]]:
    """Each run as logged: its release angle (the braking log's first angle), launch speed
    (the smoothed speed there), turns braked and the passes' durations."""

    device, rows = exp.device, []
    for stage, direction in runs(device):
        braking_path, reverse_path = exp.braking_path(stage, direction), exp.reverse_path(
            stage, direction)
        if not braking_path.is_file():
            rows.append([stage, direction, "no log", "", "", "", ""])
            continue
        braking = read_device_log(braking_path, device, "braking", direction)
        omega0 = float(smooth_log(braking, device.encoder.quantum).omega[0])
        reverse_s = "no log"
        if reverse_path.is_file():
            reverse = read_device_log(reverse_path, device, "reverse", direction)
            reverse_s = f"{reverse.t[-1] - reverse.t[0]:.2f}"
        rows.append([
            stage, direction, f"{math.degrees(braking.phi[0]):.2f}", f"{omega0:.3f}",
            f"{abs(braking.phi[-1] - braking.phi[0]) / (2 * math.pi):.1f}",
            f"{braking.t[-1] - braking.t[0]:.2f}", reverse_s,
        ])
    return rows


def _protocol_section(exp: Experiment) -> list[str]:
    def stated(value, digits="g"):
        return "not set" if value is None else f"{value:{digits}}"

    stages = exp.device.stages
    try:
        logged = _table(
            ["stage", "direction", "release angle, deg", "launch speed, rad/s",
             "turns braked", "braking, s", "reverse, s"],
            _run_rows(exp),
        )
    except InputError as error:  # a log changed since identify: the verdict names it
        logged = f"<p>The logs cannot be read now: {html.escape(str(error))}</p>"
    return [
        "<h2>Protocol</h2>",
        "<h3>As device.toml states it</h3>",
        _table(
            ["stage", "gear ratio", "nodes, deg", "launch speed, rad/s", "braking torque, N m",
             "release angle, deg", "directions"],
            [[k, f"{st.gear_ratio:.10g}", ", ".join(f"{n:g}" for n in st.nodes_deg),
              stated(st.launch_speed), stated(st.braking_torque),
              stated(st.release_angle_deg), ", ".join(st.directions)]
             for k, st in enumerate(stages, 1)],
        ),
        "<h3>As the logs ran it</h3>",
        ("<p>Release angle: the braking log's first angle (for a backward run, where the "
         "mirror releases); launch speed: the smoothed speed there.</p>"),
        logged,
    ]


def _figures(exp: Experiment, result: dict) -> list[str]:

    pictures = [(name, (exp.root / name).read_bytes(), f"{name} (from the folder)")
                for name in FIGURES if (exp.root / name).is_file()]
    try:
        pictures += [(name, figure_png(fig), f"{name} (drawn from the logs)")
                     for name, fig in experiment_figures(exp)]
    except InputError:  # said under the protocol, and in the verdict
        pass
    pictures.append(("differences.png", figure_png(difference_figure(result)),
                     "each method against the least squares (drawn from result.json)"))
    parts = ["<h2>Figures</h2>"]
    for name, data, caption in pictures:
        encoded = base64.b64encode(data).decode("ascii")
        parts.append(
            f"<figure><img alt='{html.escape(name)}' src='data:image/png;base64,{encoded}'>"
            f"<figcaption>{html.escape(caption)}</figcaption></figure>"
        )
    return parts


def _provenance_sections(result: dict, status: dict[str, str] | None) -> list[str]:
    provenance = result.get("provenance") or {}
    recorded = provenance.get("inputs") or {}
    rows = [[name, digest, status[name]] for name, digest in recorded.items()]
    software = provenance.get("software") or {}
    current = package_versions()
    return [
        "<h2>Input files (sha256 when identify read them)</h2>",
        _table(["file", "sha256", "now"], rows) if rows else "<p>Not recorded.</p>",
        "<h2>Software</h2>",
        _table(
            ["package", "made the result", "installed now"],
            [[name, software.get(name, "not recorded"), version]
             for name, version in current.items()],
        ),
    ]


def write_report(root: str | Path) -> Path:
    """Write EXP/report.html (atomically) and return its path.

    Raises
    ------
    InputError
        No result.json (run identify first), or one that is not identify's.
    """
    exp = open_experiment(root)
    result = _read_result(exp)
    out = exp.report_path
    check_writable(out)
    provenance = result.get("provenance") or {}
    status = (
        None if "inputs" not in provenance
        else input_status(exp.root, provenance["inputs"], exp.identify_inputs())
    )
    name = html.escape(exp.device.name)
    made = provenance.get("created", "at an unrecorded time")
    version = (provenance.get("software") or {}).get("rsp-inertia", "an unrecorded version")
    written = created_now()
    parts = [
        f"<h1>rsp-inertia report: {name}</h1>",
        (f"<p class='meta'>Experiment folder <code>{html.escape(str(exp.root))}</code>. "
         f"Result made {html.escape(made)} by rsp-inertia {html.escape(version)} (identify); "
         f"report written {html.escape(written)}.</p>"),
        _verdict(exp, result, status),
        *_tensor_sections(result),
        *_budget_section(result),
        *_calibration_section(result),
        *_protocol_section(exp),
        *_figures(exp, result),
        *_provenance_sections(result, status),
    ]
    page = (
        "<!DOCTYPE html><html><head><meta charset='utf-8'>"
        f"<title>rsp-inertia report: {name} ({written[:10]})</title>"
        f"<style>{STYLE}</style></head><body>\n" + "\n".join(parts) + "\n</body></html>\n"
    )
    write_atomic(out, page)
    return out

