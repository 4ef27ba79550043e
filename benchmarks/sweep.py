"""Accuracy and speed sweep: RSP against the torsion pendulum on the virtual device.

The default grid of :func:`benchmarks.cases.default_cases` (friction x0, x1, x10, x100 times
12-, 16- and 20-bit encoders times seeds at a 3 mm centre-of-mass offset, and offsets of 0
and 10 mm at friction x1 and x10) and the sensitivity study
(:func:`benchmarks.sensitivity.default_perturbations`), each case end to end on local
processes or a Dask cluster, one cached file per case (an interrupted sweep resumes; cases
made by other code run again). Writes accuracy.md, accuracy.png, speed.md and
sensitivity.png into ``--out`` (default benchmarks/results/) with the command that made
them. ``make bench`` runs it with the defaults.

    python -m benchmarks.sweep [--quick] [--seeds N] [--jobs N] [--scheduler ADDRESS] [--out DIR]

Exit status: 0 done, 1 a case crashed (a bug: named on stderr and in accuracy.md, not cached),
2 bad input (one line on stderr).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from benchmarks import RESULTS
from benchmarks.cases import default_cases
from benchmarks.report import SweepReport, write_report
from benchmarks.scheduling import run_sweep
from benchmarks.sensitivity import default_perturbations
from benchmarks.tables import command_line
from rsp_inertia.infra.errors import InputError

__all__ = ["main", "sweep"]

PROGRAM = "python -m benchmarks.sweep"


def sweep(
    seeds: int = 2,
    quick: bool = False,
    scheduler: str | None = None,
    jobs: int = -1,
    out: str | os.PathLike = RESULTS,
    command: str = PROGRAM,
    progress: bool = True,
) -> SweepReport:
    """The default sweep (or the quick one) and its report in ``out``.

    Parameters
    ----------
    seeds : int
        Seeds per friction x bits (ignored with ``quick``, which runs one).
    quick : bool
        Friction {1, 10} x 16 bits x 1 seed, without the sensitivity study.
    scheduler, jobs, progress
        As for :func:`benchmarks.scheduling.run_sweep`.
    out : path
        Results folder: cases/ (one JSON per case, reused), accuracy.md, accuracy.png,
        speed.md, sensitivity.png.
    command : str
        The command line to record in the report.
    """
    cases: list = default_cases(seeds, quick)
    if not quick:
        cases += default_perturbations()
    rows = run_sweep(cases, out, scheduler=scheduler, jobs=jobs, progress=progress)
    return write_report(rows, out, command)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROGRAM, description=__doc__.split("\n\n")[0].replace("\n", " ")
    )
    parser.add_argument("--seeds", type=int, default=2, metavar="N", help="seeds per cell (default 2)")
    parser.add_argument(
        "--quick", action="store_true",
        help="friction x1 and x10, 16 bits, one seed, no sensitivity study",
    )
    parser.add_argument(
        "--scheduler", metavar="ADDRESS",
        help="run the cases on a Dask cluster (tcp://host:8786) instead of local processes",
    )
    parser.add_argument(
        "--jobs", type=int, default=-1, metavar="N",
        help="local processes (default -1: one per core; 1: in this process)",
    )
    parser.add_argument(
        "--out", type=Path, default=RESULTS, metavar="DIR",
        help="results folder: cases/*.json (reused: an interrupted sweep resumes), "
        "accuracy.md, accuracy.png, speed.md, sensitivity.png (default: benchmarks/results)",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the sweep from the command line; return the exit status."""
    args = _parser().parse_args(argv)
    # The arguments that shape the results (not --jobs, --scheduler), so the default run
    # writes `--seeds 2` whether typed or not.
    shown = ["--quick"] if args.quick else ["--seeds", str(args.seeds)]
    if args.out.resolve() != RESULTS.resolve():
        shown += ["--out", str(args.out)]
    command = command_line("sweep", shown)
    try:
        report = sweep(
            seeds=args.seeds,
            quick=args.quick,
            scheduler=args.scheduler,
            jobs=args.jobs,
            out=args.out,
            command=command,
        )
    except InputError as error:
        print(f"{PROGRAM}: error: {error}", file=sys.stderr)
        return 2
    print(report.table)
    print("results -> " + ", ".join(str(path) for path in report.paths))
    if report.crashed:
        print(
            f"{PROGRAM}: {len(report.crashed)} case(s) crashed (bugs, see accuracy.md; not "
            f"cached): {', '.join(report.crashed)}",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
