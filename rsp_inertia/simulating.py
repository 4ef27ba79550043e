"""``rsp-inertia simulate``: the virtual device writes the logs a rig would.

Reads device.toml and virtual.toml (the virtual device's truth), runs the simulator
(rsp_inertia.virtual.device) and writes each log atomically, as the virtual rig's logger writes
it; each log written is a :class:`rsp_inertia.results.PassSummary`.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rsp_inertia.infra.errors import InputError
from rsp_inertia.infra.files import check_writable
from rsp_inertia.infra.progress import say
from rsp_inertia.plant.config import AngleUnit
from rsp_inertia.plant.direction import Direction
from rsp_inertia.plant.experiment import Experiment, open_experiment
from rsp_inertia.plant.geometry import turns_past_last_node
from rsp_inertia.plant.logs import Log, align_counter, read_device_log, read_program, write_log
from rsp_inertia.results.simulate import PassSummary
from rsp_inertia.virtual.config import Virtual, experiment_virtual
from rsp_inertia.virtual.device import (
    SimulatedPass,
    run_program,
    simulate_braking,
    simulate_ideal_reverse,
    simulate_pendulum,
    simulate_pilot,
)

__all__ = ["PARTS", "simulate"]

PARTS = ("braking", "reverse", "pendulum", "pilot")
"""What ``simulate`` can run: ``--part``'s choices."""


def _summary(
    exp: Experiment,
    stage: int,
    part: str,
    path: Path,
    sim: SimulatedPass,
    direction: Direction = Direction.FORWARD,
) -> PassSummary:
    log = sim.log
    past = None
    if part == "braking":
        past = turns_past_last_node(log.phi, exp.device.stages[stage - 1].nodes)
    return PassSummary(
        stage=stage,
        part=part,
        path=path,
        rows=len(log),
        duration=sim.truth.end_time,
        turns=float(abs(log.phi[-1] - log.phi[0]) / (2 * math.pi)),
        turns_past_last_node=past,
        direction=direction,
    )


def _check_simulate_outputs(
    exp: Experiment, stages: list[int], part: str, direction: Direction | None
) -> None:
    """Refuse, before any run is simulated, a log that :func:`simulate` could not write
    (rsp_inertia.infra.files.check_writable): in a stage folder that exists, each log; else
    the experiment folder, where the stage folder is to be made."""
    for st in stages:
        if part == "pendulum":
            nodes = len(exp.device.stages[st - 1].nodes)
            paths = [exp.pendulum_path(st, k + 1) for k in range(nodes)]
        elif part == "pilot":
            paths = [exp.pilot_path(st)]
        else:
            directions = exp.device.stages[st - 1].directions if direction is None else (direction,)
            where = exp.braking_path if part == "braking" else exp.reverse_path
            paths = [where(st, d) for d in directions]
        folder = exp.stage_dir(st)
        for path in paths if folder.is_dir() else [folder]:
            check_writable(path)


def _write_log(exp: Experiment, virtual: Virtual, path: Path, log: Log) -> None:
    """A simulated log as the virtual rig's logger writes it: in device.toml's ``[log]``
    layout (format, dialect, columns, units; a named temperature column at
    rsp_inertia.plant.log_files.TEMPERATURE), its angle as counts with virtual.toml
    ``[logger] counts`` (device.toml's ``[encoder] counter_bits`` wide). A waveform-timed
    TDMS (no ``[log] time_column``) needs a regular log: no jitter, no dropped rows."""
    device = exp.device
    if virtual.logger.counts and device.encoder.counter_bits is None:
        raise InputError(
            f"{exp.virtual_path}: logger.counts: the logger writes a counter's counts, "
            "but device.toml's [encoder] has no counter_bits (the counter's width)"
        )
    if virtual.logger.counts and device.log.angle_unit is AngleUnit.DEG:
        raise InputError(
            f"{exp.virtual_path}: logger.counts: the logger writes counts, but device.toml's "
            "[log] angle_unit is 'deg'"
        )
    if not device.log.time_column and (
        virtual.logger.time_jitter > 0 or virtual.logger.dropped_fraction > 0
    ):
        raise InputError(
            f"{exp.virtual_path}: logger.time_jitter, dropped_fraction: a TDMS log without a "
            "time channel (device.toml [log] time_column = '') has waveform timing, which "
            "holds no jitter or dropped rows: turn them off, or name a time_column"
        )
    write_log(
        path,
        log,
        counter=device.encoder if virtual.logger.counts else None,
        layout=device.log,
        encoder=device.encoder,
        torque_constant=device.motor.torque_constant,
    )


def _braking_truth(
    exp: Experiment, stage: int, virtual: Virtual, direction: Direction = Direction.FORWARD
) -> SimulatedPass:
    """Re-run the (deterministic) braking pass of ``direction`` and check it is the one on disk.

    The reverse pass starts where the braking stopped; the simulator regenerates that state
    rather than storing truth next to the logs, and refuses a braking log it did not write
    with these settings.
    """
    braking = simulate_braking(exp.device, stage, virtual, direction)
    path = exp.braking_path(stage, direction)
    if not path.is_file():
        raise InputError(f"{path}: not found: simulate the braking first (--part braking)")
    on_disk = align_counter(  # a counts log is known up to whole ranges of the counter
        read_device_log(path, exp.device, "braking", direction),
        float(braking.log.phi[0]),
        exp.device.encoder,
    )
    q = exp.device.encoder.quantum
    # The reader cuts a braking the drive logged on after at its turning point (its note
    # says so; virtual.toml [logger] hold_after_stop): compare the rows it kept.
    n = len(on_disk)
    cut = bool(on_disk.notes) and n < len(braking.log)
    simulated = braking.log.rows(slice(0, n)) if cut else braking.log
    same = (
        (n == len(braking.log) or cut)
        # within the [log] layout's conversions: stamps rounded to whole us at worst (TDMS
        # dates), a unit's scale within ulps (mN m, A); any other braking differs by far more
        and np.allclose(on_disk.t, simulated.t, rtol=0.0, atol=1e-6)
        and np.allclose(on_disk.torque, simulated.torque, rtol=1e-12, atol=0.0)
        # in counts: a counts log's angle is rebuilt from the counter, not bit for bit
        and np.array_equal(np.rint(on_disk.phi / q), np.rint(simulated.phi / q))
    )
    if not same:
        raise InputError(
            f"{path}: not the virtual device's braking pass for the current device.toml and "
            "virtual.toml; simulate it again (--part braking)"
        )
    return braking


def simulate(
    path: str | Path,
    stage: int | None = None,
    part: str = "braking",
    *,
    ideal: bool = False,
    direction: str | None = None,
) -> list[PassSummary]:
    """The command behind :func:`rsp_inertia.api.simulate`, documented there; returns the
    passes' records (rsp_inertia.results.PassSummary), which the API holds in its
    SimulateResult, and says each one's line (rsp_inertia.infra.progress.say) as soon as its
    log is written. Braking and reverse need every stage's protocol in device.toml
    (rsp_inertia.plant.config.require_protocol); pendulum and pilot runs do not, and ignore
    ``direction``."""
    if part not in PARTS:
        raise InputError(f"--part: must be one of {', '.join(PARTS)}, got {part!r}")
    if ideal and part != "reverse":
        raise InputError("--ideal goes with --part reverse")
    if direction is not None:
        direction = Direction.parse(direction, "--direction")
    exp = open_experiment(path, protocol=part in ("braking", "reverse"))
    virtual = experiment_virtual(exp)
    stages = exp.stages(stage)
    if direction is not None and part not in ("pendulum", "pilot"):
        runs = [st for st in stages if direction in exp.device.stages[st - 1].directions]
        if not runs:
            fault = (
                f"stage: no stage's directions include {direction!r}"
                if stage is None
                else f"stage[{stage}].directions: does not include {direction!r}"
            )
            raise InputError(f"{exp.device_path}: {fault}")
        stages = runs
    _check_simulate_outputs(exp, stages, part, direction)
    summaries = []
    for st in stages:
        exp.stage_dir(st).mkdir(exist_ok=True)
        if part == "pendulum":
            for k in range(len(exp.device.stages[st - 1].nodes)):
                sim = simulate_pendulum(exp.device, st, virtual, k)
                log_path = exp.pendulum_path(st, k + 1)
                _write_log(exp, virtual, log_path, sim.log)
                summary = _summary(exp, st, f"pendulum at node {k + 1}", log_path, sim)
                say(str(summary))
                summaries.append(summary)
            continue
        if part == "pilot":
            sim = simulate_pilot(exp.device, st, virtual)
            log_path = exp.pilot_path(st)
            _write_log(exp, virtual, log_path, sim.log)
            summary = _summary(exp, st, "pilot", log_path, sim)
            say(str(summary))
            summaries.append(summary)
            continue
        directions = exp.device.stages[st - 1].directions if direction is None else (direction,)
        for d in directions:
            if part == "braking":
                sim = simulate_braking(exp.device, st, virtual, d)
                log_path = exp.braking_path(st, d)
                label = "braking"
            else:
                braking = _braking_truth(exp, st, virtual, d)
                if ideal:
                    sim = simulate_ideal_reverse(exp.device, st, virtual, braking, d)
                    label = "ideal reverse"
                else:
                    program = read_program(exp.program_path(st, d), exp.device.encoder)
                    start = (braking.truth.end_phi, 0.0)
                    sim = run_program(
                        exp.device, st, virtual, program, start, direction=d,
                        motor=braking.truth.end_motor,  # the motor as warm as the braking left it
                    )
                    label = "reverse"
                log_path = exp.reverse_path(st, d)
            _write_log(exp, virtual, log_path, sim.log)
            summary = _summary(exp, st, label, log_path, sim, d)
            say(str(summary))
            summaries.append(summary)
    return summaries
