"""Command line of rsp-inertia: parse arguments, call one library function, print.

Each command calls its function of the Python API (:mod:`rsp_inertia.api`, the same
function a script calls) and prints its progress lines and its result; ``design``, which has
no function among the package's names, calls :func:`rsp_inertia.api.axis_designs`.

A command's result goes to stdout and its warnings to stderr, one line each (``warning: ...``);
with ``--strict`` (identify, calibrate, combine, report) a result that warns, a report whose
verdict is not green, or a part that fails or is indeterminate against spec.toml exits with
status 3 once its files are written.

Bad input (:class:`rsp_inertia.infra.errors.InputError`) becomes one line on stderr and exit
status 2, and so does running out of memory (a MemoryError anywhere: the line names the
command, its experiment folders and their logs' rows); argparse's own usage errors exit with
2 as well. Every command's progress goes to a
:class:`rsp_inertia.infra.progress.TerminalProgress`: its lines on stdout and, for
``identify``, ``calibrate`` and ``demo``, the fraction done of their long work on stderr
when it is a terminal; in a pipe they print only their lines.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import rsp_inertia
from rsp_inertia import api
from rsp_inertia.infra import progress
from rsp_inertia.infra.errors import InputError
from rsp_inertia.plant.direction import Direction


def _terminal(fractions: bool = True):
    """The progress of a command's work (its lines; with ``fractions``, its fraction done),
    installed for the block."""
    return progress.reporting(progress.TerminalProgress(fractions=fractions))


def _cmd_demo(args: argparse.Namespace) -> None:
    with _terminal():
        rsp_inertia.demo(args.exp)


def _cmd_simulate(args: argparse.Namespace) -> None:
    with _terminal(fractions=False):
        rsp_inertia.simulate(
            args.exp, args.stage, args.part, ideal=args.ideal, direction=args.direction
        )


def _cmd_program(args: argparse.Namespace) -> None:
    with _terminal(fractions=False):
        rsp_inertia.program(args.exp, args.stage)


def _cmd_plan(args: argparse.Namespace) -> None:
    # No fraction line: plan's stages run in forked processes, which would share it.
    with _terminal(fractions=False):
        result = rsp_inertia.plan(
            args.exp, args.max_duration, rehearse=not args.no_rehearsal,
            two_level=args.two_level,
        )
    print(result)


STRICT = 3
"""The exit status of ``--strict`` when the result is not clean (:func:`_strict`)."""

UNDECIDED = ("fail", "indeterminate")
"""The part's verdicts against spec.toml that ``--strict`` does not pass: a script that
trusts exit 0 must be able to take it for a part shown to conform."""


def _warn(warnings: tuple[str, ...]) -> None:
    """A result's warnings on stderr, one line each (its result goes to stdout)."""
    for warning in warnings:
        print(f"warning: {warning}", file=sys.stderr)


def _strict(args: argparse.Namespace, faults: bool) -> int:
    """The exit status of a command that made its result: :data:`STRICT` with ``--strict``
    when the result has ``faults`` (a warning, a red or amber verdict, a part that failed or
    is indeterminate), else 0."""
    return STRICT if args.strict and faults else 0


def _cmd_calibrate(args: argparse.Namespace) -> int:
    with _terminal():
        result = rsp_inertia.calibrate(args.exp, args.empty, args.reference)
    print(result)
    _warn(result.warnings)
    return _strict(args, bool(result.warnings))


def _cmd_identify(args: argparse.Namespace) -> int:
    with _terminal():
        result = rsp_inertia.identify(args.exp, coverage_factor=args.coverage_factor)
    print(result)
    _warn(result.warnings)
    part = None if result.decision is None else result.decision.part
    return _strict(args, bool(result.warnings) or part in UNDECIDED)


def _cmd_check(args: argparse.Namespace) -> int:
    result = rsp_inertia.check(args.exp, calibration=args.calibration)
    print(result)
    return 0 if result.ready else 1


def _cmd_report(args: argparse.Namespace) -> int:
    out = rsp_inertia.write_report(args.exp, pdf=args.pdf, paper=args.paper)
    print(f"report -> {out}")
    if args.pdf:
        print(f"pdf -> {out.with_suffix('.pdf')}")
    if not args.strict:
        return 0
    verdict, part = api.report_verdict(args.exp)
    return _strict(args, verdict != "ok" or part in UNDECIDED)


def _cmd_combine(args: argparse.Namespace) -> int:
    result = rsp_inertia.combine(args.exp, args.out, coverage_factor=args.coverage_factor)
    print(result)
    _warn(result.warnings)
    return _strict(args, bool(result.warnings))


def _cmd_export(args: argparse.Namespace) -> None:
    result = rsp_inertia.export(
        args.src, args.out, format=args.format, frame=args.frame, mass=args.mass,
        mass_std=args.mass_std,
    )
    for note in result.exported.notes:
        print(f"note: {note}", file=sys.stderr)
    print(result)


def _cmd_design(args: argparse.Namespace) -> None:
    print(api.axis_designs(args.exp, args.plot))


EXIT_STATUSES = (
    "exit status: 0 done; 1 check: the folder is not ready for identify; 2 bad input (one "
    "line on stderr naming the file, the line or key and the fault; nothing written) or out "
    "of memory; 3 --strict: the result was written but has a warning, a red or amber report "
    "verdict, or a part that failed or is indeterminate against spec.toml; 130 interrupted "
    "(Ctrl-C)"
)
"""The exit statuses, as --help states them (docs/commands.md, Exit statuses)."""


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="rsp-inertia",
        description="Inertia tensor and centre of mass by reverse-symmetrical semi-program "
        "precession (RSP) on a biaxial gimbal.",
        epilog=EXIT_STATUSES,
    )
    parser.add_argument(
        "--version", action="version", version=f"%(prog)s {rsp_inertia.__version__}",
        help="print the installed version and exit",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("demo", help="build the default virtual experiment and run it")
    p.add_argument(
        "exp", nargs="?", type=Path, default=Path("demo-experiment"), metavar="EXP",
        help="experiment folder (default: ./demo-experiment); existing inputs are kept",
    )
    p.set_defaults(run=_cmd_demo)

    p = sub.add_parser("simulate", help="the virtual device writes a stage's logs")
    p.add_argument("exp", type=Path, metavar="EXP", help="experiment folder with virtual.toml")
    p.add_argument("--stage", type=int, help="one stage (from 1); default: all")
    p.add_argument(
        "--part", choices=("braking", "reverse", "pendulum", "pilot"), default="braking",
        help="braking pass, the reverse pass running stageN/program.csv in closed loop, "
        "the torsion-pendulum runs (one per node), or a pilot run (spin-up and coast, for "
        "plan)",
    )
    p.add_argument(
        "--ideal", action="store_true",
        help="with --part reverse: the exact mirror on an ideal drive (no program needed)",
    )
    p.add_argument(
        "--direction", choices=tuple(Direction), default=None,
        help="only the runs in this direction (default: every direction of each stage)",
    )
    p.set_defaults(run=_cmd_simulate)

    p = sub.add_parser(
        "plan",
        help="choose each stage's launch_speed and braking_torque -> EXP/device.toml",
    )
    p.add_argument("exp", type=Path, metavar="EXP", help="experiment folder")
    p.add_argument(
        "--max-duration", type=float, default=None, metavar="S",
        help="seconds of motion for the whole experiment (default: device.toml [plan] "
        "max_duration, else 120)",
    )
    p.add_argument(
        "--no-rehearsal", action="store_true",
        help="skip the closed-loop rehearsal of the chosen plan (about 15 s): the predicted "
        "stds are then an ideal reverse's, a closed loop's best case",
    )
    p.add_argument(
        "--two-level", action="store_true",
        help="plan two-level brakings (coast, then brake), which measure a torque scale that "
        "differs between the passes (a warming motor, no temperature logged)",
    )
    p.set_defaults(run=_cmd_plan)

    p = sub.add_parser("program", help="stageN/braking.csv -> stageN/program.csv")
    p.add_argument("exp", type=Path, metavar="EXP", help="experiment folder")
    p.add_argument("--stage", type=int, help="one stage (from 1); default: all")
    p.set_defaults(run=_cmd_program)

    p = sub.add_parser(
        "calibrate",
        help="empty-fixture and reference-body runs -> EXP/calibration.toml (tare, fixture, "
        "torque gain)",
    )
    p.add_argument("exp", type=Path, metavar="EXP", help="experiment folder to calibrate")
    p.add_argument(
        "--empty", type=Path, required=True, metavar="EMPTY",
        help="experiment folder of the empty fixture (same stages as EXP)",
    )
    p.add_argument(
        "--reference", type=Path, default=None, metavar="REF",
        help="experiment folder of the reference body, with REF/reference.toml (same stages); "
        "without it the torque gain is taken as 1",
    )
    _strict_option(p, "warns")
    p.set_defaults(run=_cmd_calibrate)

    # The commands whose only argument is the experiment folder.
    check_help = (
        "what EXP has, lacks or looks wrong before a run, one line each (exit 1: not ready "
        "for identify)"
    )
    report_help = (
        "EXP/result.json -> EXP/report.html (one self-contained test report): a verdict (inputs "
        "changed since identify? warnings?) and the part's decision, the result with 95%% "
        "intervals, record, budget, calibration, protocol, figures, signatures; on a combine "
        "folder (OUT/body.json) the combined body's report"
    )
    for name, run, text in (
        ("check", _cmd_check, check_help),
        ("identify", _cmd_identify, "all stages' logs -> EXP/result.json"),
        ("report", _cmd_report, report_help),
    ):
        p = sub.add_parser(name, help=text)
        p.add_argument("exp", type=Path, metavar="EXP", help="experiment folder")
        if name == "report":
            p.add_argument("--pdf", action="store_true",
                           help="also print report.pdf beside report.html (headless Chromium)")
            p.add_argument("--paper", choices=("a4", "letter"), default="a4",
                           help="the PDF's paper (default a4)")
        if name == "check":
            p.add_argument(
                "--calibration", action="store_true",
                help="EXP is a calibration folder (the empty fixture's runs, for calibrate; "
                "one with reference.toml is taken as one anyway): no calibration.toml needed",
            )
        elif name == "identify":
            _strict_option(p, "warns or the part fails or is indeterminate against spec.toml")
            p.add_argument(
                "--coverage-factor", type=float, default=2.0, metavar="K",
                help="k of the expanded uncertainties U = k u in result.json and the output "
                "(default 2: about 95 %%); the principal moments' and axes' Monte Carlo "
                "intervals use its coverage probability",
            )
        else:
            _strict_option(
                p, "verdict is red or amber, or the part fails or is indeterminate against "
                "spec.toml"
            )
        p.set_defaults(run=run)

    p = sub.add_parser(
        "combine",
        help="several identified mountings of one body (device.toml [mounting]) -> "
        "OUT/body.json: the tensor and the whole centre of mass in body axes, and whether "
        "the mountings agree",
    )
    p.add_argument("exp", type=Path, nargs="+", metavar="EXP", help="a mounting's folder")
    p.add_argument(
        "--out", type=Path, required=True, metavar="OUT",
        help="folder to write body.json into (created if needed)",
    )
    _strict_option(p, "warns (the mountings disagree, a mounting's inputs changed, ...)")
    p.add_argument(
        "--coverage-factor", type=float, default=2.0, metavar="K",
        help="k of body.json's expanded uncertainties U = k u (default 2: about 95 %%)",
    )
    p.set_defaults(run=_cmd_combine)

    p = sub.add_parser(
        "export",
        help="result.json or body.json -> FILE: mass, centre of mass and tensor in a frame "
        "(FRAME.toml), with their covariance, as json, csv or a URDF <inertial>",
    )
    p.add_argument(
        "src", type=Path, metavar="SRC",
        help="a result.json, a body.json, or a folder holding one of them",
    )
    p.add_argument(
        "--format", choices=("json", "csv", "urdf"), default="json",
        help="json (values, stds, covariance), csv (one row per quantity) or urdf (an "
        "<inertial> element about the centre of mass, stds in a comment); default json",
    )
    p.add_argument(
        "--frame", type=Path, default=None, metavar="FRAME.toml",
        help="[frame] rotation (rows: the frame's axes in the source's axes) and origin (m, "
        "in the source's axes); default: the source's own axes and origin",
    )
    p.add_argument(
        "--mass", type=float, default=None, metavar="KG",
        help="the body's mass, for a source that states none (the rig does not measure it)",
    )
    p.add_argument(
        "--mass-std", type=float, default=None, metavar="KG",
        help="the mass's standard deviation (default: the mass is taken as exact, with a note)",
    )
    p.add_argument("--out", type=Path, required=True, metavar="FILE", help="the file to write")
    p.set_defaults(run=_cmd_export)

    p = sub.add_parser("design", help="conditioning of axis designs (icosahedron, cone + z, EXP)")
    p.add_argument(
        "exp", nargs="*", type=Path, metavar="EXP",
        help="also report the design of these experiments' device.toml; several (mountings "
        "of one body) or one with [mounting]: their conditioning for the centre of mass",
    )
    p.add_argument(
        "--plot", type=Path, default=None, metavar="PNG",
        help="where to write 1/cond(V) against the opening angle "
        "(default: EXP/design.png, or ./design.png)",
    )
    p.set_defaults(run=_cmd_design)

    return parser


def _strict_option(parser: argparse.ArgumentParser, when: str) -> None:
    """``--strict`` on a command that writes a result: exit status 3 when the result ``when``."""
    parser.add_argument(
        "--strict", action="store_true",
        help=f"exit with status 3 (the result still written) when the result {when}",
    )


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``rsp-inertia`` console script; returns the exit status."""
    parser = _parser()
    if not (sys.argv[1:] if argv is None else argv):
        # No command: what there is to run, rather than argparse's "COMMAND is required".
        parser.print_help(sys.stderr)
        return 2
    args = parser.parse_args(argv)
    try:
        status = args.run(args)
    except InputError as error:
        print(f"rsp-inertia: error: {error}", file=sys.stderr)
        return 2
    except MemoryError:
        print(f"rsp-inertia: error: {_out_of_memory(args)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        # Every output is written atomically (rsp_inertia.infra.files.write_atomic): an
        # interrupted command leaves the files it had not finished as they were.
        print(f"rsp-inertia: interrupted: {args.command} stopped; nothing half-written",
              file=sys.stderr)
        return 130
    return status or 0


def _out_of_memory(args: argparse.Namespace) -> str:
    """The line for a command that ran out of memory: what it was processing (its experiment
    folders and their logs' rows) and what to do."""
    folders = []
    for name in ("exp", "empty", "reference"):
        value = getattr(args, name, None)
        folders += [Path(v) for v in (value if isinstance(value, list) else [value]) if v]
    rows = sum(_rows(path) for folder in folders for path in folder.glob("stage*/*.csv"))
    where = " and ".join(str(folder) for folder in folders) or "its inputs"
    return (
        f"out of memory while running {args.command} on {where} (the logs have {rows} rows); "
        "free memory or use a machine with more, or log shorter passes"
    )


def _rows(path: Path) -> int:
    """Lines of a log after its header, counted in pieces (a log may be hundreds of MB)."""
    lines = 0
    try:
        with open(path, "rb") as file:
            while piece := file.read(1 << 20):
                lines += piece.count(b"\n")
    except OSError:
        return 0
    return max(lines - 1, 0)


if __name__ == "__main__":
    sys.exit(main())
