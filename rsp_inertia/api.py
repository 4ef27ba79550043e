"""The Python API of rsp-inertia: the commands as functions, for scripts and notebooks.

Each function does what the command of the same name does (same files read and written,
same checks) and returns a result object instead of printing:

- ``str(result)`` is the text the command prints as its result;
- ``result.to_json()`` is a JSON document of it (for :func:`identify`, the text of
  ``EXP/result.json``);
- ``result.figures(folder)`` draws the command's PNG figures, where it has any, and
  ``result.draw()`` gives them as matplotlib figures, unwritten;
- the result is a view of the library's record, which it holds (``result.identification``,
  ``result.calibration``, ``result.plan``, ...) and reads its other fields from.

The result classes, one module per command, are in :mod:`rsp_inertia.results`; this
module re-exports them, so ``rsp_inertia.api.IdentifyResult`` and
``rsp_inertia.IdentifyResult`` are the same class.

Bad input raises :class:`~rsp_inertia.infra.errors.InputError`, whose message is the line
the command line prints after ``rsp-inertia: error:``; so does an argument of the wrong type
(None or a number for a path, the string "1" for a stage, a string for a number), with a line
naming the function and the argument. Nothing is printed: what the command
line shows while it works goes to the optional ``progress`` callable, one line (a ``str``)
at a time (rsp_inertia.infra.progress.lines_to: without it, to the progress installed around
the call, none by default).

This module is the package's lazy boundary: each function imports its command's module
when it is called, and the result classes load on first use (module ``__getattr__``), so
that ``import rsp_inertia`` and ``rsp-inertia --help`` load nothing heavy and each command
loads only what it needs (``check`` and ``combine`` neither CasADi's simulator nor
matplotlib). These, and rsp_inertia.__getattr__'s, are the only imports inside functions
in the package, each with its reason. User documentation: docs/api.md.
"""

from __future__ import annotations

import numbers
import os
from pathlib import Path
from typing import TYPE_CHECKING

from rsp_inertia.infra.errors import InputError  # public: raised by every function
from rsp_inertia.infra.progress import LineReceiver, lines_to
from rsp_inertia.public import API_NAMES, RESULT_CLASSES

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from rsp_inertia.results import (
        AxisDesignResult,
        CalibrateResult,
        CheckResult,
        CombineResult,
        ExportResult,
        IdentifyResult,
        PlanResult,
        ProgramResult,
        SimulateResult,
    )

__all__ = list(API_NAMES)
"""The package's public names without its version (rsp_inertia.public, which
rsp_inertia.__all__ is made from too)."""


def __getattr__(name: str):
    """The result classes on first use (PEP 562), kept in the module."""
    if name not in RESULT_CLASSES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    # numpy: the results import it to format their numbers; looking a function up must not
    from rsp_inertia import results

    value = getattr(results, name)
    globals()[name] = value
    return value


def _identify_figures(result: IdentifyResult) -> list[tuple[str, Figure]]:
    """An identify result's figures (rsp_inertia.plots.identify_figures), its drawer."""
    # matplotlib, the smoother and the virtual device: loaded only when figures are drawn
    # (identify itself draws none)
    from rsp_inertia.plots import identify_figures

    return identify_figures(result)


# --- arguments: the types a script may pass wrong ------------------------------------------


def _path(value: object, function: str, name: str = "path") -> Path:
    """``value`` as a path; anything but a str or path-like (None, a number) is refused with
    one line naming the function and the argument (InputError), not a TypeError deep down."""
    if isinstance(value, (str, os.PathLike)):
        return Path(value)
    raise InputError(
        f"{function}: {name}: must be a path (str or pathlib.Path), got {value!r}"
    )


def _paths(value: object, function: str, name: str) -> list[Path]:
    """One path, or a list or tuple of paths (one folder is not taken for its characters)."""
    if isinstance(value, (str, os.PathLike)):
        return [Path(value)]
    if isinstance(value, (list, tuple)):
        return [_path(item, function, f"{name}[{i}]") for i, item in enumerate(value)]
    raise InputError(
        f"{function}: {name}: must be a path or a list of paths (str or pathlib.Path), "
        f"got {value!r}"
    )


def _stage(value: object, function: str) -> int | None:
    """A stage number (an integer; None: every stage), or the one-line refusal of another
    type (the string "1", 1.5, True)."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise InputError(
            f"{function}: stage: must be an integer, the stage's number from 1 (None: every "
            f"stage), got {value!r}"
        )
    return int(value)


def _number(value: object, function: str, name: str) -> float | None:
    """A real number as float (None stays None), or the one-line refusal of another type."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{function}: {name}: must be a number, got {value!r}")
    return float(value)


def _flag(value: object, function: str, name: str) -> bool:
    """A bool, or the one-line refusal of another type (the string "no" is true)."""
    if not isinstance(value, bool):
        raise InputError(f"{function}: {name}: must be True or False, got {value!r}")
    return value


# --- identify and demo ----------------------------------------------------------------------


def identify(
    path: str | Path,
    *,
    progress: LineReceiver | None = None,
    coverage_factor: float = 2.0,
) -> IdentifyResult:
    """Identify the inertia tensor and centre of mass (``rsp-inertia identify EXP``).

    Reads ``EXP/device.toml``, every stage's ``braking.csv`` and ``reverse.csv`` (and
    ``calibration.toml`` and the pendulum logs when present) and writes ``EXP/result.json``
    (atomically), with the GUM statement ``expanded_uncertainty``: U = k u of every entry
    and centre-of-mass coordinate, the principal moments' and axes' Monte Carlo intervals.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder EXP.
    progress : callable, optional
        Called with each progress line (str) as the command prints it; silent by default.
    coverage_factor : float, optional
        k of the expanded uncertainties U = k u (default 2: a coverage probability of
        95.45 % for a normal distribution); a finite number above 0.

    Returns
    -------
    IdentifyResult
        The tensor, its standard deviations, the centre of mass, the warnings.

    Raises
    ------
    InputError
        A missing or malformed file, logs that do not overlap, too few turns for a node, a
        braking whose speed reverses, an ill-conditioned axis design, a coverage factor
        that is not a finite number above 0, ...

    Examples
    --------
    >>> result = rsp_inertia.identify("bench-A")    # doctest: +SKIP
    >>> print(result.tensor)                         # doctest: +SKIP
    >>> rsp_inertia.identify("bench-A", coverage_factor=3).expanded_uncertainty["k"]  # doctest: +SKIP
    3.0
    """
    # the estimation stack (scipy.stats, CasADi's model): only the commands that read logs
    from rsp_inertia.identifying import identify as run
    from rsp_inertia.results import IdentifyResult

    path = _path(path, "identify")
    with lines_to(progress):
        identification = run(path, coverage_factor)
    return IdentifyResult(identification, path, drawer=_identify_figures)


def demo(
    path: str | Path = "demo-experiment", *, progress: LineReceiver | None = None
) -> IdentifyResult:
    """The whole real-rig workflow on the virtual rig (``rsp-inertia demo [EXP]``).

    Builds ``EXP``, ``EXP/calibration/empty`` and ``EXP/calibration/reference`` (inputs
    already there are kept), runs every stage of all three both ways (braking, program,
    closed-loop reverse) and the pendulum runs, identifies without calibration, calibrates,
    identifies again and draws the figures. About 3 minutes on 2 cores.

    Parameters
    ----------
    path : str or pathlib.Path, optional
        The experiment folder (default ``demo-experiment``, relative to the working folder).
    progress : callable, optional
        Called with each line the command prints (str); silent by default.

    Returns
    -------
    IdentifyResult
        The calibrated identification, with ``truth`` set to the virtual body's entries in
        rig axes (rsp_inertia.virtual.config.placed_body): ``str(result)`` is the demo's
        table against the truth.

    Raises
    ------
    InputError
        An edited device.toml or virtual.toml that is not valid.

    Examples
    --------
    >>> result = rsp_inertia.demo("demo-experiment", progress=print)    # doctest: +SKIP
    """
    # everything: the demo runs every command and draws
    import numpy as np

    from rsp_inertia.plant.experiment import open_experiment
    from rsp_inertia.results import IdentifyResult
    from rsp_inertia.rig_demo import demo as run
    from rsp_inertia.virtual.config import experiment_virtual, placed_body

    path = _path(path, "demo")
    with lines_to(progress):
        result = run(path)
    exp = open_experiment(path)
    truth = np.array(placed_body(exp.device, experiment_virtual(exp)).inertia, dtype=float)
    return IdentifyResult(result, Path(path), truth, drawer=_identify_figures)


# --- simulate and program -------------------------------------------------------------------


def simulate(
    path: str | Path,
    stage: int | None = None,
    part: str = "braking",
    *,
    ideal: bool = False,
    direction: str | None = None,
    progress: LineReceiver | None = None,
) -> SimulateResult:
    """Run the virtual device and write the logs a rig would (``rsp-inertia simulate EXP``).

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder, with device.toml and virtual.toml.
    stage : int, optional
        One stage (from 1); every stage by default.
    part : {'braking', 'reverse', 'pendulum', 'pilot'}, optional
        'braking' writes ``stageN/braking.csv``; 'reverse' runs ``stageN/program.csv`` in
        closed loop and writes ``stageN/reverse.csv``; 'pendulum' one torsion-pendulum run
        per node (``stageN/pendulum_kK.csv``); 'pilot' ``stageN/pilot.csv`` (for
        :func:`plan`). Backward runs use the ``_backward`` files.
    ideal : bool, optional
        With ``part='reverse'``: the exact mirror of the braking on an ideal drive (no
        program needed).
    direction : {'forward', 'backward'}, optional
        Braking and reverse: only the runs in this direction; every direction of each
        stage by default.
    progress : callable, optional
        Called with each pass's line (str) as soon as its log is written.

    Returns
    -------
    SimulateResult
        One summary per log written.

    Raises
    ------
    InputError
        A bad ``part`` or ``direction``, ``ideal`` without ``part='reverse'``, no
        virtual.toml, a missing braking or program for the reverse, ...

    Examples
    --------
    >>> rsp_inertia.simulate("bench-A")                              # doctest: +SKIP
    >>> rsp_inertia.simulate("bench-A", part="reverse", ideal=True)  # doctest: +SKIP
    """
    # the virtual device (CasADi, scipy.optimize): only simulate runs it
    from rsp_inertia.results import SimulateResult
    from rsp_inertia.simulating import simulate as run

    path, stage = _path(path, "simulate"), _stage(stage, "simulate")
    ideal = _flag(ideal, "simulate", "ideal")
    with lines_to(progress):
        passes = run(path, stage, part, ideal=ideal, direction=direction)
    return SimulateResult(tuple(passes), Path(path))


def program(
    path: str | Path, stage: int | None = None, *, progress: LineReceiver | None = None
) -> ProgramResult:
    """Make the reverse pass's torque program from the braking (``rsp-inertia program EXP``).

    Reads ``device.toml`` and ``stageN/braking.csv``; writes ``stageN/program.csv``
    (atomically): reference, feedforward torque and regulator gains at the encoder's rate.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder.
    stage : int, optional
        One stage (from 1); every stage (and each of its directions) by default.
    progress : callable, optional
        Called with each run's line (str) as soon as its program is written.

    Returns
    -------
    ProgramResult
        One summary per program written.

    Raises
    ------
    InputError
        A missing or malformed braking log, or a mirror the motor cannot drive (the message
        says how much torque it needs, and where); nothing is written for that stage.

    Examples
    --------
    >>> print(rsp_inertia.program("bench-A"))    # doctest: +SKIP
    """
    # the optimal control problem (CasADi, the regulator's design): only program solves it
    from rsp_inertia.programming import program_summaries
    from rsp_inertia.results import ProgramResult

    path, stage = _path(path, "program"), _stage(stage, "program")
    with lines_to(progress):
        runs = program_summaries(path, stage)
    return ProgramResult(tuple(runs), Path(path))


# --- calibrate and plan ---------------------------------------------------------------------


def calibrate(
    path: str | Path,
    empty: str | Path,
    reference: str | Path | None = None,
    *,
    progress: LineReceiver | None = None,
) -> CalibrateResult:
    """Calibrate the rig from empty-fixture and reference-body runs (``rsp-inertia calibrate``).

    Fits the empty system's reduced inertia per stage and the fixture's gravity terms, and
    with a reference the drive's gains h_d, h_b (by the direction of power flow) and the
    encoder's error harmonics (orders 1 to 3), in one generalised least squares (repeated on
    the logs corrected with the encoder's estimate); from pendulum runs in both folders, the
    torsion stiffness. Writes ``EXP/calibration.toml`` (atomically) and, with encoder terms,
    the error curve ``EXP/encoder_error.png``.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder to calibrate (EXP).
    empty : str or pathlib.Path
        The experiment folder of the empty fixture (same stages as EXP), with its logs.
    reference : str or pathlib.Path, optional
        The experiment folder of the reference body, with ``reference.toml`` (same stages);
        without it the drive is taken as lossless with a torque gain of 1 and the encoder's
        error as device.toml states it (none: exact).
    progress : callable, optional
        Called with each progress line (str); silent by default.

    Returns
    -------
    CalibrateResult
        The drive's gains, the encoder's error, the empty system's inertia and the fixture's
        gravity terms, with their standard deviations.

    Raises
    ------
    InputError
        Folders whose stages differ from EXP's, a missing or unphysical reference.toml, bad
        logs; nothing is written then.

    Examples
    --------
    >>> rsp_inertia.calibrate("bench-A", "bench-A-empty", "bench-A-ref")    # doctest: +SKIP
    """
    # the estimation stack and matplotlib (the encoder's error curve)
    from rsp_inertia.calibrating import calibrate as run
    from rsp_inertia.calibrating import calibrate_result

    path, empty = _path(path, "calibrate"), _path(empty, "calibrate", "empty")
    if reference is not None:
        reference = _path(reference, "calibrate", "reference")
    with lines_to(progress):
        calibration = run(path, empty, reference)
    return calibrate_result(calibration, path)


def plan(
    path: str | Path,
    max_duration: float | None = None,
    *,
    rehearse: bool = True,
    two_level: bool = False,
    progress: LineReceiver | None = None,
) -> PlanResult:
    """Choose every stage's launch speed and braking torque (``rsp-inertia plan EXP``).

    From each stage's pilot run ``stageN/pilot.csv`` (else the guesses of device.toml's
    ``[plan]`` table), tries launch speeds and braking torques, keeps those within the
    motor's limits and the duration, and chooses the combination with the smallest
    predicted worst std of J_k. Writes them (and the release angle) into
    ``EXP/device.toml`` (atomically, comments kept) and draws ``EXP/plan.png``.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder.
    max_duration : float, optional
        s of motion for the whole experiment (default: device.toml ``[plan] max_duration``,
        else 120).
    rehearse : bool, optional
        Rehearse the chosen plan in closed loop on the nominal model (about 15 s) and
        predict the stds there (default); False: the ideal reverse's prediction only.
    two_level : bool, optional
        Plan two-level brakings (``--two-level``): each stage coasts for some turns, then
        brakes, so that identify measures the reverse pass's torque scale against the
        braking's (a warming motor whose temperature is not logged); the predicted stds
        include it. Writes ``braking_torque_2`` and ``braking_switch_turns`` too.
    progress : callable, optional
        Called with each progress line (str); silent by default.

    Returns
    -------
    PlanResult
        The protocol chosen per stage and the predicted stds.

    Raises
    ------
    InputError
        ``max_duration`` not > 0, no pilot run and no ``[plan]`` guess, a bad pilot log, or
        a stage that no protocol admits (the message names the binding limit); nothing is
        written then.

    Examples
    --------
    >>> rsp_inertia.plan("bench-A", max_duration=100, rehearse=False)    # doctest: +SKIP
    """
    # experiment design: the prediction, the rehearsal's closed loop, matplotlib
    from rsp_inertia.planning import plan as run

    path = _path(path, "plan")
    max_duration = _number(max_duration, "plan", "max_duration")
    rehearse = _flag(rehearse, "plan", "rehearse")
    two_level = _flag(two_level, "plan", "two_level")
    with lines_to(progress):
        return run(path, max_duration, rehearse=rehearse, two_level=two_level)


# --- check, report, create_experiment -------------------------------------------------------


def check(path: str | Path, *, calibration: bool = False) -> CheckResult:
    """Check an experiment folder before a run (``rsp-inertia check EXP``).

    Reads what a rig produces (device.toml, the logs, calibration.toml, reference.toml;
    never virtual.toml), without stopping at the first problem.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder.
    calibration : bool, optional
        ``path`` is a calibration folder (the empty fixture's runs, which calibrate reads;
        one with reference.toml is taken as one anyway), ``--calibration``: it needs no
        calibration.toml, and ``ready`` means ready for calibrate.

    Returns
    -------
    CheckResult
        Every finding, and whether the folder is ready for identify (a calibration folder:
        for calibrate), the command's exit status 0 or 1.

    Raises
    ------
    InputError
        The folder or its device.toml is missing or malformed.

    Examples
    --------
    >>> print(rsp_inertia.check("bench-A"))    # doctest: +SKIP
    """
    # identify's readers and checks (the estimation stack), not the simulator or matplotlib
    from rsp_inertia.checking import check as run

    return run(_path(path, "check"), _flag(calibration, "check", "calibration"))


def write_report(path: str | Path, pdf: bool = False, paper: str = "a4") -> Path:
    """Write ``EXP/report.html`` from an identified experiment (``rsp-inertia report EXP``).

    One self-contained, dated file (figures inlined, no network) that leads with a verdict:
    whether the folder still holds the inputs identify read (result.json's sha256 of each)
    and identify's warnings. Then the tensor, principal moments and axes and centre of mass
    with stds and 95% intervals, the axial moments, the uncertainty budget by source, the
    calibration, the protocol as stated and as logged, the figures the logs allow and the
    software. (Named ``write_report``, not ``report``: ``rsp_inertia.report`` is the module
    that writes it.)

    On a combine folder (``OUT`` with the body.json of :func:`combine`, no device.toml) the
    combined body's report: the tensor and the centre of mass (z_c too) in body axes, the
    mountings and their consistency, the results combined and their sha256.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder, with the result.json of :func:`identify`, or a combine folder.
    pdf : bool, optional
        Also print ``report.pdf`` beside it (headless Chromium; ``report --pdf``).
    paper : str, optional
        The PDF's paper: ``"a4"`` (default) or ``"letter"``.

    Returns
    -------
    pathlib.Path
        The report.html written.

    Raises
    ------
    InputError
        No result.json (run identify first), or one that identify did not write; no
        body.json in a combine folder; with ``pdf``, no Chromium on the PATH.

    Examples
    --------
    >>> rsp_inertia.write_report("bench-A")    # doctest: +SKIP
    PosixPath('bench-A/report.html')
    """
    # the report's figures and the logs' smoother (matplotlib, the estimation stack)
    from rsp_inertia.report import write_report as run

    return run(_path(path, "write_report"), _flag(pdf, "write_report", "pdf"), paper)


def create_experiment(path: str | Path) -> Path:
    """Create a virtual experiment: the paper's scenario (what ``rsp-inertia demo`` starts from).

    Writes ``device.toml`` (two stages of three nodes each, a 16-bit encoder at 1 kHz, a
    2 kg body) and ``virtual.toml`` (the true body, friction and noise of the virtual
    device) into ``path``. Files already there are kept, so an edited experiment is never
    overwritten.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder (created if needed).

    Returns
    -------
    pathlib.Path
        The experiment folder.

    Examples
    --------
    >>> exp = rsp_inertia.create_experiment("virtual-bench")    # doctest: +SKIP
    >>> rsp_inertia.simulate(exp)                               # doctest: +SKIP
    """
    # the default files and tomlkit: light, but create_experiment's alone
    from rsp_inertia.scenarios import create_default_experiment

    return create_default_experiment(_path(path, "create_experiment"))


# --- combine --------------------------------------------------------------------------------


def combine(
    paths: list[str | Path] | str | Path, out: str | Path, *, coverage_factor: float = 2.0
) -> CombineResult:
    """Combine several identified mountings of one body (``rsp-inertia combine EXP ... --out
    OUT``): the tensor and the centre of mass (x, y and z) in body axes -> ``OUT/body.json``.

    Each folder is an experiment that :func:`identify` has run, its device.toml's
    ``[mounting]`` giving how the body sat on the rig (docs/files.md); one generalised least
    squares over their results gives the body's tensor and centre of mass with their
    covariance, and a chi^2 test of whether the mountings agree (a body not seated as its
    mounting states is the usual cause when they do not).

    Parameters
    ----------
    paths : list of str or pathlib.Path, or one of them
        The mountings' experiment folders (one folder alone: a one-element list).
    out : str or pathlib.Path
        The folder to write body.json into (created if needed).
    coverage_factor : float, optional
        k of body.json's expanded uncertainties U = k u (default 2), as for :func:`identify`.

    Returns
    -------
    CombineResult
        ``str`` is the table the command prints; ``combination`` the estimate.

    Raises
    ------
    InputError
        No folder or one given twice, folders of different devices or masses, a folder
        without result.json or ``[body] mass``, mountings that cannot give z_c (the message
        says which rotation would), an output that cannot be written, a coverage factor that
        is not a finite number above 0.

    Examples
    --------
    >>> body = rsp_inertia.combine(["bench-A", "bench-A-x90"], "body")    # doctest: +SKIP
    >>> print(body)                                                        # doctest: +SKIP
    """
    # the mountings' least squares (numpy, scipy.linalg): not the simulator or matplotlib
    from rsp_inertia.combining import combine as run
    from rsp_inertia.results import CombineResult

    paths = _paths(paths, "combine", "paths")
    combination, path = run(paths, _path(out, "combine", "out"), coverage_factor)
    return CombineResult(combination, path)


# --- export ---------------------------------------------------------------------------------


def export(
    source: str | Path,
    out: str | Path,
    *,
    format: str = "json",  # named as the command line's --format
    frame: str | Path | None = None,
    mass: float | None = None,
    mass_std: float | None = None,
) -> ExportResult:
    """A result's mass properties in another frame, as JSON, CSV or URDF (``rsp-inertia export
    SRC --format F [--frame FRAME.toml] --out FILE``).

    Reads identify's result.json (rig axes, about the rig's centre) or combine's body.json
    (body axes, about the body frame's origin) and writes the mass, the centre of mass and
    the tensor about the frame's origin in the frame's axes, with the covariance carried
    through the rotation and the parallel-axis shift (docs/method.md, "Exporting in another
    frame"); URDF: an ``<inertial>`` element, the tensor about the centre of mass, the stds
    in a comment. The file is written atomically.

    Parameters
    ----------
    source : str or pathlib.Path
        SRC: a result.json, a body.json, or a folder holding one of them.
    out : str or pathlib.Path
        FILE to write.
    format : {'json', 'csv', 'urdf'}, optional
        ``--format`` (default 'json').
    frame : str or pathlib.Path, optional
        FRAME.toml: ``[frame] rotation`` (3 x 3, rows: the frame's axes in the source's axes)
        and ``origin`` (m, in the source's axes); default: the source's own axes and origin.
    mass : float, optional
        kg, ``--mass``: needed only when the source states no mass (the rig does not measure
        it; result.json's folder's device.toml ``[body] mass``, body.json's ``mass``).
    mass_std : float, optional
        kg, ``--mass-std``: the mass's std (default: the mass is taken as exact, with a note).

    Returns
    -------
    ExportResult
        The values in the frame with their covariance, and the file written.

    Raises
    ------
    InputError
        A source that is missing, not a result file or edited after it was written; a frame
        file that is not valid (a rotation that is not orthonormal with determinant +1); no
        mass; a result.json asked for what its missing z_c would give (URDF, a shifted
        origin); a bad ``format``; an output that cannot be written.

    Examples
    --------
    >>> rsp_inertia.export("body", "body.urdf", format="urdf", frame="cad.toml")  # doctest: +SKIP
    """
    # numpy and the geometry only: not the estimation stack, CasADi or matplotlib
    from rsp_inertia.exporting import export as run
    from rsp_inertia.results import ExportResult

    source, out = _path(source, "export", "source"), _path(out, "export", "out")
    if frame is not None:
        frame = _path(frame, "export", "frame")
    mass = _number(mass, "export", "mass")
    mass_std = _number(mass_std, "export", "mass_std")
    exported = run(source, out, format, frame, mass, mass_std)
    return ExportResult(exported, out, format)


# --- the report's verdicts (the command line's --strict; not in __all__) ---------------------


def report_verdict(path: str | Path) -> tuple[str, str | None]:
    """The verdicts ``rsp-inertia report EXP`` leads with, for ``report --strict``.

    Parameters
    ----------
    path : str or pathlib.Path
        The experiment folder, with the result.json of :func:`identify`.

    Returns
    -------
    (str, str or None)
        The software's verdict, 'ok' (green), 'warn' (amber: warnings, an overdue
        calibration) or 'stale' (red: inputs changed since identify, or not recorded, or
        result.json edited after it was written); the
        part's against spec.toml, 'pass', 'fail', 'indeterminate', or None without one.

    Raises
    ------
    InputError
        No result.json (run identify first), or one that identify did not write.

    Examples
    --------
    >>> rsp_inertia.api.report_verdict("bench-A")    # doctest: +SKIP
    ('ok', 'pass')
    """
    # the report's module (matplotlib, the estimation stack): only report --strict asks
    from rsp_inertia.report import report_verdict as run

    return run(_path(path, "report_verdict"))


# --- design (the command line's; not in __all__) --------------------------------------------


def axis_designs(
    paths: list[str | Path] | None = None, plot: str | Path | None = None
) -> AxisDesignResult:
    """The conditioning of axis designs and of mountings (``rsp-inertia design [EXP ...]``).

    Reports the icosahedron and the cone + z design at its best opening, and each folder's
    device.toml design; for several folders (mountings of one body) or one with
    ``[mounting]``, their conditioning for the centre of mass. Writes the paper's Fig. 1,
    1/cond(V) of the cone + z design against its opening, as a PNG.

    Parameters
    ----------
    paths : list of str or pathlib.Path, optional
        Experiment folders whose designs are reported too.
    plot : str or pathlib.Path, optional
        The PNG to write (default: the first folder's design.png, or ./design.png).

    Returns
    -------
    AxisDesignResult
        ``str`` is the report the command prints.

    Raises
    ------
    InputError
        A folder without a valid device.toml.

    Examples
    --------
    >>> print(rsp_inertia.api.axis_designs(["bench-A"]))    # doctest: +SKIP
    """
    # scipy.optimize (the best opening) and matplotlib: only design and the drawing commands
    from rsp_inertia.axis_designs import axis_designs as run

    return run(
        _paths(paths, "axis_designs", "paths") if paths is not None else None,
        None if plot is None else _path(plot, "axis_designs", "plot"),
    )
