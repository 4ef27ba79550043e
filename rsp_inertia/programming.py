"""``rsp-inertia program``: each run's braking log in, its reverse pass's torque program out.

Reads device.toml and ``stageN/braking.csv`` (``_backward`` for a backward run) and writes
``stageN/program.csv`` atomically (rsp_inertia.ocp.program.make_program: reference,
feedforward torque and regulator gains at the encoder's rate); each program written is a
:class:`rsp_inertia.results.ProgramSummary`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from rsp_inertia.infra.files import check_writable
from rsp_inertia.ocp.program import TorqueProgram, make_program
from rsp_inertia.plant.experiment import open_experiment
from rsp_inertia.plant.logs import read_device_log, write_program
from rsp_inertia.results import ProgramSummary

__all__ = ["program", "program_summaries"]


def program_summaries(
    root: str | Path,
    stage: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[ProgramSummary]:
    """``rsp-inertia program``: stageN/braking.csv -> stageN/program.csv (written atomically).

    Reads only device.toml and the braking log. Nothing is written for a stage whose mirror
    the motor cannot drive (the error says what torque it needs).

    Parameters
    ----------
    root : str or pathlib.Path
        The experiment folder.
    stage : int, optional
        One stage (from 1); every stage (and each of its directions) by default.
    progress : callable, optional
        Called with each run's summary line (str) as soon as its program is written.

    Returns
    -------
    list of rsp_inertia.results.ProgramSummary
        One per program.csv written, in order.

    Raises
    ------
    InputError
        A missing or malformed braking log, an unwritable program.csv (found before any
        program is made), or a mirror the motor cannot drive.
    """
    exp = open_experiment(root)
    # Every program's file found writable before any is made (a run without its braking log
    # is refused, in order, by the reader below).
    for st in exp.stages(stage):
        for direction in exp.device.stages[st - 1].directions:
            if exp.braking_path(st, direction).is_file():
                check_writable(exp.program_path(st, direction))
    summaries = []
    for st in exp.stages(stage):
        for direction in exp.device.stages[st - 1].directions:
            path = exp.braking_path(st, direction)
            braking = read_device_log(path, exp.device, "braking", direction)
            result = make_program(exp.device, st, braking, str(path), direction=direction)
            out = exp.program_path(st, direction)
            write_program(out, result.program)
            summary = ProgramSummary(st, direction, out, result)
            if progress is not None:
                progress(str(summary))
            summaries.append(summary)
    return summaries


def program(
    root: str | Path,
    stage: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[TorqueProgram]:
    """``rsp-inertia program``: :func:`program_summaries`, each run's TorqueProgram only.

    Parameters
    ----------
    root : str or pathlib.Path
        The experiment folder.
    stage : int, optional
        One stage (from 1); every stage by default.
    progress : callable, optional
        Called with each run's summary line (str) as soon as its program is written.

    Returns
    -------
    list of rsp_inertia.ocp.program.TorqueProgram
        One per program.csv written, in order.
    """
    return [summary.details for summary in program_summaries(root, stage, progress)]
