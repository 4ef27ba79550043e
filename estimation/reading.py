"""An experiment folder read for the estimators: its logs, calibration.toml and reference.toml.

The estimators work on data in memory (rsp_inertia.estimation.identify.identify_logs,
rsp_inertia.estimation.calibration.calibrate_logs). This module is the one of the package
that opens the files they need: it reads them, names every input by its path for the
messages (rsp_inertia.estimation.runs.Sources), and calls the estimators.

An experiment's calibration.toml is read once per command (:func:`read_calibration`: parsed
and validated into its config class, rsp_inertia.estimation.calibration_file.CalibrationFile);
what identify and check take from it (the known terms, the pendulum's stiffness) comes from
that one reading.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import tomllib
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path

import numpy as np

from rsp_inertia.estimation.calibration import (
    Calibration,
    calibrate_logs,
    calibrated_known_terms,
    device_known_terms,
)
from rsp_inertia.estimation.calibration_file import CalibrationFile, read_calibration_file
from rsp_inertia.estimation.coverage import DEFAULT_COVERAGE_FACTOR
from rsp_inertia.estimation.decision import (
    check_quantities,
    decide,
    expanded_for_decision,
    result_quantities,
)
from rsp_inertia.estimation.identify import TEMPCO_SOURCE, add_consider_line, identify_logs
from rsp_inertia.estimation.known_terms import KnownTerms
from rsp_inertia.estimation.records import experiment_record
from rsp_inertia.estimation.results import Identification
from rsp_inertia.estimation.runs import ExperimentLogs, Sources, runs
from rsp_inertia.estimation.tempco import TempcoFit
from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import file_sha256
from rsp_inertia.infra.progress import say
from rsp_inertia.plant.config import load_reference
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.experiment import Experiment
from rsp_inertia.plant.log_checks import unterminated_last_line
from rsp_inertia.plant.logs import (
    Log,
    align_counter,
    compensate_temperature,
    read_device_log,
    reverse_start_lag,
)
from rsp_inertia.plant.record_config import load_spec
from rsp_inertia.plant.transducers import magnet_temperature

__all__ = [
    "calibrate_experiment",
    "check_same_stages",
    "identify_experiment",
    "known_terms",
    "read_calibration",
    "read_experiment",
    "read_run",
    "tempco_in_use",
    "tempco_line",
    "unterminated_warnings",
]


def read_run(
    exp: Experiment, stage: int, direction: Direction, tempco: float | None = None
) -> tuple[Log, Log]:
    """One run's braking and reverse logs as logged, their torques at the torque constant's
    reference temperature when device.toml states a tempco and the logs a temperature
    (rsp_inertia.plant.logs.compensate_temperature; else as logged, bit for bit).

    Parameters
    ----------
    exp : Experiment
        The experiment folder.
    stage : int
        The stage, 1-based.
    direction : Direction
        The run's direction.
    tempco : float, optional
        1/K, the tempco to compensate with instead of device.toml's.

    Returns
    -------
    (Log, Log)
        The braking log and the reverse log, the reverse's counter continuing the braking's
        (rsp_inertia.plant.logs.align_counter).
    """
    device = exp.device
    braking = _read_log(exp.braking_path(stage, direction), device, "braking", direction, tempco)
    # The reverse starts where the braking stopped: one counter, one angle; its magnets where
    # the braking left them.
    reverse = align_counter(
        _read_log(
            exp.reverse_path(stage, direction), device, "reverse", direction, tempco,
            reverse_start_lag(braking, device.motor),
        ),
        float(braking.phi[-1]),
        device.encoder,
    )
    return braking, reverse


def _read_log(
    path, device, kind: str, direction: Direction, tempco: float | None, start_lag: float = 0.0
) -> Log:
    """A log read for the estimators: as the device reads it, temperature compensated (the one
    place the estimators' logs are read, rsp_inertia.plant.logs.compensate_temperature; a
    reverse's magnets from ``start_lag``, K, behind the logged temperature)."""
    log = read_device_log(path, device, kind, direction)
    return compensate_temperature(log, device.motor, tempco, start_lag)


class _OnDemand(Mapping):
    """Logs read from their files at every lookup, never kept: the estimators take the runs
    one by one, so an experiment's memory holds one run's logs whatever its number of runs
    (a calibration that balances the runs again reads them again), and a bad log is reported
    after the runs before it are balanced, as they are listed."""

    def __init__(self, readers: dict[tuple, Callable[[], Log | tuple[Log, Log]]]) -> None:
        self._readers = readers

    def __getitem__(self, key):
        return self._readers[key]()

    def __contains__(self, key) -> bool:
        return key in self._readers

    def __iter__(self) -> Iterator:
        return iter(self._readers)

    def __len__(self) -> int:
        return len(self._readers)


def read_experiment(exp: Experiment, tempco: float | None = None) -> ExperimentLogs:
    """Every run's logs and every ``stageN/pendulum_kK.csv`` present, named by their paths;
    each log is read when the estimators look it up (:func:`read_run`; ``tempco``, 1/K: the
    tempco to compensate with instead of device.toml's)."""
    device = exp.device
    keys = runs(device)
    pendulum = [
        (stage, k)
        for stage, st in enumerate(device.stages, 1)
        for k in range(1, len(st.nodes) + 1)
        if exp.pendulum_path(stage, k).is_file()
    ]
    sources = Sources(
        experiment=str(exp.root),
        device=str(exp.device_path),
        runs={
            (s, d): (str(exp.braking_path(s, d)), str(exp.reverse_path(s, d))) for s, d in keys
        },
        pendulum={(s, k): str(exp.pendulum_path(s, k)) for s, k in pendulum},
    )
    return ExperimentLogs(
        device=device,
        runs=_OnDemand(
            {(s, d): functools.partial(read_run, exp, s, d, tempco) for s, d in keys}
        ),
        pendulum=_OnDemand(
            {
                (s, k): functools.partial(
                    _read_log, exp.pendulum_path(s, k), device, "pendulum", Direction.FORWARD,
                    tempco,
                )
                for s, k in pendulum
            }
        ),
        sources=sources,
    )


def read_calibration(exp: Experiment) -> CalibrationFile | None:
    """``EXP/calibration.toml`` parsed and validated, once: everything a command takes from
    it comes from this reading (:func:`known_terms`,
    rsp_inertia.estimation.calibration_file.CalibrationFile.pendulum_stiffness).

    Parameters
    ----------
    exp : Experiment
        The experiment folder.

    Returns
    -------
    CalibrationFile or None
        The file's tables; None if the folder has no calibration.toml.

    Raises
    ------
    InputError
        A file that is not TOML or breaks a rule of calibration.toml
        (rsp_inertia.estimation.calibration_file.read_calibration_file), the path in front.
    """
    path = exp.calibration_path
    if not path.is_file():
        return None
    try:
        with open(path, "rb") as file:
            doc = tomllib.load(file)
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise InputError(f"{path}: cannot read as TOML: {' '.join(str(error).split())}") from None
    return read_calibration_file(doc, str(path))


def known_terms(
    exp: Experiment, calibration: CalibrationFile | None
) -> tuple[KnownTerms, list[str]]:
    """The rig's known terms for identify: calibration.toml's, checked to be made for this
    device (rsp_inertia.estimation.calibration.calibrated_known_terms), else device.toml's
    (rsp_inertia.estimation.calibration.device_known_terms).

    Parameters
    ----------
    exp : Experiment
        The experiment folder.
    calibration : CalibrationFile or None
        Its calibration.toml as :func:`read_calibration` gives it (None: the folder has none).

    Returns
    -------
    (KnownTerms, list of str)
        The terms, with the warnings they give (a file of an older rsp-inertia; device.toml's
        unstated stds).

    Raises
    ------
    InputError
        A calibration made for another device (name, encoder or stages differ).
    """
    source = str(exp.calibration_path)
    if calibration is not None:
        return calibrated_known_terms(calibration, exp.device, source)
    return device_known_terms(exp.device, source)


def identify_experiment(
    exp: Experiment, made: str | None = None, coverage_factor: float = DEFAULT_COVERAGE_FACTOR
) -> Identification:
    """Identify an experiment folder: its logs, calibration and pendulum runs read, then
    rsp_inertia.estimation.identify.identify_logs (its errors and warnings name the files).
    calibration.toml is read once (:func:`read_calibration`); record.toml and spec.toml, when
    present, are read and checked before the work: with ``made`` (when the result is made,
    ISO 8601) the result carries its record (rsp_inertia.estimation.records, a warning when
    the calibration is overdue) and its decision against spec.toml
    (rsp_inertia.estimation.decision), made with the expanded uncertainties of coverage
    factor ``coverage_factor`` (rsp_inertia.estimation.coverage).

    Parameters
    ----------
    exp : Experiment
        The experiment folder.
    made : str, optional
        When the result is made (ISO 8601): with it the result carries its record.
    coverage_factor : float, optional
        k of the result's expanded uncertainties (default 2).

    Returns
    -------
    Identification
        What identify found.
    """
    calibration = read_calibration(exp)
    record, record_warnings = (None, []) if made is None else experiment_record(
        exp, calibration, made
    )
    spec = load_spec(exp.spec_path) if exp.spec_path.is_file() else None
    if spec is not None:
        check_quantities(
            spec, result_quantities(exp.device.body is not None), str(exp.spec_path)
        )
    known, warnings = known_terms(exp, calibration)
    warnings += record_warnings
    # The tempco: calibration.toml's where calibrate measured it, else device.toml's.
    alpha, alpha_std, tempco_warnings = tempco_in_use(exp, calibration)
    warnings += tempco_warnings
    logs = read_experiment(exp, alpha)
    warnings += unterminated_warnings(logs)
    stiffness = None
    if calibration is not None and logs.pendulum:
        stiffness = calibration.pendulum_stiffness()
    # What calibrate found of the rig's conventions goes on with the calibration.
    conventions = "" if calibration is None else calibration.calibration.conventions
    found = identify_logs(
        logs, known, pendulum_stiffness=stiffness, warnings=warnings, conventions=conventions
    )
    if alpha is not None and alpha_std:
        # The tempco's std, a consider parameter: the same runs identified with alpha one std
        # off give every estimate's response to it (docs/method.md §3, "Temperature").
        say(f"{TEMPCO_SOURCE}: the runs identified again with the tempco one std off")
        shifted = identify_logs(
            read_experiment(exp, alpha + alpha_std),
            known, pendulum_stiffness=stiffness, conventions=conventions,
        )
        found = add_consider_line(found, shifted, TEMPCO_SOURCE)
    measured = calibration is not None and calibration.motor is not None
    source = "calibration.toml" if measured else "device.toml"  # tempco_in_use's choice
    found = dataclasses.replace(
        found,
        coverage_factor=coverage_factor,
        tempco=None if alpha is None else (alpha, alpha_std, source),
    )
    if record is None and spec is None:  # identify_logs' result as it is
        return found
    decision = None if spec is None else decide(
        spec, expanded_for_decision(found), str(exp.spec_path)
    )
    return dataclasses.replace(found, record=record, decision=decision)


def tempco_in_use(
    exp: Experiment, calibration: CalibrationFile | None
) -> tuple[float | None, float | None, list[str]]:
    """(alpha, std, warnings) identify, check and plan's pilots compensate the logs with:
    calibration.toml's ``[motor]``
    where calibrate measured the tempco and device.toml states one (calibrated over stated,
    as for the other terms), else device.toml's; a warning when device.toml's
    ``reference_temperature`` is not the one the calibration's gains hold at."""
    motor = exp.device.motor
    alpha, std = motor.torque_constant_tempco, motor.torque_constant_tempco_std
    measured = None if calibration is None else calibration.motor
    if alpha is None or measured is None:
        return alpha, std, []
    warnings = []
    if not math.isclose(measured.reference_temperature, motor.reference_temperature):
        warnings.append(
            f"{exp.calibration_path}: its gains hold at reference_temperature = "
            f"{measured.reference_temperature:g} C, device.toml states "
            f"{motor.reference_temperature:g} C: the torques are compensated to the latter "
            "(set device.toml's back, or calibrate again)"
        )
    return measured.torque_constant_tempco, measured.torque_constant_tempco_std, warnings


def tempco_line(
    motor, logs: list[ExperimentLogs | None], found: TempcoFit | None = None
) -> str:
    """calibrate's one line on the torque constant's tempco, when device.toml states one
    (rsp_inertia.estimation.calibration.Calibration.tempco, printed with its result, not a
    warning; docs/method.md §3, "Temperature"): the tempco the runs measured, with its std, the
    runs' span of magnet temperature and the stated value; or that device.toml's is kept,
    because the runs determine it no better than it is stated (to the runs' own std, against
    the stated one) or because calibrate could not take it as an unknown (no std stated, no
    reference, no temperature logged); with the calibration runs' magnet temperatures (their
    range and mean over every row) against ``reference_temperature``, at which the calibrated
    gains hold. '' without a tempco.

    Parameters
    ----------
    motor : device.toml's ``[motor]``
        The calibration folders' (rsp_inertia.plant.config.Motor).
    logs : list of ExperimentLogs or None
        The calibration's runs (None: a folder not given).
    found : TempcoFit, optional
        What calibrate's fit found of alpha (rsp_inertia.estimation.tempco), when it took it
        as an unknown.

    Returns
    -------
    str
        The line, or ''.
    """
    if motor.torque_constant_tempco is None:
        return ""
    temperatures = [
        magnet_temperature(log.temperature, log.t, motor.temperature_lag)
        for folder in logs
        if folder is not None
        for pair in folder.runs.values()
        for log in pair
        if log.temperature is not None
    ]
    alpha, std = motor.torque_constant_tempco, motor.torque_constant_tempco_std
    stated = f"{alpha:g}" + ("" if std is None else f" +- {std:g}")
    gains_at = f"the calibrated gains hold at motor.reference_temperature = {motor.reference_temperature:g} C"
    runs = ""
    if temperatures:
        every = np.concatenate(temperatures)
        low, mean, high = float(every.min()), float(every.mean()), float(every.max())
        runs = f"{high - low:.2f} K of magnet temperature ({low:.2f} to {high:.2f} C, mean {mean:.2f} C)"
    if found is not None and found.informed:
        return (
            f"torque constant's tempco measured by the calibration runs: alpha = "
            f"{found.estimate:.4g} +- {found.std:.2g} /K from their {runs}, against "
            f"device.toml's {stated} /K; calibration.toml carries it and identify applies it "
            f"({gains_at})"
        )
    if found is not None:
        would = (
            "carry no information on it"
            if math.isinf(found.data_std)
            else f"would determine it to +- {found.data_std:.2g} /K"
        )
        return (
            f"the calibration runs span only {runs}: they {would} against device.toml's "
            f"+- {std:g} /K, so device.toml's torque constant's tempco {alpha:g} /K is kept; "
            f"{gains_at} (set it to the runs' mean magnet temperature, so that the tempco's "
            "error hardly reaches them)"
        )
    if std is None:
        why = "device.toml states no torque_constant_tempco_std"
    elif not temperatures:
        why = "the calibration logs carry no temperature"
    else:
        why = "without a reference experiment the torque's scale is not measured"
    line = (
        f"calibrate does not estimate the torque constant's tempco ({why}): it stays "
        f"device.toml's motor.torque_constant_tempco = {stated} /K, and {gains_at}"
    )
    if not temperatures:
        return line
    return (
        f"{line}; the calibration runs' magnets were at {low:.2f} to {high:.2f} C, mean "
        f"{mean:.2f} C (set reference_temperature to it, so that the tempco's error hardly "
        "reaches the gains)"
    )


def unterminated_warnings(logs: ExperimentLogs) -> list[str]:
    """A warning per CSV log of ``logs`` whose last line has no line end, which the reader
    left out (rsp_inertia.plant.log_checks.unterminated_last_line)."""
    paths = [p for pair in logs.sources.runs.values() for p in pair]
    paths += list(logs.sources.pendulum.values())
    return [
        f"{path}: its last line has no line end (a logger stopped while writing it?): that "
        "row was left out"
        for path in paths
        if Path(path).suffix == ".csv" and Path(path).is_file() and unterminated_last_line(path)
    ]


def check_same_stages(exp: Experiment, other: Experiment, role: str) -> None:
    """Raise InputError unless ``other`` is ``exp``'s device: its ``[device] name``, its stages
    (gear ratios and nodes) and its encoder's counts per revolution (a calibration made on
    another gimbal would be applied to this one without a word, docs/real-rig.md).

    Parameters
    ----------
    exp : Experiment
        The experiment to calibrate.
    other : Experiment
        A calibration folder.
    role : str
        What ``other`` is (``"empty"``, ``"reference"``), in messages.

    Raises
    ------
    InputError
        ``other``'s device.toml differs from ``exp``'s (naming both files and the key).
    """
    mine, theirs = exp.device.stages, other.device.stages
    mine_path, where = exp.device_path, other.device_path
    if other.device.name != exp.device.name:
        raise InputError(
            f"{where}: device.name = {other.device.name!r} differs from "
            f"{mine_path}'s {exp.device.name!r}: the {role} runs must be made "
            "on the same device"
        )
    if len(theirs) != len(mine):
        raise InputError(
            f"{where}: the {role} experiment has {len(theirs)} stage(s), {exp.root} has "
            f"{len(mine)}: calibration runs need the same stages"
        )
    for k, (a, b) in enumerate(zip(mine, theirs), 1):
        if not math.isclose(a.gear_ratio, b.gear_ratio, rel_tol=1e-9, abs_tol=1e-12):
            raise InputError(
                f"{where}: stage[{k}].gear_ratio = {b.gear_ratio!r} differs from "
                f"{mine_path}'s {a.gear_ratio!r}"
            )
        if tuple(a.nodes_deg) != tuple(b.nodes_deg):
            raise InputError(
                f"{where}: stage[{k}].nodes_deg = {list(b.nodes_deg)} differs from "
                f"{mine_path}'s {list(a.nodes_deg)}"
            )
    if other.device.encoder.counts_per_rev != exp.device.encoder.counts_per_rev:
        raise InputError(
            f"{where}: encoder.counts_per_rev differs from {mine_path}'s: "
            "calibration runs must be made on the same device"
        )


def calibrate_experiment(
    exp: Experiment,
    empty: Experiment,
    reference: Experiment | None = None,
) -> Calibration:
    """Calibrate ``exp``'s rig from the empty-fixture and reference experiment folders
    (rsp_inertia.estimation.calibration.calibrate_logs), recording every input file's sha256.

    Parameters
    ----------
    exp : Experiment
        The experiment whose rig is calibrated (its device names the calibration).
    empty : Experiment
        The empty-fixture calibration folder.
    reference : Experiment, optional
        The reference-body calibration folder (its reference.toml holds the body).

    Returns
    -------
    Calibration
        What calibrate found, its ``inputs`` the sha256 of every file read (paths as the
        folders give them) and its warnings led by the logs' unterminated last lines.

    Raises
    ------
    InputError
        A calibration folder whose stages differ from ``exp``'s, a missing or unphysical
        reference.toml, bad logs.
    """
    check_same_stages(exp, empty, "empty")
    certificate = None
    if reference is not None:
        check_same_stages(exp, reference, "reference")
        certificate = dataclasses.replace(
            load_reference(reference.reference_path), mounting=reference.device.mounting
        )
    empty_logs = read_experiment(empty)
    reference_logs = None if reference is None else read_experiment(reference)
    result = calibrate_logs(exp.device, empty_logs, reference_logs, certificate)
    cut = unterminated_warnings(empty_logs)
    if reference_logs is not None:
        cut += unterminated_warnings(reference_logs)
    if cut:
        result = dataclasses.replace(result, warnings=cut + list(result.warnings))
    tempco = tempco_line(empty.device.motor, [empty_logs, reference_logs], result.tempco_fit)
    if tempco:
        result = dataclasses.replace(result, tempco=tempco)
    inputs = {}
    for folder, logs in ((empty, empty_logs), (reference, reference_logs)):
        if folder is None:
            continue
        files = [str(folder.device_path)]
        if folder is reference:
            files.append(str(folder.reference_path))
        for names in logs.sources.runs.values():
            files += names
        inputs.update({path: file_sha256(path) for path in files})
    if result.stiffness is not None:
        inputs.update({path: file_sha256(path) for path in result.stiffness.paths})
    return dataclasses.replace(result, inputs=inputs)
