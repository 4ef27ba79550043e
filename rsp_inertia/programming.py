"""``rsp-inertia program``: each run's braking log in, its reverse pass's torque program out.

Reads device.toml and ``stageN/braking.csv`` (``_backward`` for a backward run) and writes
``stageN/program.csv`` atomically (rsp_inertia.ocp.program.make_program: reference,
feedforward torque and regulator gains at the encoder's rate); each program written is a
:class:`rsp_inertia.results.ProgramSummary`.
"""

from __future__ import annotations

from pathlib import Path

from rsp_inertia.infra.files import check_writable
from rsp_inertia.infra.progress import say
from rsp_inertia.ocp.program import TorqueProgram, make_program
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.logs import read_device_log, write_program
from rsp_inertia.results.program import ProgramSummary

__all__ = ["program", "program_summaries"]


def program_summaries(
    path: str | Path,
    stage: int | None = None,
) -> list[ProgramSummary]:
    """The command behind :func:`rsp_inertia.api.program`, documented there; returns the
    runs' records (rsp_inertia.results.ProgramSummary), which the API holds in its
    ProgramResult. Every program.csv is found writable before any program is made."""
    exp = open_experiment(path)
    # Every program's file found writable before any is made (a run without its braking log
    # is refused, in order, by the reader below).
    for st in exp.stages(stage):
        for direction in exp.device.stages[st - 1].directions:
            if exp.braking_path(st, direction).is_file():
                check_writable(exp.program_path(st, direction))
    summaries = []
    for st in exp.stages(stage):
        for direction in exp.device.stages[st - 1].directions:
            braking_path = exp.braking_path(st, direction)
            braking = read_device_log(braking_path, exp.device, "braking", direction)
            result = make_program(exp.device, st, braking, str(braking_path), direction=direction)
            out = exp.program_path(st, direction)
            write_program(out, result.program)
            summary = ProgramSummary(st, direction, out, result)
            say(str(summary))
            summaries.append(summary)
    return summaries


def program(
    path: str | Path,
    stage: int | None = None,
) -> list[TorqueProgram]:
    """:func:`program_summaries`, each run's library record only (the command behind
    :func:`rsp_inertia.api.program`, documented there)."""
    return [summary.details for summary in program_summaries(path, stage)]
