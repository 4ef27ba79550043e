"""``rsp-inertia check``: an experiment folder checked before a run, one line per finding.

Reads what a rig produces (device.toml, the logs, calibration.toml, reference.toml), never
virtual.toml, and reports for every stage and direction of rotation what is there, what is
missing for the next step and what looks wrong, without stopping at the first problem:

- ``error``: what identify (or calibrate, on a calibration folder) would refuse, with its own
  message, found by identify's own checks, everything short of the fit: the logs read by its
  reader (rsp_inertia.estimation.reading.read_run), each run's passes smoothed and checked
  (rsp_inertia.estimation.runs.checked_run: a braking whose speed reverses, passes that share
  too few turns at useful speed, naming the log at fault, a gap of dropped samples near a
  node too long for the smoother to bridge, with the size it would bridge), the pendulum
  runs reduced (rsp_inertia.estimation.identify.reduce_pendulum_run), the axis design
  (rsp_inertia.estimation.identify.checked_design) and calibration.toml.
- ``missing``: what identify needs and does not find (a braking or reverse log), with the
  command that makes it.
- ``suspicious``: what identify accepts but a test engineer would want to know before the
  run: a braking that covers few turns past its last node, a logged braking torque that is
  not device.toml's, a glitch the reader left out (rsp_inertia.plant.log_glitches: a row
  whose angle or torque disagrees with its neighbours), what identify warns about a run's
  passes (a braking torque that is not constant within its noise), a program older than the braking it mirrors, a reverse much
  shorter or longer than its braking, constants that identify will take as exact and warn
  about, a gap of dropped samples near a node too long to bridge in a log check cannot pair
  with its run's other (identify refuses it if the node's passage is in the range it
  balances), a program whose
  regulator the encoder holds too slow to follow the braking's speed harmonics (a coarse
  encoder: the closed loop then tracks on its feedforward alone, and identify's stds grow),
  a program the drive could not run again (its time step not device.toml's sample rate)
  whose reverse log is there (identify never reads program.csv; an ``error`` while the
  reverse is still to run).
- record.toml and spec.toml as identify reads them (``error`` where it would refuse them;
  ``ok`` naming the part, the limits and the rule), and a calibration past its due date
  today (``suspicious``, as identify warns).
- ``ok``: what is in place, and a gap of dropped samples near a node that identify bridges,
  with the share of the balance's speed std it adds there
  (rsp_inertia.estimation.balance.NodeGap).

The folder is ready for identify when no line is ``error`` or ``missing``. A calibration
folder (``calibration=True``, or one with reference.toml) is checked alike, but is ready for
calibrate, and needs no calibration.toml or stated stds (calibrate measures those).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rsp_inertia.estimation.balance import (
    NodeGap,
    check_node_gaps,
    harmonic_reach,
)
from rsp_inertia.estimation.calibration_file import CalibrationFile
from rsp_inertia.estimation.decision import check_quantities, result_quantities
from rsp_inertia.estimation.identify import (
    checked_design,
    pendulum_settings,
    reduce_pendulum_run,
)
from rsp_inertia.estimation.reading import (
    known_terms,
    read_calibration,
    read_run,
    tempco_in_use,
)
from rsp_inertia.estimation.records import experiment_record
from rsp_inertia.estimation.runs import checked_run
from rsp_inertia.estimation.smoothing import top_speed
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.config import Device, load_reference, require_protocol
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.experiment import Experiment, open_experiment
from rsp_inertia.plant.geometry import turns_past_last_node
from rsp_inertia.plant.log_checks import unterminated_last_line
from rsp_inertia.plant.log_files import log_rows
from rsp_inertia.plant.logs import (
    Log,
    check_braking_monotone,
    dropped_samples,
    mirror_log,
    read_device_log,
    read_program,
)
from rsp_inertia.plant.record_config import load_spec
from rsp_inertia.provenance import created_now
from rsp_inertia.results.check import CheckResult

__all__ = ["MIN_TURNS_PAST_LAST_NODE", "check"]

Findings = list[tuple[str, str]]
"""The findings so far, ``(level, message)`` in the order made (rsp_inertia.results.LEVELS)."""


def _add(findings: Findings, level: str, message: str) -> None:
    """One more finding."""
    findings.append((level, message))

MIN_TURNS_PAST_LAST_NODE = 3.0
"""Turns past the last node below which a braking is flagged: every node then has few
whole-turn pairs (identify needs at least one)."""

TORQUE_TOLERANCE = 0.05
"""Relative difference between the logged mean braking torque and device.toml's above which
the braking is flagged (a drive that did not apply the commanded torque)."""

DURATION_TOLERANCE = 0.05
"""Relative difference of a reverse's duration from its braking's above which it is flagged
(the mirror runs the braking backwards in time)."""


def check(path: str | Path, calibration: bool = False) -> CheckResult:
    """The command behind :func:`rsp_inertia.api.check`, documented there (the findings:
    this module's docstring)."""
    exp = open_experiment(path, protocol=False)  # a stage without one: a missing line
    device = exp.device
    reference = exp.reference_path
    calibration_folder = calibration or reference.is_file()
    findings: Findings = []
    _add(findings, "ok", f"{exp.device_path}: {len(device.stages)} stage(s)")
    try:
        require_protocol(device, exp.device_path)
        protocol = True
    except InputError as error:  # before plan: its pilots are what the folder needs
        _add(findings, "missing", str(error))
        protocol = False
    try:
        checked_design(device, str(exp.device_path))
    except InputError as error:
        _add(findings, "error", str(error))
    # calibration.toml, read once: the encoder's error that identify takes off every reading,
    # and what _check_constants reports
    try:
        calibrated = read_calibration(exp)
        known, known_warnings = known_terms(exp, calibrated)
        encoder, fault = (known.encoder, known.zero), None
    except InputError as error:
        calibrated, known_warnings = None, []
        encoder, fault = ((), 0.0), str(error)  # a bad calibration.toml: its own line (_check_constants)
    # The tempco identify compensates with: calibration.toml's where calibrate measured it.
    tempco = tempco_in_use(exp, calibrated)[0]
    for stage, st in enumerate(device.stages, 1):
        for direction in st.directions if protocol else ():
            _check_run(exp, stage, direction, encoder, findings, tempco)
        if exp.pilot_path(stage).is_file():
            _try_read(findings, exp.pilot_path(stage), device, "pilot")
    _check_pendulum(exp, encoder, findings)
    _check_constants(exp, findings, calibration_folder, calibrated, known_warnings, fault)
    if reference.is_file():
        try:
            certified = load_reference(reference)
        except InputError as error:
            _add(findings, "error", str(error))
        else:
            named = certified.certificate
            which = "" if named is None else f" (certificate {named.id})"
            if certified.stated:
                _add(findings, "ok", f"{reference}: the reference body's data and stds{which}")
            else:
                _add(
                    findings, "suspicious",
                    f"{reference}: the reference body's data{which} without stds: the "
                    "certificate's uncertainty would be left out of every std (state "
                    "body.mass_std, body.inertia_std or body.inertia_cov, body.com_std)",
                )
    _check_records(exp, calibrated, findings)
    return CheckResult(tuple(findings), exp.root, calibration_folder)


def _check_records(
    exp: Experiment, calibrated: CalibrationFile | None, findings: Findings
) -> None:
    """record.toml and spec.toml as identify will read them (an error where it would refuse
    them), and a calibration past its due date today (identify's warning: suspicious)."""
    try:
        record, overdue = experiment_record(exp, calibrated, created_now())
    except InputError as error:
        _add(findings, "error", str(error))
    else:
        if exp.record_path.is_file():
            _add(findings, "ok", f"{exp.record_path}: the record (part {record.part_id})")
        for warning in overdue:
            _add(findings, "suspicious", warning)
    if exp.spec_path.is_file():
        try:
            spec = load_spec(exp.spec_path)
            check_quantities(
                spec, result_quantities(exp.device.body is not None), str(exp.spec_path)
            )
            _add(findings, "ok", f"{exp.spec_path}: {len(spec.limits())} limit(s), "
                 f"{spec.decision.rule.value} rule")
        except InputError as error:
            _add(findings, "error", str(error))


def _try_read(
    findings: Findings,
    path: Path,
    device: Device,
    kind: str,
    direction: Direction = Direction.FORWARD,
) -> Log | None:
    """The log read as identify reads it (the device's encoder and torque limit), or None
    with an ``error`` line; a ``suspicious`` line when its last line has no line end (the
    reader leaves it out) and per glitch the reader left out, an ``ok`` line per note of the
    reader (a braking's rows after its turning point left out)."""
    try:
        log = read_device_log(path, device, kind, direction)
    except InputError as error:
        _add(findings, "error", str(error))
        return None
    _check_last_line(findings, path, log)
    return log


def _check_last_line(findings: Findings, path: Path, log: Log) -> None:
    """A ``suspicious`` line when a CSV log's last line has no line end (the reader leaves it
    out) and per warning of the reader (rsp_inertia.plant.logs.Log.warnings: a glitch left
    out); an ``ok`` line per note of the reader (rsp_inertia.plant.logs.Log.notes: a braking
    cut at its turning point; identify warns about both in the same words), and one with the
    motor temperature's range over the pass when the logger logs it."""
    for note in log.notes:
        _add(findings, "ok", note)
    for warning in log.warnings:
        _add(findings, "suspicious", warning)
    if log.temperature is not None:
        low, high = float(np.min(log.temperature)), float(np.max(log.temperature))
        _add(findings, "ok", f"{path}: motor temperature {low:.1f} to {high:.1f} C")
    if path.suffix == ".csv" and unterminated_last_line(path):
        _add(
            findings,
            "suspicious",
            f"{path}: its last line has no line end (a logger stopped while writing it?): "
            "identify leaves that row out",
        )


def _check_timing(
    exp: Experiment,
    stage: int,
    direction: Direction,
    path: Path,
    log,
    findings: Findings,
    nodes: bool,
) -> None:
    """A log's sampling: dropped samples and jitter (a line when there are any); with
    ``nodes``, a gap near a node too long to bridge that identify would refuse
    (rsp_inertia.estimation.balance.check_node_gaps, its other pass taken as this one's
    mirror), ``suspicious``: for a log that check cannot pair with its run's other log, whose
    range identify balances is unknown (a paired run's gaps are checked in that range, by
    checked_run)."""
    rate = exp.device.encoder.sample_rate
    periods = np.diff(log.t) * rate
    missing = dropped_samples(log.t, rate)
    jitter = float(np.max(np.abs(periods - np.rint(periods)))) if periods.size else 0.0
    if missing.any() or jitter > 1e-6:
        gaps = int(np.count_nonzero(missing))
        _add(
            findings,
            "ok",
            f"{path}: {int(missing.sum())} sample(s) dropped in {gaps} gap(s) (longest "
            f"{int(missing.max())}); time steps off whole periods by up to {jitter:.2f} of a "
            "period",
        )
    if not nodes or not missing.any():
        return
    q = exp.device.encoder.quantum
    forward = log if direction is Direction.FORWARD else mirror_log(log, q)
    try:
        check_node_gaps(
            exp.device, stage, forward, str(path), direction=direction.sign, dropped=missing
        )
    except InputError as error:
        _add(
            findings,
            "suspicious",
            f"{error} (identify refuses it if that passage is in the range it balances)",
        )


def _check_run(
    exp: Experiment,
    stage: int,
    direction: Direction,
    encoder,
    findings: Findings,
    tempco: float | None = None,
) -> None:
    """One stage in one direction: braking, program, reverse. The two logs are read as
    identify reads them (rsp_inertia.estimation.reading.read_run; each alone, to say which
    and why, when that fails) and checked as identify checks them before its fit
    (rsp_inertia.estimation.runs.checked_run, with ``encoder``: the encoder's error
    coefficients and zero offset; ``tempco``: the tempco identify compensates with,
    rsp_inertia.estimation.reading.tempco_in_use)."""
    device = exp.device
    run = f"stage {stage} {direction}"
    option = "" if direction is Direction.FORWARD else f" --direction {direction}"
    b_path = exp.braking_path(stage, direction)
    p_path = exp.program_path(stage, direction)
    r_path = exp.reverse_path(stage, direction)
    pair = None
    if b_path.is_file() and r_path.is_file():
        try:
            pair = read_run(exp, stage, direction, tempco)
        except InputError:
            pass  # each log read alone below says which and why
    braking, usable = None, False
    if not b_path.is_file():
        _add(
            findings,
            "missing",
            f"{b_path}: the {run} braking log (the rig's braking pass; on the virtual device "
            f"rsp-inertia simulate {exp.root} --stage {stage}{option})",
        )
    elif pair is not None:
        braking = pair[0]
        _check_last_line(findings, b_path, braking)
    else:
        braking = _try_read(findings, b_path, device, "braking", direction)
    if braking is not None:
        usable = _check_braking(exp, stage, direction, b_path, braking, findings, pair is None)
    if p_path.is_file():
        if b_path.is_file() and p_path.stat().st_mtime < b_path.stat().st_mtime:
            _add(
                findings,
                "suspicious",
                f"{p_path}: older than {b_path.name}: made from another braking? (rerun "
                f"rsp-inertia program {exp.root} --stage {stage})",
            )
        else:
            _add(findings, "ok", f"{p_path}: the torque program")
            if braking is not None:
                _check_regulator(exp, p_path, braking, findings, done=r_path.is_file())
    elif not r_path.is_file():
        _add(
            findings,
            "missing",
            f"{p_path}: no torque program for the {run} reverse pass (rsp-inertia program "
            f"{exp.root} --stage {stage})",
        )
    if not r_path.is_file():
        _add(
            findings,
            "missing",
            f"{r_path}: the {run} reverse log (the rig runs the program; on the virtual device "
            f"rsp-inertia simulate {exp.root} --stage {stage} --part reverse{option})",
        )
        return
    if pair is None:
        reverse = _try_read(findings, r_path, device, "reverse", direction)
        if reverse is None:
            return
    else:
        reverse = pair[1]
        _check_last_line(findings, r_path, reverse)
    _check_timing(exp, stage, direction, r_path, reverse, findings, nodes=pair is None)
    if pair is not None and usable:
        warnings: list[str] = []
        bridged: list[NodeGap] = []
        try:
            checked_run(
                device, stage, pair, direction, warnings, (str(b_path), str(r_path)), *encoder,
                bridged=bridged,
            )
        except InputError as error:
            _add(findings, "error", str(error))
            return
        for warning in warnings:
            _add(findings, "suspicious", warning)
        for gap in bridged:
            _add(findings, "ok", gap.line())
    duration = float(reverse.t[-1] - reverse.t[0])
    if braking is not None:
        b_duration = float(braking.t[-1] - braking.t[0])
        if not math.isclose(duration, b_duration, rel_tol=DURATION_TOLERANCE):
            _add(
                findings,
                "suspicious",
                f"{r_path}: {duration:.2f} s against the braking's {b_duration:.2f} s: the "
                "reverse should mirror the braking (the drive stopped early or ran on?)",
            )
            return
    _add(findings, "ok", f"{r_path}: {duration:.2f} s")


def _check_braking(
    exp: Experiment,
    stage: int,
    direction: Direction,
    path: Path,
    braking: Log,
    findings: Findings,
    nodes: bool,
) -> bool:
    """A braking log's own findings: its sampling (:func:`_check_timing`, ``nodes`` as
    there), a speed that reverses (``error``), the turns it covers past its last node and its
    mean torque. Whether the run's check (checked_run) can take it: not when it reverses or
    is too short (then it counts as missing: the braking must be run again)."""
    device = exp.device
    st = device.stages[stage - 1]
    _check_timing(exp, stage, direction, path, braking, findings, nodes)
    q = device.encoder.quantum
    forward = braking if direction is Direction.FORWARD else mirror_log(braking, q)
    usable = True
    try:
        check_braking_monotone(forward, log_rows(path, device.log))
    except InputError as error:
        _add(findings, "error", str(error))
        usable = False
    turns = turns_past_last_node(braking.phi, st.nodes)
    torque = float(np.mean(np.abs(braking.torque)))
    duration = float(braking.t[-1] - braking.t[0])
    level = "ok"
    notes = []
    if turns < 1.0:
        level, usable = "missing", False
        notes.append(
            f"it covers {turns:.2f} turns past its last node: identify needs whole turns "
            "from every node (raise launch_speed or lower braking_torque; rsp-inertia plan)"
        )
    elif turns < MIN_TURNS_PAST_LAST_NODE:
        level = "suspicious"
        notes.append(f"it covers only {turns:.2f} turns past its last node (few whole-turn pairs)")
    expected = st.braking_torque
    if expected > 0 and abs(torque / expected - 1) > TORQUE_TOLERANCE:
        level = "suspicious" if level == "ok" else level
        notes.append(
            f"its mean logged torque {torque:.4g} N m is not device.toml's braking_torque "
            f"{expected:.4g} N m"
        )
    summary = f"{path}: {duration:.2f} s, {turns:.2f} turns past the last node"
    _add(findings, level, summary + ("; " + "; ".join(notes) if notes else ""))
    return usable


def _check_regulator(
    exp: Experiment, path: Path, braking: Log, findings: Findings, done: bool
) -> None:
    """``suspicious`` when the program's regulator is slower than the braking's speed
    harmonics at the balances' slowest speed: its bandwidth w from its gains (the LQR's
    k_omega = sqrt 2 k_phi / w, rsp_inertia.ocp.regulator) against 2 Omega at
    MIN_SPEED_FRACTION of the top speed, with the encoder's counts per sample there.

    A program the drive could not run (a time step that is not device.toml's sample rate) is
    an ``error`` while its reverse pass is still to run (``done`` False); once the reverse log
    is there (``done``), ``suspicious``: identify never reads program.csv, so check says ready
    where identify runs."""
    try:
        program = read_program(path, exp.device.encoder)
    except InputError as error:
        if not done:
            _add(findings, "error", str(error))
            return
        _add(
            findings,
            "suspicious",
            f"{error} (identify does not read the program: its reverse log is there; make it "
            f"again, rsp-inertia program {exp.root}, before another reverse pass)",
        )
        return
    gains = (program.k_omega > 0) & (program.k_phi > 0)
    if not np.any(gains) or len(braking) < 2:
        return
    w = float(np.median(math.sqrt(2) * program.k_phi[gains] / program.k_omega[gains]))
    reach = harmonic_reach(exp.device, w, top_speed(braking))
    if reach.follows:
        return
    _add(
        findings,
        "suspicious",
        f"{path}: its regulator's bandwidth, {w:.2g} rad/s, is below the braking's speed "
        f"harmonics (2 Omega >= {2 * reach.slowest:.2g} rad/s over the balances; "
        f"{reach.counts:.2g} encoder counts per sample there): the encoder's count holds the "
        "gains down, the reverse will track the mirror on its feedforward alone and identify's "
        "stds grow (rsp-inertia plan rehearses it; a finer encoder lifts it)",
    )


def _check_pendulum(exp: Experiment, encoder, findings: Findings) -> None:
    """The torsion-pendulum baseline's runs (optional), each read and reduced as identify
    reduces it (rsp_inertia.estimation.identify.reduce_pendulum_run, with the encoder's error
    coefficients and zero offset ``encoder``)."""
    device = exp.device
    present = [
        (stage, k)
        for stage, st in enumerate(device.stages, 1)
        for k in range(1, len(st.nodes) + 1)
        if exp.pendulum_path(stage, k).is_file()
    ]
    if present:
        try:
            pendulum_settings(device, str(exp.device_path))
        except InputError as error:
            _add(findings, "error", str(error))
            return
    elif device.pendulum is None:
        return
    found = 0
    for stage, k in present:
        path = exp.pendulum_path(stage, k)
        log = _try_read(findings, path, device, "pendulum")
        if log is None:
            continue
        try:
            reduce_pendulum_run(device, log, stage, k, str(path), *encoder)
        except InputError as error:
            _add(findings, "error", str(error))
            continue
        found += 1
    total = sum(len(st.nodes) for st in device.stages)
    level = "ok" if found in (0, total) else "suspicious"
    _add(
        findings,
        level,
        f"pendulum baseline: {found} of {total} node runs (stageN/pendulum_kK.csv; optional, "
        "its tensor needs all of them)",
    )


def _check_constants(
    exp: Experiment,
    findings: Findings,
    calibration_folder: bool,
    calibration: CalibrationFile | None,
    warnings: list[str],
    fault: str | None,
) -> None:
    """What identify will take as known: calibration.toml (``calibration``, read once by
    :func:`check`, with identify's ``warnings`` on it, or the ``fault`` that refused it), or
    device.toml's stated stds; none needed in a calibration folder."""
    device = exp.device
    path = exp.calibration_path
    if fault is not None:
        _add(findings, "error", fault)
        return
    stiffness = None if calibration is None else calibration.pendulum_stiffness()
    if calibration is not None:
        _add(findings, "ok", f"{path}: made for this device; identify applies it")
        for warning in warnings:
            _add(findings, "suspicious", warning)
    elif calibration_folder:
        _add(
            findings,
            "ok",
            f"{exp.root}: a calibration folder, read by calibrate, which measures what a "
            "calibration.toml would give (none needed)",
        )
        return
    else:
        unstated = [
            f"stage[{k}].tare_inertia_std"
            for k, st in enumerate(device.stages, 1)
            if st.tare_inertia_std is None
        ]
        if device.motor.torque_scale_std() is None:
            current = device.motor.torque_constant is not None
            unstated.append("motor.torque_constant_std" if current else "motor.torque_gain_std")
        if unstated:
            _add(
                findings,
                "suspicious",
                f"{path}: not found, and device.toml states no {', '.join(unstated)}: identify "
                "will take the tares, a torque gain of 1 and a lossless drive as exact, and "
                "warn (rsp-inertia calibrate)",
            )
    if device.pendulum is not None and stiffness is None and device.pendulum.stiffness_std is None:
        _add(
            findings,
            "suspicious",
            f"{exp.device_path}: pendulum: no stiffness_std and no calibrated stiffness: "
            "the best-practice pendulum will take the stiffness as exact, and warn",
        )
