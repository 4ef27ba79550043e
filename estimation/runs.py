"""The runs of an experiment: which (stage, direction) pairs it has, and their passes estimated.

A run is one stage in one direction of rotation (device.toml ``[[stage]] directions``): its
braking log and its reverse log. A backward run is mirrored into the forward coordinate
(rsp_inertia.plant.logs.mirror_log), so everything downstream treats it as a forward run.

The estimators take an experiment's logs in memory (:class:`ExperimentLogs`), named for their
messages by :class:`Sources`; rsp_inertia.estimation.reading reads them from a folder.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np

from rsp_inertia.estimation.balance import NodeGap, StageBalance, balance_range, stage_balance
from rsp_inertia.estimation.passes import (
    CONSTANCY_TAIL,
    PassEstimate,
    constancy_level,
    estimate_pass,
)
from rsp_inertia.estimation.smoothing import Smoothed
from rsp_inertia.infra.progress import report, say
from rsp_inertia.plant.config import Device
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.experiment import DEVICE_FILE
from rsp_inertia.plant.log_files import log_rows
from rsp_inertia.plant.logs import Log, check_braking_monotone, mirror_log
from rsp_inertia.plant.transducers import true_angle

__all__ = [
    "ExperimentLogs",
    "Sources",
    "balance_runs",
    "checked_run",
    "corrected_log",
    "estimate_forward_run",
    "estimate_run",
    "run_logs",
    "runs",
]

T = TypeVar("T")


@dataclass(frozen=True)
class Sources:
    """What the messages call an experiment's inputs: a reader's file paths, or labels."""

    experiment: str | None = None
    """The experiment's name, prefixing the progress line of each run (None: no prefix)."""
    device: str = DEVICE_FILE
    """The device description."""
    runs: Mapping[tuple[int, Direction], tuple[str, str]] = field(default_factory=dict)
    """(stage, direction) -> the braking log's and the reverse log's names."""
    pendulum: Mapping[tuple[int, int], str] = field(default_factory=dict)
    """(stage, node from 1) -> the torsion-pendulum log's name."""

    def run(self, stage: int, direction: Direction) -> tuple[str, str]:
        """The names of one run's braking and reverse logs ("stage N direction braking" and
        "... reverse" when not given)."""
        label = f"stage {stage} {direction}"
        return self.runs.get((stage, direction), (f"{label} braking", f"{label} reverse"))

    def pendulum_log(self, stage: int, node: int) -> str:
        """The name of the pendulum log of ``stage`` at node ``node`` (from 1)."""
        return self.pendulum.get((stage, node), f"stage {stage} pendulum at node {node}")


@dataclass(frozen=True)
class ExperimentLogs:
    """An experiment's logs in memory: what the estimators take instead of a folder."""

    device: Device
    """The device (device.toml)."""
    runs: Mapping[tuple[int, Direction], tuple[Log, Log]]
    """(stage, direction) -> (braking log, reverse log) of every run of the device, as logged
    (a backward run not mirrored; the reverse's counter continuing the braking's,
    rsp_inertia.plant.logs.align_counter)."""
    pendulum: Mapping[tuple[int, int], Log] = field(default_factory=dict)
    """(stage, node from 1) -> torsion-pendulum log, for the nodes that have one."""
    sources: Sources = field(default_factory=Sources)
    """The names messages give the inputs."""


def runs(device: Device) -> list[tuple[int, Direction]]:
    """(stage, direction) of every run of the device, stage by stage."""
    return [
        (stage, direction)
        for stage, st in enumerate(device.stages, 1)
        for direction in st.directions
    ]


def corrected_log(log: Log, encoder, zero: float = 0.0) -> Log:
    """The log with its readings taken back to the true angle: phi with phi + z + e(phi) =
    reading (rsp_inertia.plant.transducers.true_angle), ``encoder`` the error's coefficients
    theta_e, ``zero`` the encoder's zero offset z (rad).

    The reading floor((phi + e) / q) q bounds the read angle from below, so its true angle
    bounds the true one from below: the floor convention the smoother assumes holds, the
    count's width changed by the factor 1 - e' (|e'| of a few 1e-4). An empty ``encoder``
    and no zero offset return the log itself.

    Parameters
    ----------
    log : Log
        The log as read.
    encoder : sequence of float
        theta_e, rad (empty: none).
    zero : float
        z, rad, the encoder's zero offset.

    Returns
    -------
    Log
        The log with the true angle, its notes kept.
    """
    encoder = np.asarray(encoder, dtype=float)
    if (encoder.size == 0 or not np.any(encoder)) and not zero:
        return log
    return dataclasses.replace(log, phi=true_angle(log.phi, encoder, zero))


def run_logs(
    device: Device,
    braking: Log,
    reverse: Log,
    direction: Direction,
    encoder=(),
    zero: float = 0.0,
) -> tuple[Log, Log]:
    """A run's braking and reverse logs as its passes are estimated: the readings taken back
    to the true angle (:func:`corrected_log`) and a backward run mirrored into the forward
    coordinate (rsp_inertia.plant.logs.mirror_log).

    Parameters
    ----------
    device : Device
        The device (its encoder's quantum).
    braking, reverse : Log
        The run's logs as logged.
    direction : Direction
        The run's direction.
    encoder : sequence of float
        The encoder's error coefficients theta_e (empty: none).
    zero : float
        rad, the encoder's zero offset (:func:`corrected_log`).

    Returns
    -------
    braking, reverse : Log
        The logs in the true angle and the forward coordinate.
    """
    braking = corrected_log(braking, encoder, zero)
    reverse = corrected_log(reverse, encoder, zero)
    if direction is Direction.BACKWARD:
        q = device.encoder.quantum
        braking, reverse = mirror_log(braking, q), mirror_log(reverse, q)
    return braking, reverse


def estimate_run(
    device: Device,
    braking: Log,
    reverse: Log,
    direction: Direction,
    warnings: list[str],
    braking_source: str = "braking",
    reverse_source: str = "reverse",
    braking_smoothed: Smoothed | None = None,
    encoder=(),
    zero: float = 0.0,
    two_levels: bool = False,
) -> tuple[PassEstimate, PassEstimate]:
    """Both passes of one run from their logs in memory, checked and estimated (a backward
    run mirrored): :func:`run_logs` then :func:`estimate_forward_run`.

    Parameters
    ----------
    device : Device
        The device.
    braking, reverse : Log
        The run's logs as logged.
    direction : Direction
        The run's direction.
    warnings : list of str
        Gets what identify warns about the passes.
    braking_source, reverse_source : str
        The logs' names in messages.
    braking_smoothed : Smoothed, optional
        The (mirrored) braking log's smoothed states when already computed
        (rsp_inertia.ocp.program's).
    encoder : sequence of float
        The encoder's error coefficients; the readings are taken back to the true angle
        first (:func:`corrected_log`).
    zero : float
        rad, the encoder's zero offset, taken off with them.
    two_levels : bool, optional
        The stage's braking holds two levels (device.toml ``braking_torque_2``): its log is
        held at each level's mean (rsp_inertia.estimation.passes.estimate_pass).

    Returns
    -------
    braking, reverse : PassEstimate
        The run's passes.
    """
    braking, reverse = run_logs(device, braking, reverse, direction, encoder, zero)
    return estimate_forward_run(
        device, braking, reverse, warnings, braking_source, reverse_source, braking_smoothed,
        two_levels,
    )


def estimate_forward_run(
    device: Device,
    braking: Log,
    reverse: Log,
    warnings: list[str],
    braking_source: str = "braking",
    reverse_source: str = "reverse",
    braking_smoothed: Smoothed | None = None,
    two_levels: bool = False,
) -> tuple[PassEstimate, PassEstimate]:
    """Both passes of one run whose logs :func:`run_logs` made (true angles, the forward
    coordinate), checked and estimated; each pass finds its dropped samples at the encoder's
    sample rate (:attr:`rsp_inertia.estimation.passes.PassEstimate.dropped`).

    Parameters
    ----------
    device : Device
        The device.
    braking, reverse : Log
        The run's logs, made by :func:`run_logs`.
    warnings : list of str
        Gets what identify warns about the passes.
    braking_source, reverse_source : str
        The logs' names in messages.
    braking_smoothed : Smoothed, optional
        As for :func:`estimate_run`.
    two_levels : bool, optional
        As for :func:`estimate_run`.

    Returns
    -------
    braking, reverse : PassEstimate
        The run's passes.
    """
    q = device.encoder.quantum
    check_braking_monotone(braking, log_rows(braking_source, device.log))
    rate = device.encoder.sample_rate
    # The experiment's braking logs share the test's false-alarm rate (CONSTANCY_TAIL).
    logs = sum(len(st.directions) for st in device.stages)
    b_est = estimate_pass(
        braking, q, braking_source, constant_torque=True, smoothed=braking_smoothed,
        sample_rate=rate, constancy_logs=logs, two_levels=two_levels,
    )
    if b_est.torque_mean is None:
        warnings.append(
            f"{braking_source}: the braking torque is not constant within the log's noise "
            f"(p = {b_est.constancy_p:.2g}, below {constancy_level(logs):.2g}: a false alarm "
            f"in {CONSTANCY_TAIL:g} of experiments of {logs} honest braking logs); its work "
            "is summed row by row, with a larger uncertainty"
        )
    # The torque channel's logging noise shows cleanly only in the braking log (constant
    # applied torque); the reverse's own changes are largely real regulator torque.
    r_est = estimate_pass(
        reverse, q, reverse_source, sigma_torque=b_est.sigma_torque, sample_rate=rate
    )
    return b_est, r_est


def checked_run(
    device: Device,
    stage: int,
    pair: tuple[Log, Log],
    direction: Direction,
    warnings: list[str],
    sources: tuple[str, str] = ("braking", "reverse"),
    encoder=(),
    zero: float = 0.0,
    bridged: list[NodeGap] | None = None,
) -> tuple[PassEstimate, PassEstimate]:
    """One run's passes, estimated as :func:`balance_runs` estimates them, and checked for
    every reason identify and calibrate refuse a run before they fit: :func:`run_logs`,
    :func:`estimate_forward_run` (a braking whose speed reverses, a log too short to smooth)
    and rsp_inertia.estimation.balance.balance_range (passes that share too few turns at
    useful speed, naming the log at fault; a gap of dropped samples near a node too long for
    the smoother to bridge).
    ``rsp-inertia check`` runs it on every run whose two logs it could read.

    Parameters
    ----------
    device : Device
        The device.
    stage : int
        Stage number, from 1.
    pair : tuple of Log
        The run's (braking, reverse) logs as logged (:attr:`ExperimentLogs.runs`).
    direction : Direction
        The run's direction.
    warnings : list of str
        Gets what identify warns about the passes.
    sources : tuple of str
        The logs' names in messages.
    encoder : sequence of float
        The encoder's error coefficients (:func:`corrected_log`).
    zero : float
        rad, the encoder's zero offset (:func:`corrected_log`).
    bridged : list of NodeGap, optional
        Gets the gaps near a node that the smoother bridges
        (rsp_inertia.estimation.balance.check_node_gaps).

    Returns
    -------
    braking, reverse : PassEstimate
        The run's passes.

    Raises
    ------
    InputError
        Naming the log at fault.
    """
    braking, reverse = run_logs(device, *pair, direction, encoder, zero)
    # The logs as read go now (balance_runs hands them over, nothing else holds them): they
    # are not kept through the estimation, only the ones estimated (mirrored, corrected).
    del pair
    two = device.stages[stage - 1].braking_torque_2 is not None
    b_est, r_est = estimate_forward_run(
        device, braking, reverse, warnings, *sources, two_levels=two
    )
    balance_range(device, stage, b_est, r_est, direction.sign, bridged)
    return b_est, r_est


def balance_runs(
    logs: ExperimentLogs,
    warnings: list[str],
    encoder=(),
    keep: Callable[[int, int, PassEstimate, PassEstimate], T] | None = None,
    zero: float = 0.0,
) -> tuple[list[StageBalance], list[T]]:
    """Every run's balance equations (rsp_inertia.estimation.balance), in the device's order of
    runs, and what ``keep`` takes of each run's passes.

    One run at a time: its logs are looked up, its passes estimated, balanced and handed to
    ``keep(stage, sign, braking, reverse)`` (sign +1 forward, -1 backward), then let go, so
    that an experiment's memory is one run's passes whatever its number of runs. Each run
    done is a line and a step of the fraction done (rsp_inertia.infra.progress).

    Parameters
    ----------
    logs : ExperimentLogs
        The experiment's logs in memory.
    warnings : list of str
        Gets what identify warns about the passes.
    encoder : sequence of float
        The encoder's error coefficients, taken off every log's readings
        (:func:`corrected_log`).
    keep : callable, optional
        ``keep(stage, sign, braking, reverse)``: what to keep of each run's passes.
    zero : float
        rad, the encoder's zero offset, taken off every log's readings with the error.

    Returns
    -------
    balances : list of StageBalance
        Every run's balance equations.
    kept : list
        ``keep``'s results (empty without ``keep``).

    Raises
    ------
    ValueError
        ``logs.runs`` lacks a run of the device or has one the device does not make.
    """
    device = logs.device
    expected = runs(device)
    if set(logs.runs) != set(expected):
        raise ValueError(
            f"the runs given {sorted(logs.runs)} are not the device's {expected}"
        )
    prefix = "" if logs.sources.experiment is None else f"{logs.sources.experiment}: "
    balances, kept = [], []
    for k, (stage, direction) in enumerate(expected, 1):
        # What the reader did to the logs (their notes and warnings) first; then the logs as read are
        # checked_run's alone (popped: nothing here holds them while it estimates).
        read = [logs.runs[stage, direction]]
        warnings += [line for log in read[0] for line in (*log.notes, *log.warnings)]
        b_est, r_est = checked_run(
            device, stage, read.pop(), direction, warnings, logs.sources.run(stage, direction),
            encoder, zero,
        )
        balances.append(stage_balance(device, stage, b_est, r_est, direction.sign))
        if keep is not None:
            kept.append(keep(stage, direction.sign, b_est, r_est))
        rows = (len(b_est.log), len(r_est.log))
        del b_est, r_est  # before the next run's logs are read
        say(
            f"{prefix}stage {stage} {direction}: {rows[0]} + {rows[1]} "
            "rows smoothed and balanced"
        )
        report("runs smoothed and balanced", k, len(expected))
    return balances, kept
