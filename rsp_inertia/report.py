"""``rsp-inertia report``: EXP/report.html, one self-contained file for a test report.

Built from what identify wrote (result.json) and what the experiment holds. It leads with a
verdict: whether the inputs are still those identify read (result.json's provenance, checked
against the folder), and identify's warnings. Then the tensor, its principal moments and
axes and the centre of mass, each with its std, its expanded uncertainty U = k std and the
interval y +- U (result.json's ``expanded_uncertainty``; what std and U mean, in JCGM 100's
words; the principal moments' Monte Carlo intervals, an axis not determined said so); the
axial moments; the
uncertainty budget by source, per stage and node, with its total; the calibration applied;
how the torque's scale was taken through the passes (:func:`_torque_scale_section`);
the protocol of every stage and the runs as logged (release angle, launch speed, turns);
the figures the logs allow (drawn from them) and those found in the folder; the input files'
sha256; the software that made the result; the signature block. Figures are inlined as
base64 PNG: the file needs no network and no other file. The report never reads virtual.toml
(the simulator's truth).

As a test report (ISO/IEC 17025 section 7.8, rsp_inertia.report_parts): a title, the report's
number (from result.json's sha256), the dates of issue and of the measurement, the lab and rig,
the method, the item, the record fields (result.json ``record``) and the part's decision
against its specification (result.json ``decision``) beside the software's verdict; the first
printed page holds the verdicts and the result. On a combine folder, the combined body's
report instead (rsp_inertia.body_report).
"""

from __future__ import annotations

import base64
import html
import json
import math
from pathlib import Path

from rsp_inertia.body_report import body_report_verdict, is_body_folder, write_body_report
from rsp_inertia.estimation.runs import runs
from rsp_inertia.estimation.smoothing import smooth_log
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import check_writable, write_atomic
from rsp_inertia.pdf import PAPERS, find_renderer, print_pdf
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
from rsp_inertia.report_parts import (
    STATEMENT,
    VALUE,
    Z95,
    decision_box,
    identification,
    page,
    record_section,
    report_number,
    signature_block,
    warning_items,
    warnings_section,
)
from rsp_inertia.report_parts import interval as _interval
from rsp_inertia.report_parts import table as _table

__all__ = [
    "FIGURES",
    "PDF_FILE",
    "REPORT_FILE",
    "VALUE",
    "Z95",
    "figure_rows",
    "report_verdict",
    "verdict_level",
    "write_report",
]

PDF_FILE = "report.pdf"
"""``report --pdf``'s print of report.html, beside it."""

FIGURES = (PLAN_FIGURE, AXIS_DESIGN_FIGURE, ENCODER_FIGURE, ERRORS_FIGURE)
"""Figures of other commands inlined when present (plan, design or demo, calibrate, demo);
the motion and tracking figures are drawn from the logs (rsp_inertia.plots.experiment_figures)."""

def _interval_U(value: float, U: float, digits: str = VALUE) -> str:
    """The interval ``[value - U, value + U]`` of an expanded uncertainty U."""
    return f"[{value - U:{digits}}, {value + U:{digits}}]"


def _principal_section(stated: dict, moments, moments_std, axes, tilt_std) -> list[str]:
    """The principal moments with their Monte Carlo intervals and U (the linearised U beside
    them), the axes with their tilt at the coverage probability, or "not determined"."""
    p = f"{100 * stated['coverage_probability']:.2f} %"
    determined = stated["principal_axes_determined"]
    rows = []
    for i, (m, s, a) in enumerate(zip(moments, moments_std, axes)):
        low, high = stated["principal_moments_interval"][i]
        tilt = stated["principal_axes_tilt_deg"][i]
        rows.append([
            f"I{i + 1}", f"{m:{VALUE}}", f"{s:.2g}", f"{stated['principal_moments'][i]:.2g}",
            f"{stated['linearised']['principal_moments'][i]:.2g}",
            f"[{low:{VALUE}}, {high:{VALUE}}]",
            "(" + ", ".join(f"{c:+.6f}" for c in a) + ")",
            f"{tilt:.2g}" if determined[i] and tilt is not None
            else "not determined (moment within 3 stds of another)",
        ])
    return [
        "<h2>Principal moments and axes</h2>",
        _table(
            ["", "kg m^2", "std", "U (Monte Carlo)", "U (linearised)",
             f"interval ({p}, Monte Carlo)", "axis (x, y, z)", f"axis tilt ({p}), deg"],
            rows,
        ),
    ]


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
    items, level = [], verdict_level(result, status)
    integrity = integrity_state(result)
    if integrity == "edited":
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
            items.append(
                "<p><b>The inputs changed since identify made this result</b>: the numbers "
                "below describe the files as they were, not as they are. Run "
                f"<code>rsp-inertia identify {html.escape(str(exp.root))}</code> again.</p>"
            )
            items.append("<ul>" + "".join(f"<li>{html.escape(c)}</li>" for c in changes)
                         + "</ul>")
    else:
        items.append(
            "<p><b>result.json records no provenance</b> (made by an older rsp-inertia): "
            "whether the folder still holds the inputs it was made from cannot be checked. "
            "Run identify again.</p>"
        )
    if warnings:
        items.append(
            f"<p><b>{len(warnings)} warning{'s' if len(warnings) > 1 else ''}</b>: each says "
            "what may move the result beyond its stds; read them before using the numbers.</p>"
        )
        items.append(warning_items(warnings))
    else:
        items.append("<p><b>No warnings</b>: identify found nothing questionable.</p>")
    due = (result.get("record") or {}).get("calibration") or {}
    if due.get("overdue"):
        items.append(
            f"<p><b>The calibration was overdue</b>: made {html.escape(str(due.get('date')))}, "
            f"due {html.escape(str(due.get('due')))}.</p>"
        )
    title = {"ok": "Verdict: no warnings", "warn": "Verdict: read the warnings",
             "stale": "Verdict: do not use as it stands"}[level]
    return f"<div class='verdict {level}'><h2>{title}</h2>" + "".join(items) + "</div>"


def verdict_level(result: dict, status: dict[str, str] | None) -> str:
    """The colour of the report's verdict: 'stale' (red) when result.json was edited after
    it was written (rsp_inertia.provenance.integrity_state) or the inputs changed since
    identify or cannot be checked (``status`` None), else 'warn' (amber) when result.json
    has a warning or an overdue calibration, else 'ok' (green).

    Parameters
    ----------
    result : dict
        result.json's document.
    status : dict or None
        Each recorded input's status now (rsp_inertia.provenance.input_status); None when
        result.json records no inputs.

    Returns
    -------
    str
        'ok', 'warn' or 'stale'.
    """
    if integrity_state(result) == "edited" or status is None or input_changes(status):
        return "stale"
    due = (result.get("record") or {}).get("calibration") or {}
    return "warn" if result.get("warnings") or due.get("overdue") else "ok"


def report_verdict(root: str | Path) -> tuple[str, str | None]:
    """The verdicts a report of ``root`` leads with, without writing it: the software's
    (:func:`verdict_level`) and the part's against spec.toml (None without one).

    Parameters
    ----------
    root : str or pathlib.Path
        The experiment folder, with its result.json; or a combine folder, with its body.json
        (rsp_inertia.body_report.body_report_verdict; no part verdict).

    Returns
    -------
    (str, str or None)
        'ok', 'warn' or 'stale'; 'pass', 'fail', 'indeterminate' or None.

    Raises
    ------
    InputError
        No result.json, or one that identify did not write.
    """
    if is_body_folder(root):
        return body_report_verdict(root), None
    exp = open_experiment(root)
    result = _read_result(exp)
    decision = result.get("decision") or {}
    return verdict_level(result, _input_status(exp, result)), decision.get("part")


def _input_status(exp: Experiment, result: dict) -> dict[str, str] | None:
    """Each input result.json records, as the folder holds it now
    (rsp_inertia.provenance.input_status); None when it records none."""
    provenance = result.get("provenance") or {}
    if "inputs" not in provenance:
        return None
    return input_status(exp.root, provenance["inputs"], exp.identify_inputs())


def _expanded(result: dict) -> dict | None:
    """result.json's GUM statement ``expanded_uncertainty`` (None: a result.json of an older
    rsp-inertia, which the report states with +- Z95 std)."""
    stated = result.get("expanded_uncertainty")
    return stated if isinstance(stated, dict) and "k" in stated else None


def _gum_paragraph(stated: dict) -> str:
    """What std and U mean, in the words of JCGM 100 (and how the principal moments' and
    axes' intervals were obtained)."""
    k, p = stated["k"], 100 * stated["coverage_probability"]
    mc = stated["monte_carlo"]
    return (
        "<p><b>std</b> is the standard uncertainty u: the standard deviation of the values "
        "that could reasonably be attributed to the quantity (JCGM 100 §2.3.1). <b>U = k u</b> "
        f"with k = {k:g} is the expanded uncertainty: the interval y &plusmn; U is expected to "
        f"contain about {p:.2f} % of those values (the coverage probability of k = {k:g} for a "
        "normal distribution; JCGM 100 §6). The principal moments and axes, nonlinear in the "
        "tensor, have their intervals from a Monte Carlo of the entries' joint distribution "
        f"(JCGM 101: {mc['draws']} draws, seed {mc['seed']}"
        + ("" if mc["converged"] else ", not stabilised")
        + "); the first-order (linearised) U is given beside them.</p>"
    )


def _tensor_sections(result: dict) -> list[str]:
    tensor, std = result["tensor"], result["tensor_std"]
    stated = _expanded(result)
    if stated is None:
        interval_head, U, U_head = "95% interval", {}, "U"
        gum = []
    else:
        interval_head = f"interval y +- U ({100 * stated['coverage_probability']:.2f} %)"
        U = stated["tensor"]
        U_head = f"U (k = {stated['k']:g})"
        gum = [_gum_paragraph(stated)]
    parts = [
        "<h2>Inertia tensor (least squares), kg m^2</h2>",
        ("<p>In the rig's axes: z along the shaft, x and y as at phi = 0. Products are the "
         "tensor's entries (Jxy = -integral of x y dm).</p>"),
        *gum,
        _table(
            ["entry", "kg m^2", "std", *([U_head] if U else []), "relative std", interval_head],
            [[k, f"{v:{VALUE}}", f"{std[k]:.2g}", *([f"{U[k]:.2g}"] if U else []),
              f"{std[k] / abs(v):.1e}" if v else "-",
              _interval_U(v, U[k]) if U else _interval(v, std[k])]
             for k, v in tensor.items()],
        ),
    ]
    moments = result.get("principal_moments")
    if moments:
        moments_std = result.get("principal_moments_std") or [float("nan")] * 3
        tilt = result.get("principal_axes_tilt_std_deg") or [None] * 3
        axes = result["principal_axes"]
        if stated is None:
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
        else:
            parts += _principal_section(stated, moments, moments_std, axes, tilt)
    com = result.get("com")
    if com is not None:
        com_std = result.get("com_std") or {}
        com_U = (stated or {}).get("com") or {}
        parts += [
            "<h2>Centre of mass, mm</h2>",
            ("<p>z_c, along the shaft, does not change the potential energy on this gimbal: "
             "one mounting does not measure it.</p>"),
            _table(
                ["", "mm", "std", *([U_head] if com_U else []),
                 interval_head if com_U else "95% interval"],
                [[n, f"{com[n] * 1e3:.5f}", f"{com_std.get(n, float('nan')) * 1e3:.2g}",
                  *([f"{com_U[n] * 1e3:.2g}"] if com_U else []),
                  _interval_U(com[n] * 1e3, com_U[n] * 1e3, ".5f") if com_U
                  else _interval(com[n] * 1e3, com_std.get(n, float("nan")) * 1e3, ".5f")]
                 for n in ("x", "y")],
            ),
        ]
    else:
        parts.append("<p>Centre of mass: not identified (device.toml gives no [body] mass).</p>")
    return parts


def _axes_section(result: dict) -> list[str]:
    axes = result["axes"]
    return [
        "<h2>Axial moments</h2>",
        (f"<p>cond(V) of the node axes = {result.get('condition_number', float('nan')):.4g}"
         "</p>" + _table(
            ["stage", "node, deg", "J, kg m^2", "std", "node formula", "std"],
            [[a["stage"], f"{a['phi_deg']:g}", f"{a['J']:{VALUE}}", f"{a['J_std']:.2g}",
              f"{a['J_node']:{VALUE}}", f"{a['J_node_std']:.2g}"] for a in axes],
        )),
    ]


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


def _torque_scale_section(exp: Experiment, result: dict) -> list[str]:
    """How the torque's scale was taken through the passes: the temperature's compensation,
    the warming motor's coefficient, the two-level runs' pass gains, the drift's stated std
    (result.json, device.toml ``[motor]``); nothing when none applies."""
    motor = exp.device.motor
    least = result.get("least_squares") or {}
    lines = []
    compensation = result.get("temperature_compensation") or {}
    if compensation.get("compensated"):
        std = compensation.get("tempco_std")
        lines.append(
            f"Compensated for the magnets' temperature: tempco {compensation['tempco']:.4g} "
            + ("(exact)" if std is None else f"+- {std:.2g}")
            + f" /K from {compensation['source']}"
            + (
                ""
                if motor.reference_temperature is None  # device.toml changed since identify
                else f", reference temperature {motor.reference_temperature:g} C, the magnets "
                + ("at the logged temperature" if motor.temperature_lag is None
                   else f"{motor.temperature_lag:g} s behind it")
            )
            + "."
        )
    warming = least.get("warming") or {}
    if warming.get("fitted"):
        drifts = ", ".join(
            f"{d['run']} {d['value']:+.2g} +- {d['std']:.1g}" for d in warming["drift"]
        )
        taus = (
            ""
            if motor.winding_time_constant is None  # device.toml changed since identify
            else f" (winding {motor.winding_time_constant:g} s, magnets "
            f"{motor.temperature_lag or 0:g} s behind)"
        )
        lines.append(
            f"Warming motor modelled{taus}: c = {warming['coefficient']:.4g} +- "
            f"{warming['std']:.2g} /(N^2 m^2); the torque's scale from the braking to the "
            f"reverse pass: {drifts}."
        )
    gains = [g for g in least.get("pass_gain") or [] if g.get("fitted")]
    if gains:
        lines.append(
            "Pass gains fitted (two-level brakings): "
            + ", ".join(f"{g['run']} {g['value']:+.2g} +- {g['std']:.1g}" for g in gains)
            + "."
        )
    if motor.torque_constant_drift_std:
        lines.append(
            f"A drift of the torque's scale between the passes stated as "
            f"{motor.torque_constant_drift_std:g} (relative std per run), in the budget."
        )
    if not lines:
        return []
    return ["<h2>Torque scale through the passes</h2>",
            *(f"<p>{html.escape(line)}</p>" for line in lines)]


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
              stated(st.launch_speed),
              stated(st.braking_torque) + (
                  "" if st.braking_torque_2 is None
                  else f", then {st.braking_torque_2:g} after {st.braking_switch_turns:g} turns"
              ),
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
    return ["<h2>Figures</h2>", *figure_rows(pictures)]


def figure_rows(pictures: list[tuple[str, bytes, str]]) -> list[str]:
    """The figures inlined (base64 PNG), two to a row (printed side by side, a row never split
    across pages).

    Parameters
    ----------
    pictures : list of (str, bytes, str)
        Each figure's name, PNG bytes and caption.

    Returns
    -------
    list of str
        One HTML part per row.
    """
    figures = []
    for name, data, caption in pictures:
        encoded = base64.b64encode(data).decode("ascii")
        figures.append(
            f"<figure><img alt='{html.escape(name)}' src='data:image/png;base64,{encoded}'>"
            f"<figcaption>{html.escape(caption)}</figcaption></figure>"
        )
    return ["<div class='figures keep'>" + "".join(figures[i : i + 2]) + "</div>"
            for i in range(0, len(figures), 2)]


def _provenance_sections(result: dict, status: dict[str, str] | None) -> list[str]:
    provenance = result.get("provenance") or {}
    recorded = provenance.get("inputs") or {}
    rows = [[name, digest, status[name]] for name, digest in recorded.items()]
    software = provenance.get("software") or {}
    current = package_versions()
    return [
        "<h2>Input files (sha256 when identify read them)</h2>",
        _table(["file", "sha256", "now"], rows, kind="long hashes") if rows
        else "<p>Not recorded.</p>",
        "<h2>Software</h2>",
        _table(
            ["package", "made the result", "installed now"],
            [[name, software.get(name, "not recorded"), version]
             for name, version in current.items()],
        ),
    ]


def _identification(exp: Experiment, result: dict, number: str, written: str) -> str:
    """The test report's identification (ISO/IEC 17025 section 7.8.2.1)."""
    provenance = result.get("provenance") or {}
    record = result.get("record") or {}
    made = provenance.get("created", "not recorded")
    version = (provenance.get("software") or {}).get("rsp-inertia", "an unrecorded version")
    item = ", ".join(f"{label} {record[key]}" for label, key in
                     (("part", "part_id"), ("serial", "serial")) if record.get(key))
    rig = exp.device.name + (f" (asset {record['asset_id']})" if record.get("asset_id") else "")
    return identification([
        ("report number", number),
        ("date of issue", written),
        ("item tested", item or "the body mounted in device.toml's [body] (part and serial "
                                "not recorded)"),
        ("laboratory and rig", rig),
        ("method", (f"reverse semi-program motion (RSP), rsp-inertia {version} identify "
                   "(docs/method.md)")),
        ("date of the measurement", str(record.get("date") or
                                        f"not recorded; identify ran {made}")),
        ("experiment folder", str(exp.root)),
        ("operator", str(record.get("operator") or "not recorded")),
    ])


def write_report(root: str | Path, pdf: bool = False, paper: str = "a4") -> Path:
    """Write EXP/report.html (atomically) and return its path; on a combine folder (OUT with
    body.json and no device.toml) the combined body's report, OUT/report.html
    (rsp_inertia.body_report). With ``pdf``, also its print, report.pdf beside it
    (rsp_inertia.pdf.print_pdf).

    Parameters
    ----------
    root : str or pathlib.Path
        The experiment folder (with result.json) or the combine folder (with body.json).
    pdf : bool, optional
        Also print report.pdf (needs Chromium; its absence is found before anything is
        written).
    paper : str, optional
        The PDF's paper, ``"a4"`` (default) or ``"letter"``.

    Returns
    -------
    pathlib.Path
        The report.html written.

    Raises
    ------
    InputError
        No result.json (run identify first), or one that is not identify's; no body.json on a
        combine folder; with ``pdf``, no Chromium, an unknown paper or an unwritable PDF.
    """
    browser = None
    if pdf:
        if paper not in PAPERS:
            raise InputError(f"--paper {paper}: not one of {', '.join(PAPERS)}")
        browser = find_renderer()
        if Path(root).is_dir():
            check_writable(Path(root) / PDF_FILE)
    if is_body_folder(root):
        out = write_body_report(root)
    else:
        out = _write_experiment_report(root)
    if pdf:
        print_pdf(out, out.with_name(PDF_FILE), paper, browser)
    return out


def _write_experiment_report(root: str | Path) -> Path:
    """EXP/report.html (:func:`write_report`)."""
    exp = open_experiment(root)
    result = _read_result(exp)
    out = exp.report_path
    check_writable(out)
    status = _input_status(exp, result)
    name = exp.device.name
    written = created_now()
    number = report_number("RSP", exp.result_path.read_bytes())
    record = result.get("record") or {}
    parts = [
        f"<h1>Test report: inertia tensor of {html.escape(name)}</h1>",
        _identification(exp, result, number, written),
        ("<div class='boxes'>" + _verdict(exp, result, status)
         + decision_box(result.get("decision")) + "</div>"),
        *_tensor_sections(result),
        f"<p class='statement'>{html.escape(STATEMENT)}</p>",
        *warnings_section(result.get("warnings") or []),
        *record_section({"result.json": result.get("record")}),
        *_axes_section(result),
        *_budget_section(result),
        *_calibration_section(result),
        *_torque_scale_section(exp, result),
        *_protocol_section(exp),
        *_figures(exp, result),
        *_provenance_sections(result, status),
        signature_block(record.get("operator")),
    ]
    write_atomic(out, page(f"Test report {number}: {name} ({written[:10]})", number, parts))
    return out
